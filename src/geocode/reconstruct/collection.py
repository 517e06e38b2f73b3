"""A collection of a user's own files, reconstructed by the workflow (workflow/rules/reconstruct.smk):

    snakemake -j2 results/reconstruct/scans --config reconstruct='{scans: {domain: chair, inputs: scans/}}'

The collection's inputs, and their names, are those of `geocode reconstruct scans/ -o
results/reconstruct/scans` (`geocode.reconstruct.plan`), taken in batches of `batch` inputs
in that order. Each batch is one job (`batch_step`): its inputs reconstructed as a folder run
reconstructs them, their outputs and pictures written under the same names in
<paths.runs>/reconstruct/<name>/files/, then each input's record (done/<hash of its name>.json:
its page entry, summary, files, and the input, model and settings it was made from), then the
batch's record (batch-<n>.json) last. An input whose record still matches is not done again:
a file added to the folder shifts the batches after it, and their jobs run again, but only the
new file is reconstructed; a stopped job leaves the inputs it had not finished without a
record. The page job (`page_step`) links every input's files into the collection's folder
(copies where links cannot be made) and writes the page, summary.csv and the folder's record,
as `geocode reconstruct` does.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Annotated

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from geocode.errors import UserError
from geocode.reconstruct.plan import Job, Plan, job_files, plan_run
from geocode.settings import NAME, Expect, Flag, optional, whole

BATCH = 8      # inputs per job: a job's start (Blender, the network, the training shapes) is a
               # few seconds, a real mesh's reconstruction 15-30 s
FORM = "{<name>: {domain: <domain>, inputs: <folder>}}"
REAL_FORM = "{<domain>: <folder of real meshes>, ...}"
REAL_PREFIX = "real_shapes-"   # the collection of --config real's folder of a domain


class Spec(BaseModel):
    """One collection as --config reconstruct gives it: its domain, its folder of inputs (or
    one file), the inputs per job, the program evaluations of each fit (null:
    eval.reconstruct_budget) and whether the folder's subfolders are read too."""

    model_config = ConfigDict(extra="forbid", strict=True)
    domain: Annotated[str, Expect("a domain of the run")]
    inputs: Annotated[str, Field(min_length=1), Expect("a folder of meshes, scans, clouds or drawings")]
    batch: whole(1) = BATCH
    budget: optional(whole(0)) = None
    recursive: Flag = False


@dataclass(frozen=True)
class Collection:
    name: str
    domain: str
    inputs: Path
    batch: int
    budget: int | None
    recursive: bool
    plan: Plan              # its inputs and their names in the collection's folder

    def batches(self) -> list[list[Job]]:
        return batches(self.plan.jobs, self.batch)


def batches(jobs: list[Job], size: int) -> list[list[Job]]:
    return [jobs[i:i + size] for i in range(0, len(jobs), size)]


def collections(value, domains: list[str], out_dir, work_dir) -> dict[str, Collection]:
    """The collections of --config reconstruct (None: none), each checked and planned;
    `out_dir(name)` and `work_dir(name)` are its folders. UserError (one line) on a bad one."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise UserError(f"reconstruct={value!r}", "not a mapping", f"give {FORM}")
    for name in value:
        if isinstance(name, str) and name.startswith(REAL_PREFIX):
            raise UserError(f"reconstruct: {name!r}", f"names starting {REAL_PREFIX} are --config real's",
                            "choose another name")
    return {name: collection(name, spec, domains, Path(out_dir(name)), Path(work_dir(name)))
            for name, spec in value.items()}


def real_collections(value, domains: list[str], out_dir, work_dir) -> dict[str, Collection]:
    """The collections of --config real (None: none): per domain a folder of real meshes (or a
    collection's mapping without its domain), each the collection `real_shapes-<domain>`."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise UserError(f"real={value!r}", "not a mapping", f"give {REAL_FORM}")
    found = {}
    for domain, spec in value.items():
        if domain not in domains:
            raise UserError(f"real.{domain}", "not a domain of this run",
                            f"use one of {', '.join(domains) or 'none'} (the run's domains: --config domains=[...])")
        spec = {"inputs": spec} if isinstance(spec, str) else spec
        if not isinstance(spec, dict) or "domain" in spec:
            raise UserError(f"real.{domain}={spec!r}", "not a folder", f"give {REAL_FORM}")
        name = REAL_PREFIX + domain
        found[name] = collection(name, {"domain": domain, **spec}, domains, Path(out_dir(name)),
                                 Path(work_dir(name)), where=f"real.{domain}")
    return found


def collection(name, spec, domains: list[str], out: Path, work: Path, where: str | None = None) -> Collection:
    """One collection, checked and planned; `where` names it in a mistake's line."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise UserError(f"reconstruct: {name!r}", "not a plain name (it names a folder)",
                        "use letters, digits, _, - and . (not a path)")
    where = where or f"reconstruct.{name}"
    if not isinstance(spec, dict):
        raise UserError(f"{where}={spec!r}", "not a mapping", f"give {FORM}")
    try:
        spec = Spec.model_validate({k: typed(v) if k in ("batch", "budget", "recursive") else v
                                    for k, v in spec.items()})
    except ValidationError as exc:
        raise UserError(spec_error(where, exc.errors()[0])) from None
    if spec.domain not in domains:
        raise UserError(f"{where}.domain={spec.domain}", "not a domain of this run",
                        f"use one of {', '.join(domains) or 'none'} (the run's domains: --config domains=[...])")
    inputs = Path(spec.inputs)
    for folder in (out, work):
        if inputs.resolve().is_relative_to(folder.resolve()) or (
                spec.recursive and folder.resolve().is_relative_to(inputs.resolve())):
            raise UserError(f"{where}.inputs={spec.inputs}", f"overlaps {folder}, which the workflow writes",
                            "keep the inputs in a folder of their own")
    try:
        plan = plan_run(inputs, out, spec.recursive)
    except UserError as exc:                          # a missing folder, no inputs in it
        raise UserError(f"{where}.inputs: {exc}") from None
    return Collection(name, spec.domain, inputs, spec.batch, spec.budget, spec.recursive, plan)


def typed(value):
    """A value as YAML reads it: --config gives every value inside a mapping as text ("8", "null")."""
    return yaml.safe_load(value) if isinstance(value, str) else value


def spec_error(where: str, error: dict) -> str:
    key = ".".join(map(str, error["loc"]))
    if error["type"] == "extra_forbidden":
        return f"{where}.{key}: unknown key; use {', '.join(Spec.model_fields)}"
    field = Spec.model_fields[key]
    expect = next(str(m) for m in field.metadata if isinstance(m, Expect))
    if error["type"] == "missing":
        return f"{where}.{key}: missing; give {expect}"
    return f"{where}.{key}={error['input']!r}: not valid; give {expect}"


# -- the workflow's steps ----------------------------------------------------------------------

def batch_step(cfg, domain: str, inputs: Path, out_dir: Path, work: Path, batch: int, size: int,
               checkpoint: Path | None = None, budget: int | None = None, recursive: bool = False,
               workers: int = 1) -> dict:
    """Reconstruct the collection's batch `batch` (of `size` inputs) into <work>/files, each
    input's record after its files and the batch's record last; an input whose record matches
    what it would be made from now (`origin`) and whose files are there is kept as it is."""
    from geocode import paths
    from geocode.reconstruct.run import reconstruct_jobs

    plan = plan_run(Path(inputs), Path(out_dir), recursive)
    parts = batches(plan.jobs, size)
    if not 0 <= batch < len(parts):
        raise UserError(f"--batch {batch}", f"the collection has {len(parts)} batches of {size}",
                        f"give 0 .. {len(parts) - 1}")
    jobs = parts[batch]
    folder = paths.collection_files_dir(work)
    settings = {"domain": domain, "checkpoint": checkpoint, "refine": budget, "up": "auto", "candidates": 1}
    made_from = {job.name: origin(cfg, settings, job) for job in jobs}
    kept = {job.name: record for job in jobs
            if (record := read_json(paths.collection_input_record(work, job.name))) is not None
            and record["made_from"] == made_from[job.name] and all((folder / f).is_file() for f in record["files"])}
    todo = [job for job in jobs if job.name not in kept]
    files = {job.name: job_files(job, plan.out_dir) for job in todo}
    for name in (f for names in files.values() for f in names):
        (folder / name).unlink(missing_ok=True)     # what a stopped or older try left
    moved = Plan(folder, [Job(j.path, j.name, folder / j.stem.relative_to(plan.out_dir)) for j in todo],
                 [f for names in files.values() for f in names], [])
    entries, summaries = reconstruct_jobs(cfg, settings, moved, workers) if todo else ([], [])
    for e, s in zip(entries, summaries, strict=True):
        record = {"name": e.name, "entry": asdict(e), "summary": s, "made_from": made_from[e.name],
                  "files": [f for f in files[e.name] if (folder / f).is_file()]}
        kept[e.name] = record
        if "error" not in s:                         # a failed input is tried again by a rerun
            write_json(paths.collection_input_record(work, e.name), record)
    record = [kept[job.name] for job in jobs]
    write_json(paths.collection_batch_file(work, batch), record)
    return {"batch": batch, "inputs": len(record), "reconstructed": len(todo),
            "failed": sum("error" in r["summary"] for r in record)}


def origin(cfg, settings: dict, job: Job) -> dict:
    """What an input's outputs are made from: the file (its size and time), the model (its
    checkpoint's time) and the settings; a rerun keeps outputs made from the same."""
    from omegaconf import OmegaConf

    def stamp(path) -> list:
        stat = Path(path).stat()
        return [str(path), stat.st_size, stat.st_mtime_ns]

    checkpoint = settings["checkpoint"]
    return {"input": stamp(job.path), "checkpoint": checkpoint and stamp(checkpoint),
            "settings": json.dumps(settings, sort_keys=True, default=str),
            "config": json.dumps(OmegaConf.to_container(cfg, resolve=True), sort_keys=True, default=str)}


def read_json(path: Path):
    """A record, or None where there is none (or only half of one)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def write_json(path: Path, value) -> None:
    from geocode.meshio import write_text

    write_text(path, json.dumps(value, indent=1, default=plain) + "\n")


def page_step(domain: str, inputs: Path, out_dir: Path, work: Path, size: int, recursive: bool = False) -> dict:
    """The collection's folder: every batch's files linked in, the page, summary.csv and the
    folder's record."""
    from geocode import paths
    from geocode.reconstruct import page
    from geocode.reconstruct.run import PAGE_NOTE, folder_summary, page_title

    out_dir = Path(out_dir)
    plan = plan_run(Path(inputs), out_dir, recursive)
    items = [item for batch in range(len(batches(plan.jobs, size)))
             for item in json.loads(paths.collection_batch_file(work, batch).read_text())]
    if [item["name"] for item in items] != [job.name for job in plan.jobs]:
        raise UserError(inputs, "its files changed since the batches were reconstructed",
                        "run the workflow again: it redoes the batches")
    plan.write_record()
    folder = paths.collection_files_dir(work)
    for item in items:
        for name in item["files"]:
            place(folder / name, out_dir / name)
    entries = [entry_of(item["entry"]) for item in items]
    page.write_page(entries, out_dir, page_title(domain), note=PAGE_NOTE)
    return folder_summary([item["summary"] for item in items], out_dir)


def place(source: Path, target: Path) -> None:
    """`source` at `target` too: a hard link (no space taken), or a copy across file systems."""
    target.parent.mkdir(parents=True, exist_ok=True)
    target.unlink(missing_ok=True)      # an earlier gathering's (the plan's names avoid every other file)
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def entry_of(record: dict):
    """A drawn page entry from its record (`dataclasses.asdict` of it)."""
    from geocode.reconstruct.page import Candidate, Entry

    return Entry(**{**record, "candidates": [Candidate(**c) for c in record["candidates"]]})


def plain(value):
    """A numpy number as JSON's."""
    return value.item()
