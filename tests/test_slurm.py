"""The SLURM profile: a dry run resolves the whole DAG, and a real run submits its jobs through
`sbatch` and follows them with `sacct`/`squeue`, here stand-ins on PATH (tests/slurm/standin.py)
that record their arguments and run each job locally."""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
STANDIN = ROOT / "tests" / "slurm" / "standin.py"
TOOLS = ("sbatch", "srun", "squeue", "sacct", "sinfo", "sacctmgr", "sshare", "scontrol", "scancel")

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("snakemake_executor_plugin_slurm") is None,
    reason="the SLURM executor plugin is not installed (bash scripts/setup.sh --slurm, or pip install -e '.[slurm]')")


@pytest.fixture
def cluster(tmp_path: Path) -> tuple[Path, dict]:
    """A working folder, and an environment whose PATH starts with the SLURM stand-ins."""
    bin_dir, state, work = tmp_path / "bin", tmp_path / "slurm", tmp_path / "work"
    for folder in (bin_dir, state, work):
        folder.mkdir()
    for tool in TOOLS:
        (bin_dir / tool).symlink_to(STANDIN)
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}", GEOCODE_SLURM_STANDIN=str(state))
    return work, env


def snakemake(work: Path, env: dict, *args: str, config: tuple[str, ...] = ()) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
           "--profile", str(ROOT / "profiles" / "slurm"), *args, "--config", "profile=smoke", *config]
    return subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True, timeout=600)


def calls(env: dict, tool: str) -> list[list[str]]:
    lines = (Path(env["GEOCODE_SLURM_STANDIN"]) / "calls.jsonl").read_text().splitlines()
    return [call[1:] for call in map(json.loads, lines) if call[0] == tool]


def test_the_slurm_profile_plans_the_whole_dag_without_submitting(cluster):
    work, env = cluster
    result = snakemake(work, env, "-n", "results/smoke/tables")
    assert result.returncode == 0, result.stderr[-3000:]
    assert "rule train" in result.stdout + result.stderr
    assert not (Path(env["GEOCODE_SLURM_STANDIN"]) / "jobs.jsonl").exists()


def test_the_slurm_profile_submits_real_jobs_with_their_resources(cluster):
    work, env = cluster
    target = "build/programs/vase.manifest.json"
    result = snakemake(work, env, target, "--slurm-init-seconds-before-status-checks", "1")
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads((work / target).read_text())["domain"] == "vase"
    (submitted,) = calls(env, "sbatch")
    text = " ".join(submitted)
    assert "-p cpu" in text and "-t 120" in text and "--mem 2000" in text
    assert "rule_program_wildcards_vase" in text
    assert calls(env, "sacct") or calls(env, "squeue")


def test_the_slurm_profile_reconstructs_a_collection_one_job_per_batch(smoke_run, cluster):
    """results/smoke/reconstruct/<name>/ on the cluster: a job per batch, then the page job."""
    from test_workflow import COLLECTION, COLLECTION_DIR, check_collection, collection_run

    work, env = cluster
    collection_run(smoke_run, work / "run")
    result = snakemake(work / "run", env, str(COLLECTION_DIR), "--slurm-init-seconds-before-status-checks", "1",
                       config=(COLLECTION,))
    assert result.returncode == 0, result.stderr[-3000:]
    submitted = [re.search(r"--comment rule_(\S+?)_wildcards", " ".join(call))[1] for call in calls(env, "sbatch")]
    check_collection(work / "run", submitted, batches=2)
