"""The Snakemake workflow: lint, dry runs, bad config, and a real smoke run to results/smoke/tables.

Every run happens in a temporary working directory, so a user's data/ and results/ are never
touched. The smoke run is real: Blender builds and exports vases, renders Freestyle sketches,
a model trains for an epoch, predictions are rebuilt and measured.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import trimesh
import yaml

from geocode.steps.dataset import first_draws

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ["--config", "profile=smoke"]


def snakemake(cwd: Path, *args: str, check: bool = True, **popen) -> subprocess.CompletedProcess:
    cmd = snakemake_cmd(*args)
    result = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, **popen)
    if check and result.returncode != 0:
        raise AssertionError(f"{' '.join(cmd)} failed:\n{result.stdout[-3000:]}\n{result.stderr[-6000:]}")
    return result


def snakemake_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "snakemake", "-s", str(ROOT / "workflow" / "Snakefile"),
            "--workflow-profile", str(ROOT / "profiles" / "default"), *args]


def test_lint_is_clean(tmp_path):
    """Clean but for one lint that does not apply: rules run in the project's own virtual
    environment (scripts/setup.sh), not in per-rule conda environments."""
    out = snakemake(tmp_path, "--lint", check=False)
    lints = [line.strip() for line in (out.stdout + out.stderr).splitlines() if line.strip().startswith("* ")]
    assert lints, "the linter printed nothing: is it still reading the workflow?"
    assert {line for line in lints if "conda environment or container" not in line} == set()


def test_paper_profile_plans_the_whole_dag(tmp_path):
    out = snakemake(tmp_path, "-n", "results/paper/tables", "--config", "profile=paper",
                    "eval={variants: [joint, regression]}").stdout
    assert "runs/paper/vase/regression/checkpoints/best.ckpt" in out
    for rule in ("program", "sample", "export", "sketch", "points", "train", "simplify",
                 "predict", "rebuild", "metrics", "tables"):
        assert f"rule {rule}:" in out or f"{rule} " in out, rule


def test_default_run_plans_huang_everywhere_and_the_chair_ablations(tmp_path):
    out = snakemake(tmp_path, "-n", "results/tables", "--config", "domains=[vase,chair]").stdout
    for run in ("vase/joint", "vase/huang", "chair/joint", "chair/huang", "chair/regression", "chair/separate"):
        assert f"runs/mini/{run}/eval/metrics.parquet" in out, run
    assert "runs/mini/vase/regression" not in out and "runs/mini/vase/separate" not in out
    bad = snakemake(tmp_path, "-n", "results/tables", "--config", "eval={variants: [joint, hwang]}", check=False)
    assert bad.returncode != 0
    assert ("eval.variants=hwang: unknown model variant; use one of huang, joint, regression, separate"
            in bad.stdout + bad.stderr)


def test_bad_config_stops_before_any_job_with_one_line(tmp_path):
    result = snakemake(tmp_path, "-n", "results/tables", "--config", "data={shards: 0}", check=False)
    assert result.returncode != 0
    assert "data.shards=0: out of range; give a whole number >= 1" in result.stdout + result.stderr
    assert not (tmp_path / "data").exists()


def file_hashes(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_smoke_run_makes_the_dataset(smoke_run):
    split = smoke_run / "data" / "smoke" / "vase" / "train"
    ids = pd.read_parquet(split / "recipes.parquet")["id"].tolist()
    drawn = {ids[k] for k in first_draws(ids, (1, 2))}     # data.cloud_factor 2: the first draw of each class
    assert len(ids) == 12 and 0 < len(drawn) < len(ids)
    for i in ids:
        for suffix in (".obj", ".yaml", ".labels.yaml", ".parts.npy"):
            assert (split / "shapes" / f"{i}{suffix}").exists()
        clouds = np.load(split / "points" / f"{i}.npz")
        assert clouds["fps"].shape == (300, 3) and clouds["random"].shape == (300, 3)
        cameras = ["az35", "az55"] if i in drawn else []
        assert sorted(p.stem.split("_")[-1] for p in (split / "sketches").glob(f"{i}_*.png")) == cameras
    test = smoke_run / "data" / "smoke" / "vase" / "test"      # the novel camera is drawn for the test split only
    test_id = pd.read_parquet(test / "recipes.parquet")["id"].iloc[0]
    assert len(list((test / "sketches").glob(f"{test_id}_*.png"))) == 3
    assert not list(smoke_run.rglob("*.tmp"))


def test_smoke_run_reaches_the_tables(smoke_run):
    assert not (smoke_run / "results" / "tables").exists()     # the default profile's: never a smoke run's
    tables = smoke_run / "results" / "smoke" / "tables"
    assert (smoke_run / "results" / "smoke" / "report" / "index.html").exists()
    assert (tables / "README.md").exists()
    frame = pd.read_csv(tables / "pc_vs_sketch.csv", comment="#", index_col=0)
    metrics = pd.read_parquet(smoke_run / "runs" / "smoke" / "vase" / "joint" / "eval" / "metrics.parquet")

    def mean_over_shapes(condition: str) -> float:   # a cell: the mean over test shapes (6 digits in the CSV)
        return metrics[metrics.condition == condition].groupby("id").chamfer.mean().mean()

    assert frame.loc["vase", "pc"] == pytest.approx(mean_over_shapes("pc"), rel=1e-5)
    assert frame.loc["vase", "pc (paper)"] == 0.00264
    assert "vase mean-shape baseline" in frame.index
    # the smoke profile fits the clean clouds' predictions of 3 of its 4 shapes: never further from the input
    assert frame.loc["vase", "pc n"] == 4 and frame.loc["vase", "pc + fit n"] == 3
    fits = pd.concat(pd.read_parquet(p) for p in (smoke_run / "runs" / "smoke" / "vase" / "joint" / "eval"
                                                  / "rebuilt").glob("fit-*.parquet"))
    assert len(fits) == 6 and (fits.after <= fits.before).all() and (fits.evaluations <= 20).all()
    assert set(fits.condition) == {"pc-fit", "sketch-az35-fit"}
    assert frame.loc["vase", "sketch + fit n"] == 3
    assert frame.loc["vase", "sketch + fit"] == pytest.approx(mean_over_shapes("sketch-az35-fit"), rel=1e-5)
    assert frame.loc["vase", "pc + fit"] == pytest.approx(mean_over_shapes("pc-fit"), rel=1e-5)
    cameras = pd.read_csv(tables / "camera_angles.csv", comment="#", index_col=0)
    assert cameras.loc["vase", "angle 1 + fit n"] == 3
    assert "line drawing is nearest" in (tables / "camera_angles.md").read_text()
    for name in ("camera_angles", "simplified", "sparse", "noise", "stability"):
        assert (tables / f"{name}.md").exists(), name
    assert "profile smoke" in (tables / "pc_vs_sketch.md").read_text()
    huang = pd.read_csv(tables / "vs_huang.csv", comment="#", index_col=0)    # the smoke run trains huang too
    assert list(huang.index) == ["vase Huang et al. 2017", "vase ours"]
    assert huang.loc["vase ours", "novel camera n"] == 4 and 0 <= huang.loc["vase ours", "novel camera p"] <= 1
    predictions = pd.read_parquet(smoke_run / "runs" / "smoke" / "vase" / "huang" / "eval" / "predictions.parquet")
    assert set(predictions.modality) == {"sketch"} and set(predictions.source) == {"test"}   # clean sketches only


@pytest.mark.parametrize("bench, split", [
    (["turns", "vase", "-n", "1", "--budget", "3"], "val"),
    (["fit", "vase", "--modality", "sketch", "-n", "1", "--budget", "12"], "val"),
    (["fit", "vase", "--modality", "sketch", "--camera", "novel", "-n", "1", "--budget", "12"], "val"),
    (["fit", "vase", "-n", "2", "--budget", "5", "--split", "test"], "test"),
])
def test_benchmarks_of_the_pose_and_the_fits_run_on_a_trained_model(smoke_run, monkeypatch, capsys, bench, split):
    """On the validation split unless told; the dataset draws the validation shapes from the
    trained cameras only, so the novel camera's drawings are rendered for the benchmark."""
    import json

    import geocode.blender.sketch
    import geocode.steps.evaluate
    from geocode.cli import main

    chosen, rendered = [], []
    split_ids, sketch_mesh = geocode.steps.evaluate.split_ids, geocode.blender.sketch.sketch_mesh
    module = {"turns": "geocode.steps.evaluate", "fit": "geocode.bench.fit"}[bench[0]]
    module = "geocode.bench.sketch_fit" if "sketch" in bench else module
    monkeypatch.setattr(f"{module}.split_ids", lambda cfg, domain, s: chosen.append(s) or split_ids(cfg, domain, s))
    monkeypatch.setattr(geocode.blender.sketch, "sketch_mesh",
                        lambda mesh, out, cameras, *a: rendered.extend(cameras) or sketch_mesh(mesh, out, cameras, *a))
    monkeypatch.chdir(smoke_run)
    assert main(["bench", *bench, "--json", "profile=smoke"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert chosen == [split] and result["split"] == split
    assert [c.name for c in rendered] == (["az15"] if "novel" in bench else [])
    if bench[0] == "turns":     # five turns of one validation shape, each fitted in its own pose
        assert result["shapes"] == 1 and len(result["files"][0]["distances"]) == 5
        assert result["files"][0]["shape"].startswith("val-")
        distances = result["files"][0]["distances"]   # each turn's fitted distance: the worst over the best
        ratio = max(distances) / min(distances)    # of the distances rounded to 6 decimals
        assert result["worst_ratio"] == result["files"][0]["ratio"] == pytest.approx(ratio, rel=1e-2)
        assert result["median_distance"] == sorted(distances)[2]
    else:
        option = {flag: int(value) for flag, value in zip(bench, bench[1:], strict=False) if flag in ("-n", "--budget")}
        assert result["shapes"] == option["-n"] and result["budget"] == option["--budget"]
        assert 0 < result["chamfer_before"] and 0 < result["chamfer_after"]
    if bench[0] == "fit":   # each shape's distances, for paired comparisons
        shapes = result["per_shape"]
        assert len({s["shape"] for s in shapes}) == len(shapes) == option["-n"]
        assert shapes[0]["shape"].startswith(f"{split}-")
        for key in ("chamfer_before", "chamfer_after"):
            assert result[key] == pytest.approx(np.mean([s[key] for s in shapes]), abs=1e-6)


def test_interrupted_dataset_run_resumes_to_identical_outputs(smoke_run, tmp_path):
    """Kill snakemake while it exports and renders, run it again: the same bytes as the run
    that was never interrupted."""
    target = "data/smoke/vase/dataset.done"
    # As in a terminal: SIGINT handled by default even where the test runner was started
    # in the background (which makes a shell ignore SIGINT in what it starts).
    proc = subprocess.Popen(snakemake_cmd("-j2", target, *SMOKE), cwd=tmp_path,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    sketches = tmp_path / "data" / "smoke" / "vase"
    deadline = time.time() + 300
    while time.time() < deadline and len(list(sketches.rglob("*.png"))) < 5 and proc.poll() is None:
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)             # Ctrl-C: the whole process group
    try:
        proc.wait(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        snakemake(tmp_path, "--unlock", target, *SMOKE)
    assert not (tmp_path / target).exists(), "the run finished before it could be interrupted"
    snakemake(tmp_path, "-j2", target, *SMOKE)
    ours = file_hashes(tmp_path / "data" / "smoke" / "vase")
    theirs = file_hashes(smoke_run / "data" / "smoke" / "vase")
    for split in ("test-s10",):                    # made by evaluation, not by this target
        theirs = {k: v for k, v in theirs.items() if not k.startswith(split)}
    assert ours == theirs


def test_a_slice_of_the_paper_profile_runs_with_the_papers_settings(tmp_path):
    """The paper profile's own settings (clouds of 1500 FPS + 1500 random points, batch 33, lr 1e-2
    with StepLR, 600 epochs planned, the argmax read) on one batch of vases: its data and one epoch."""
    snakemake(tmp_path, "-j2", "runs/paper/vase/joint/checkpoints/best.ckpt", "--config", "profile=paper",
              "domains=[vase]", "data={max_shapes: {train: 33, val: 4, test: 4}, shards: 1}",
              "train={max_epochs: 1}")
    split = tmp_path / "data" / "paper" / "vase" / "train"
    ids = pd.read_parquet(split / "recipes.parquet")["id"].tolist()
    assert len(ids) == 33
    clouds = np.load(split / "points" / f"{ids[0]}.npz")
    assert clouds["fps"].shape == (1500, 3) and clouds["random"].shape == (1500, 3)
    run = tmp_path / "runs" / "paper" / "vase" / "joint"
    config = yaml.safe_load((run / "config.yaml").read_text())
    assert (config["train"]["batch_size"], config["train"]["lr"], config["train"]["schedule"]) == (33, 0.01, "step")
    assert config["data"]["variations"] == {"train": 30, "val": 3, "test": 3} and config["eval"]["decode"] == "argmax"
    summary = json.loads((run / "summary.json").read_text())
    assert summary["epochs"] == 1


# -- a collection of one's own files: results/smoke/reconstruct/<name>/ ------------------------------

COLLECTION = "reconstruct={scans: {domain: vase, inputs: scans, batch: 2, budget: 3}}"
COLLECTION_DIR = Path("results/smoke/reconstruct/scans")


def collection_run(smoke_run: Path, work: Path) -> Path:
    """A copy of the smoke run (its model trained) with a folder scans/ of three vases, two of
    one stem: other.obj, twin.obj, twin.ply (two batches of 2 and 1)."""
    shutil.copytree(smoke_run, work, symlinks=True)
    shapes = sorted((work / "data" / "smoke" / "vase" / "test" / "shapes").glob("*.obj"))
    scans = work / "scans"
    scans.mkdir()
    shutil.copy(shapes[0], scans / "other.obj")
    shutil.copy(shapes[1], scans / "twin.obj")
    trimesh.load(shapes[1], force="mesh").export(scans / "twin.ply")
    return work


def check_collection(work: Path, jobs: list[str], batches: int) -> None:
    """Every input's outputs under the names `geocode reconstruct scans -o ...` gives, one row
    each in summary.csv, their pictures on the page; the rules of the `jobs` run: `batches`
    batch jobs and the page, nothing else (the model was not trained again)."""
    out = work / COLLECTION_DIR
    for stem in ("other", "twin-obj", "twin-ply"):
        for suffix in (".yaml", ".obj", ".in-place.obj", ".png", ".blend"):
            assert (out / f"{stem}{suffix}").is_file(), f"{stem}{suffix}"
    summary = pd.read_csv(out / "summary.csv")
    assert list(summary["name"]) == ["other.obj", "twin.obj", "twin.ply"] and summary["error"].isna().all()
    assert (summary["after"] <= summary["before"]).all()
    assert len(list((out / "page").glob("*.png"))) == 6
    assert "twin.ply" in (out / "index.html").read_text()
    assert sorted(jobs) == ["reconstruct_batch"] * batches + ["reconstruct_page"], jobs


def rules_run(result: subprocess.CompletedProcess) -> list[str]:
    """The rule of each job a local run ran, from its log."""
    return [line.split()[1].rstrip(":") for line in (result.stdout + result.stderr).splitlines()
            if line.startswith(("rule ", "localrule "))]


def test_a_collection_is_reconstructed_in_batches_and_a_rerun_redoes_only_what_is_missing(smoke_run, tmp_path):
    work = collection_run(smoke_run, tmp_path / "work")
    target = str(COLLECTION_DIR)
    first = snakemake(work, "-j2", target, "--config", "profile=smoke", COLLECTION)
    check_collection(work, rules_run(first), batches=2)
    records = work / "runs" / "smoke" / "reconstruct" / "scans"
    kept = (records / "batch-0.json").stat().st_mtime_ns
    # as a run stopped in batch 1 (its record not yet written), before the page
    (records / "batch-1.json").unlink()
    shutil.rmtree(work / COLLECTION_DIR)
    again = snakemake(work, "-j2", target, "--config", "profile=smoke", COLLECTION)
    check_collection(work, rules_run(again), batches=1)
    assert (records / "batch-0.json").stat().st_mtime_ns == kept
    # a file added first shifts every batch: their jobs run again, but only the new file is reconstructed
    done = {p.name: p.stat().st_mtime_ns for p in (records / "done").iterdir()}
    assert len(done) == 3
    shutil.copy(work / "scans" / "other.obj", work / "scans" / "another.obj")
    shutil.rmtree(work / COLLECTION_DIR)
    added = snakemake(work, "-j2", target, "--config", "profile=smoke", COLLECTION)
    assert sorted(rules_run(added)) == ["reconstruct_batch"] * 2 + ["reconstruct_page"]
    now = {p.name: p.stat().st_mtime_ns for p in (records / "done").iterdir()}
    assert len(now) == 4 and all(now[name] == t for name, t in done.items())
    summary = pd.read_csv(work / COLLECTION_DIR / "summary.csv")
    assert list(summary["name"]) == ["another.obj", "other.obj", "twin.obj", "twin.ply"]
    assert (work / COLLECTION_DIR / "another.obj").is_file() and summary["error"].isna().all()


def test_the_real_shape_table_scores_each_file_against_the_baselines(smoke_run, tmp_path):
    """results/real_shapes for a folder of "real" vases: a training shape itself, a test shape
    and a squashed copy of it; every file measured four ways in the pose the tool finds (the
    training shape nearer its nearest training shape than the others are, nearer than the
    defaults), the means with intervals, the paper's rows beside, the folder's page made."""
    work = tmp_path / "work"
    shutil.copytree(smoke_run, work, symlinks=True)
    data = work / "data" / "smoke" / "vase"
    vases = work / "vases"
    vases.mkdir()
    shutil.copy(sorted((data / "train" / "shapes").glob("*.obj"))[0], vases / "seen.obj")
    test = trimesh.load(sorted((data / "test" / "shapes").glob("*.obj"))[0], force="mesh")
    test.export(vases / "unseen.obj")
    test.apply_scale([1.0, 1.0, 0.5])
    test.export(vases / "squashed.obj")
    snakemake(work, "-j2", "results/smoke/real_shapes", "--config", "profile=smoke",
              "real={vase: {inputs: vases, budget: 3}}")
    out = work / "results" / "smoke" / "real_shapes"
    shapes = pd.read_csv(out / "shapes.csv", comment="#").set_index("file")
    assert sorted(shapes.index) == ["seen.obj", "squashed.obj", "unseen.obj"] and (shapes.error.isna()).all()
    assert (shapes.chamfer_after <= shapes.chamfer_before).all()
    assert shapes.chamfer_nearest.idxmin() == "seen.obj"
    assert (shapes.chamfer_nearest < shapes.chamfer_defaults).all()
    table = pd.read_csv(out / "real_shapes.csv", comment="#").set_index(["row", "domain"])
    fit = table.loc[("network + fit", "vase")]
    assert fit["mean"] == pytest.approx(shapes.chamfer_after.mean(), rel=1e-4) and fit["n"] == 3
    assert fit["CI low"] <= fit["mean"] <= fit["CI high"]
    assert table.loc[("GeoCode (paper)", "vase"), "mean"] == 0.0112
    text = (out / "real_shapes.md").read_text()
    assert "| nearest training shape | " in text and "StructureNet (paper)" in text
    page = work / "results" / "smoke" / "reconstruct" / "real_shapes-vase" / "index.html"
    assert "squashed.obj" in page.read_text()


@pytest.mark.parametrize("spec, line", [
    ("{scans: {domain: chiar, inputs: scans}}", "reconstruct.scans.domain=chiar: not a domain of this run"),
    ("{scans: {domain: vase, inputs: nowhere}}", "reconstruct.scans.inputs: nowhere: no such file or folder"),
    ("{scans: {domain: vase, inputs: empty}}", "reconstruct.scans.inputs: empty: no mesh, cloud or drawing files"),
    ("{a/b: {domain: vase, inputs: scans}}", "reconstruct: 'a/b': not a plain name (it names a folder)"),
    ("{scans: {domain: vase, inputs: scans, batch: 0}}", "reconstruct.scans.batch=0: not valid; give a whole"),
    ("{real_shapes-vase: {domain: vase, inputs: scans}}", "names starting real_shapes- are --config real's"),
])
def test_a_bad_collection_stops_before_any_job_with_one_line(tmp_path, spec, line):
    (tmp_path / "scans").mkdir()
    (tmp_path / "scans" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "empty").mkdir()
    result = snakemake(tmp_path, "-n", "results/smoke/reconstruct/scans", "--config", "profile=smoke",
                       f"reconstruct={spec}", check=False)
    assert result.returncode != 0
    assert line in result.stdout + result.stderr
    assert "Traceback" not in result.stdout + result.stderr


@pytest.mark.parametrize("config, line", [
    ([], "--config real names no folder; give real="),
    (["real={chiar: scans}"], "real.chiar: not a domain of this run"),
    (["real={vase: nowhere}"], "real.vase.inputs: nowhere: no such file or folder"),
    (["real={vase: {domain: chair, inputs: scans}}"], "real.vase="),
])
def test_a_bad_real_shape_folder_stops_before_any_job_with_one_line(tmp_path, config, line):
    (tmp_path / "scans").mkdir()
    (tmp_path / "scans" / "a.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    result = snakemake(tmp_path, "-n", "results/smoke/real_shapes", "--config", "profile=smoke", *config,
                       check=False)
    assert result.returncode != 0
    assert line in result.stdout + result.stderr
    assert "Traceback" not in result.stdout + result.stderr
