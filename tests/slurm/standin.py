#!/usr/bin/env python3
"""A stand-in for SLURM's commands, for tests on a machine without a cluster.

Linked as sbatch, srun, squeue, sacct, sinfo, sacctmgr, sshare, scontrol and scancel. Every
call's arguments go to `$GEOCODE_SLURM_STANDIN/calls.jsonl`; `sbatch` runs the job at once, locally,
with its output in the requested log file, and records its final state, which `sacct` and
`squeue` then report as SLURM does (`<id>|<STATE>`).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

STATE = Path(os.environ["GEOCODE_SLURM_STANDIN"])
JOBS = STATE / "jobs.jsonl"


def option(args: list[str], *names: str) -> str | None:
    """The value of `--name value`, `--name=value` or `-n value`."""
    for i, arg in enumerate(args):
        for name in names:
            if arg == name and i + 1 < len(args):
                return args[i + 1]
            if arg.startswith(f"{name}="):
                return arg.split("=", 1)[1]
    return None


def jobs() -> list[dict]:
    return [json.loads(line) for line in JOBS.read_text().splitlines()] if JOBS.exists() else []


def sbatch(args: list[str]) -> None:
    script = option(args, "--wrap")
    if script is None:                                 # the script comes on stdin (/dev/stdin)
        script = sys.stdin.read()
    job_id = str(1000 + len(jobs()))
    log = Path(option(args, "--output", "-o").replace("%j", job_id))
    log.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, SLURM_JOB_ID=job_id, SLURM_JOBID=job_id)
    with open(log, "w") as out:
        code = subprocess.run(["sh", "-c", script], stdout=out, stderr=subprocess.STDOUT, env=env).returncode
    with open(JOBS, "a") as f:
        f.write(json.dumps({"id": job_id, "name": option(args, "--job-name", "-J"),
                            "state": "COMPLETED" if code == 0 else "FAILED"}) + "\n")
    print(job_id)


def srun(args: list[str]) -> None:
    command = args[next(i for i, a in enumerate(args) if not a.startswith("-")):]
    os.execvp(command[0], command)


def status(args: list[str]) -> None:
    name = option(args, "--name")
    for job in jobs():
        if name is None or job["name"] == name:
            print(f"{job['id']}|{job['state']}")


def main() -> None:
    tool, args = Path(sys.argv[0]).name, sys.argv[1:]
    with open(STATE / "calls.jsonl", "a") as f:
        f.write(json.dumps([tool, *args]) + "\n")
    if tool == "sbatch":
        sbatch(args)
    elif tool == "srun":
        srun(args)
    elif tool in ("sacct", "squeue"):
        status(args)
    elif tool == "sinfo":
        print("PARTITION\ncpu*\ngpu")
    elif tool in ("sacctmgr", "sshare"):
        print("geocode")


if __name__ == "__main__":
    main()
