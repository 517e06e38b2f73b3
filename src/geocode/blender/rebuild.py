"""Rebuild predicted shapes: parameter values -> program -> unit-sphere OBJ, batched in one
process (docs/paper-numbers.md#evaluation: predicted labels are denormalised upstream; here they are raw values)."""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from pathlib import Path

from geocode import meshio
from geocode.blender.export import load_program, unit_mesh
from geocode.errors import UserError, one_line
from geocode.timing import Progress

log = logging.getLogger(__name__)


def rebuild(domain: str, rows: Iterable[tuple[str, Mapping[str, float]]], out_dir: str | Path,
            program=None, overwrite: bool = True, total: int | None = None) -> list[Path]:
    """Write `<out_dir>/<key>.obj` for every (key, values); values missing from a row take the
    program's defaults. Existing OBJs are replaced (new predictions must never meet stale
    meshes) unless `overwrite=False`, which resumes a crashed run. `total` only feeds the
    progress ETA when `rows` is a generator. Returns the OBJ paths in order."""
    program = program or load_program(domain)
    out_dir = Path(out_dir)
    if total is None and hasattr(rows, "__len__"):
        total = len(rows)
    progress = Progress(f"rebuild {domain}", total or 0, log)
    paths = []
    for key, values in rows:
        path = out_dir / f"{key}.obj"
        if overwrite or not path.exists():
            try:
                mesh = unit_mesh(program, values)
            except ValueError as exc:
                raise UserError(f"rebuild {domain} {key}", one_line(exc, 300), "check the predictions file") from None
            meshio.write_obj(path, mesh)
        paths.append(path)
        progress.step()
    progress.finish()
    return paths
