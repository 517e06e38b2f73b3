"""The files of one `geocode reconstruct` run, settled before any work: its inputs, the names of
each input's outputs, and the record of what it writes in the output folder.

Names: an input's outputs are named after its path under the folder given, without its suffix
(`sub/scan.obj` -> `sub/scan.yaml|obj|in-place.obj|png|blend`). Where one of those names would
also be another input's output, or would replace a file that reconstruct did not write (an input
of the run, as with `-o` the input's own folder; a `scan.blend` of the user's), the input keeps
its suffix in its name (`scan.obj` -> `scan-obj.*`, `scan.ply` -> `scan-ply.*`). The names
depend on the inputs and the output folder's other files alone, so a rerun gives the same ones.

Record: `<out>/.geocode-reconstruct.json` lists the files that reconstruct writes in that folder,
written before they are. A rerun replaces those (each input's all together, `geocode.outputs`)
and no other file, and a run that reads that folder never takes them for inputs (a folder
reconstructed into itself). Where the page's own `index.html` or `summary.csv` would replace a
file that reconstruct did not write, the run stops with one line before any work.
"""

from __future__ import annotations

import json
import os
from collections import Counter
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from geocode.errors import UserError
from geocode.reconstruct.inputs import IMAGE_SUFFIXES, SUFFIXES

RECORD = ".geocode-reconstruct.json"
SHAPE_OUTPUTS = (".yaml", ".obj", ".png", ".blend", ".in-place.obj")
DRAWING_OUTPUTS = SHAPE_OUTPUTS[:4]           # a drawing has no in-place mesh
PAGE_FILES = ("index.html", "summary.csv")
FIX = "give -o another folder"


@dataclass(frozen=True)
class Job:
    """One input: its file, its name on the page (its path under the folder given) and the stem
    of its outputs (`<stem>.yaml`, ...)."""

    path: Path
    name: str
    stem: Path


@dataclass(frozen=True)
class Plan:
    out_dir: Path
    jobs: list[Job]
    files: list[str]        # every file the run may write, relative to out_dir
    recorded: list[str]     # the record before the run: files an earlier run wrote

    @property
    def record_path(self) -> Path:
        return self.out_dir / RECORD

    def record_text(self) -> str:
        """The record with this run's files added (and the earlier files no longer there dropped)."""
        kept = [f for f in self.recorded if os.path.lexists(self.out_dir / f)]
        about = "the files geocode reconstruct writes in this folder: a rerun replaces these and no others"
        return json.dumps({"about": about, "files": sorted({*kept, *self.files})}, indent=0) + "\n"

    def write_record(self) -> None:
        from geocode.meshio import write_text

        write_text(self.record_path, self.record_text())


def output_suffixes(path: Path) -> tuple[str, ...]:
    return DRAWING_OUTPUTS if path.suffix.lower() in IMAGE_SUFFIXES else SHAPE_OUTPUTS


def plan_run(input_path: Path, out_dir: Path, recursive: bool, candidates: int = 1) -> Plan:
    """The run's inputs and where each one's outputs go (see the module's docstring); UserError
    where an output could not avoid a file that reconstruct did not write."""
    recorded = read_record(out_dir)
    files = inputs_of(input_path, recursive, ours={(out_dir / f).resolve() for f in recorded})
    root = input_path if input_path.is_dir() else input_path.parent
    names = [p.relative_to(root).as_posix() for p in files]
    inputs = {p.resolve() for p in files}
    ours = set(recorded)

    def taken(output: str) -> bool:
        """Whether writing `output` (relative to out_dir) would replace an input or a file that
        reconstruct did not write."""
        path = out_dir / output
        return path.resolve() in inputs or (os.path.lexists(path) and output not in ours)

    for name in PAGE_FILES:
        if taken(name):
            raise UserError(out_dir / name, "would be replaced by the page, but reconstruct did not write it",
                            f"move it away or {FIX}")
    stems = output_stems(names, [output_suffixes(p) for p in files], taken)
    jobs = [Job(path, name, out_dir / stem) for path, name, stem in zip(files, names, stems, strict=True)]
    return Plan(out_dir, jobs, [*(f for job in jobs for f in job_files(job, out_dir, candidates)), *PAGE_FILES],
                recorded)


def job_files(job: Job, out_dir: Path, candidates: int = 1) -> list[str]:
    """The files one input's reconstruction may write, relative to `out_dir`: its outputs and
    its pictures."""
    from geocode.reconstruct.page import picture_path, picture_roles

    stem = job.stem.relative_to(out_dir).as_posix()
    return [*(f"{stem}{s}" for s in output_suffixes(job.path)),
            *(picture_path(job.name, role) for role in picture_roles(candidates))]


def output_stems(names: list[str], suffixes: list[tuple[str, ...]], taken) -> list[str]:
    """Each input's outputs' stem (relative to the output folder): its name without its suffix,
    or with it kept (`scan-obj`) where one of its outputs would be another input's (names
    compared without case, as some file systems do) or `taken(output)`."""
    kept = [False] * len(names)

    def stem(i: int) -> str:
        name = PurePosixPath(names[i])
        plain = name.with_suffix("").as_posix()
        return f"{plain}-{name.suffix[1:]}" if kept[i] and name.suffix else plain

    while True:
        outputs = [[f"{stem(i)}{s}" for s in suffixes[i]] for i in range(len(names))]
        count = Counter(o.casefold() for out in outputs for o in out)
        clashes = {i: o for i, out in enumerate(outputs) for o in out if count[o.casefold()] > 1 or taken(o)}
        if all(kept[i] for i in clashes):
            break
        for i in clashes:
            kept[i] = True
    if clashes:
        i, output = next(iter(clashes.items()))
        raise UserError(names[i], f"its output {output} would replace another input's output or a file "
                        "that reconstruct did not write", f"rename the input or {FIX}")
    return [stem(i) for i in range(len(names))]


def inputs_of(path: Path, recursive: bool, ours: set[Path] = frozenset()) -> list[Path]:
    """The input files: `path` itself, or the files of the folder with a known suffix, but for
    those that reconstruct wrote (`ours`, resolved)."""
    if not path.exists():
        raise UserError(f"{path}: no such file or folder; check the path")
    if path.is_file():
        return [path]
    found = sorted(p for p in (path.rglob("*") if recursive else path.iterdir())
                   if p.is_file() and p.suffix.lower() in SUFFIXES and p.resolve() not in ours)
    if not found:
        raise UserError(path, "no mesh, cloud or drawing files in the folder"
                        + ("" if recursive else " (--recursive reads subfolders)"),
                        f"give a folder of {', '.join(SUFFIXES)} files")
    return found


def read_record(out_dir: Path) -> list[str]:
    """The files an earlier run wrote in `out_dir` (relative to it), from its record."""
    path = out_dir / RECORD
    if not path.is_file():
        return []
    try:
        files = json.loads(path.read_text())["files"]
        if not all(isinstance(f, str) for f in files):
            raise ValueError("a file name is not text")
    except (ValueError, KeyError, TypeError, UnicodeDecodeError) as exc:
        raise UserError(path, f"is not a record of geocode reconstruct ({exc})", f"remove it or {FIX}") from None
    return files
