"""The on-disk layout: the one owner of every file and folder name the pipeline reads or writes.

The Python steps and the workflow's rules (workflow/rules/*.smk) both take their paths from
here, so nothing else builds or parses one. A name given as "{domain}", "{split}", ... comes
back as it was: a Snakemake wildcard.

    programs/<domain>.py, <domain>.yaml                  the program and its recipe
    <paths.build>/programs/<domain>.blend, .manifest.json
    <paths.data>/<domain>/<split>/recipes.parquet
        shapes/<id>.obj, .yaml, .labels.yaml, .parts.npy
        sketches/<id>_<camera>.png
        points/<id>.npz
        done/<stage>-<shard>.txt
    <paths.data>/<domain>/dataset.done
    <paths.runs>/<domain>/<variant>/config.yaml, summary.json, checkpoints/{best,last}.ckpt,
        logs/version_<n>/metrics.csv (Lightning's CSVLogger), eval/predictions.parquet,
        eval/metrics.parquet, eval/rebuilt/<condition>/<id>.obj, done-<shard>.txt, fit-<shard>.parquet
    <paths.results>/tables/, report/index.html           (the default profile's: results/)
    <paths.results>/reconstruct/<name>/                  a collection (workflow target), its batches
        in <paths.runs>/reconstruct/<name>/batch-<n>/, batch-<n>.json
    <paths.results>/real_shapes/                         the real-shape table (collections real_shapes-<domain>)
    logs/<the folder a job writes>/<rule>/<name>.log
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from geocode.errors import UserError

SPLITS = ("train", "val", "test")
PROGRAMS_ENV = "GEOCODE_PROGRAMS"


# -- the project's own files ------------------------------------------------------------------

def repo_root() -> Path:
    """The project folder holding conf/, programs/ and workflow/ (GEOCODE_ROOT overrides)."""
    if root := os.environ.get("GEOCODE_ROOT"):
        return Path(root).resolve()
    return Path(__file__).resolve().parents[2]


def programs_dir() -> Path:
    """The shape programs: `$GEOCODE_PROGRAMS`, else `programs/` at the repository root."""
    if override := os.environ.get(PROGRAMS_ENV):
        return Path(override)
    return repo_root() / "programs"


def program_path(domain: str) -> Path:
    return programs_dir() / f"{domain}.py"


def recipe_path(domain: str) -> Path:
    return programs_dir() / f"{domain}.yaml"


# -- built programs -----------------------------------------------------------------------------

def blend_path(cfg, domain: str) -> Path:
    return Path(cfg.paths.build) / "programs" / f"{domain}.blend"


def manifest_path(cfg, domain: str) -> Path:
    """The manifest that `geocode program build` writes for `domain` under the build folder."""
    return Path(cfg.paths.build) / "programs" / f"{domain}.manifest.json"


def program_key(cfg, domain: str) -> str:
    """The key of `domain`'s program: a hash of its manifest (parameters, visibility rules
    and the fingerprint of its geometry), so that a changed program has another key."""
    manifest = json.loads(manifest_path(cfg, domain).read_text())
    return hashlib.sha1(json.dumps(manifest, sort_keys=True).encode()).hexdigest()[:10]


# -- datasets -----------------------------------------------------------------------------------

def simplified_split(factor: int | str) -> str:
    """The decimated copy of the test split that keeps 1/factor of the faces."""
    return f"test-s{factor}"


def source_split(source: str) -> str:
    """The split holding a test condition's inputs: "test", or "s<factor>" -> test-s<factor>."""
    return "test" if source == "test" else f"test-{source}"


def splits(cfg) -> list[str]:
    return [*SPLITS, *(simplified_split(f) for f in cfg.eval.simplify)]


def check_split(cfg, split: str) -> str:
    """A split from outside the known set is refused, so that no user-given name leads out of
    the data folder."""
    if split not in splits(cfg):
        raise UserError(f"split {split!r}", "unknown", f"use one of {', '.join(splits(cfg))}")
    return split


def domain_dir(cfg, domain: str) -> Path:
    """<paths.data>/<domain>: every split of one domain's dataset."""
    return Path(cfg.paths.data) / domain


def split_of(domain_folder: Path, split: str) -> Path:
    return Path(domain_folder) / split


def split_dir(cfg, domain: str, split: str) -> Path:
    return split_of(domain_dir(cfg, domain), split)


def dataset_done(cfg, domain: str) -> Path:
    """Touched when every shard of every stage of the domain's dataset is done."""
    return domain_dir(cfg, domain) / "dataset.done"


def recipes_file(split_folder: Path) -> Path:
    return Path(split_folder) / "recipes.parquet"


def shapes_dir(split_folder: Path) -> Path:
    return Path(split_folder) / "shapes"


def shape_file(shapes_folder: Path, shape_id: str, suffix: str = ".obj") -> Path:
    """A shape's file in a split's `shapes_dir`: suffix .obj (the mesh), .yaml (raw values),
    .labels.yaml (normalised labels), .parts.npy (a part label per face)."""
    return Path(shapes_folder) / f"{shape_id}{suffix}"


def sketch_file(split_folder: Path, shape_id: str, camera: str) -> Path:
    return Path(split_folder) / "sketches" / f"{shape_id}_{camera}.png"


def cloud_file(split_folder: Path, shape_id: str) -> Path:
    return Path(split_folder) / "points" / f"{shape_id}.npz"


def done_file(split_folder: Path, stage: str, shard: int | str) -> Path:
    """The ids a shard of a stage finished (export, sketch, points), written last."""
    return Path(split_folder) / "done" / f"{stage}-{shard}.txt"


def program_stamp(split_folder: Path) -> Path:
    """The `program_key` of the program that a split's shapes were made with."""
    return Path(split_folder) / "program.txt"


DERIVED = ("shapes", "sketches", "points", "done")   # a split's folders made from its recipes


# -- runs -------------------------------------------------------------------------------------

def run_dir(cfg, domain: str, variant: str) -> Path:
    return Path(cfg.paths.runs) / domain / variant


def checkpoint_dir(run: Path) -> Path:
    return Path(run) / "checkpoints"


def checkpoint_file(run: Path, name: str = "best") -> Path:
    """best.ckpt (by val/acc) or last.ckpt (the one training resumes from)."""
    return checkpoint_dir(run) / f"{name}.ckpt"


def run_config_file(run: Path) -> Path:
    return Path(run) / "config.yaml"


def summary_file(run: Path) -> Path:
    """The best validation scores beside the majority bar."""
    return Path(run) / "summary.json"


def csv_log_files(run: Path) -> list[Path]:
    """The metrics of every (re)start, oldest first (Lightning's CSVLogger(run, name="logs"))."""
    return sorted(Path(run).glob("logs/version_*/metrics.csv"), key=lambda f: int(f.parent.name.split("_")[1]))


def card_file(run: Path) -> Path:
    """The model card: what the model saw, its numbers, what it is for (geocode.card)."""
    return run / "README.md"


def real_bench_file(run: Path) -> Path:
    """`geocode bench real`'s numbers for this model, read by its card."""
    return run / "real-bench.json"


def predictions_file(run: Path) -> Path:
    return Path(run) / "eval" / "predictions.parquet"


def metrics_file(run: Path) -> Path:
    return Path(run) / "eval" / "metrics.parquet"


def run_of(path: Path) -> Path:
    """The run folder of one of its checkpoints or evaluation files."""
    return Path(path).parent.parent


def rebuilt_dir(predictions: Path) -> Path:
    """The meshes rebuilt from a predictions file, beside it."""
    return Path(predictions).parent / "rebuilt"


def rebuilt_key(condition: str, shape_id: str) -> str:
    """A rebuilt mesh's name inside the rebuilt folder, less its .obj."""
    return f"{condition}/{shape_id}"


def rebuilt_mesh(rebuilt: Path, condition: str, shape_id: str) -> Path:
    return Path(rebuilt) / f"{rebuilt_key(condition, shape_id)}.obj"


def rebuilt_done(rebuilt: Path, shard: int | str) -> Path:
    return Path(rebuilt) / f"done-{shard}.txt"


def fit_file(rebuilt: Path, shard: int | str) -> Path:
    """The fits of a rebuild shard: distances before and after, evaluations, seconds."""
    return Path(rebuilt) / f"fit-{shard}.parquet"


# -- results and logs ---------------------------------------------------------------------------

def tables_dir(cfg) -> Path:
    return Path(cfg.paths.results) / "tables"


def report_dir(cfg) -> Path:
    return Path(cfg.paths.results) / "report"


def report_index(cfg) -> Path:
    return report_dir(cfg) / "index.html"


# -- the workflow's collections of a user's own files (workflow/rules/reconstruct.smk) -----------

def collection_dir(cfg, name: str) -> Path:
    """<paths.results>/reconstruct/<name>/: the collection's outputs, page and summary.csv, as
    `geocode reconstruct <folder> -o` writes them."""
    return Path(cfg.paths.results) / "reconstruct" / name


def real_shapes_dir(cfg) -> Path:
    """<paths.results>/real_shapes/: the real-shape table of --config real's folders."""
    return Path(cfg.paths.results) / "real_shapes"


def collection_work(cfg, name: str) -> Path:
    """<paths.runs>/reconstruct/<name>/: each batch's outputs, before the page gathers them."""
    return Path(cfg.paths.runs) / "reconstruct" / name


def collection_files_dir(work: Path) -> Path:
    """<work>/files/: every input's outputs and pictures, under the names they have in the
    collection's folder."""
    return Path(work) / "files"


def collection_input_record(work: Path, name: str) -> Path:
    """<work>/done/<hash of the input's name>.json: one input's page entry, summary, files and
    what it was made from, written after its files."""
    return Path(work) / "done" / f"{hashlib.sha1(name.encode()).hexdigest()[:16]}.json"


def collection_batch_file(work: Path, batch: int | str) -> Path:
    """A batch's record (its inputs' page entries, summaries and files), written last."""
    return Path(work) / f"batch-{batch}.json"


def log_file(folder: str | Path, rule: str, name: str | None = None) -> Path:
    """logs/<folder>/<rule>/<name>.log, or logs/<folder>/<rule>.log: a job logs under the
    folder it writes (or, for the tables and the report, the runs it reads)."""
    folder = Path(folder)
    folder = folder.relative_to(folder.anchor) if folder.is_absolute() else folder
    return Path("logs") / folder / (f"{rule}.log" if name is None else Path(rule) / f"{name}.log")
