"""Export a shard of a split: recipe rows -> program meshes on the unit sphere, with raw
values, normalised labels and per-face part labels (docs/design.md, dataset layout).

One process per shard: the program is loaded once and re-evaluated for every row."""

from __future__ import annotations

import logging
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np
import yaml

from geocode import meshio, paths
from geocode.errors import UserError, one_line
from geocode.timing import Progress

log = logging.getLogger(__name__)

SUFFIXES = (".obj", ".yaml", ".labels.yaml", ".parts.npy")


def load_program(domain: str):
    from geocode.program import Program

    return Program.load(domain)


def unit_mesh(program, values: Mapping[str, float]):
    """Evaluate and normalise to the unit sphere; part labels stay in metadata["part"]."""
    return meshio.normalise_unit_sphere(program.evaluate(values))


def shard_rows(recipes: str | Path, shard: int) -> Iterator[tuple[str, dict[str, float]]]:
    """(id, raw values) for the rows of `recipes.parquet` with `shard == shard`, in file order
    (the sampler's bookkeeping columns are not parameter values)."""
    from geocode.recipe import META_COLUMNS, load_recipes

    frame = load_recipes(recipes)
    frame = frame[frame["shard"] == shard]
    columns = [c for c in frame.columns if c not in META_COLUMNS]
    for shape_id, row in zip(frame["id"], frame[columns].itertuples(index=False), strict=True):
        yield str(shape_id), {c: float(v) for c, v in zip(columns, row, strict=True)}


def typed(parameters, values: Mapping[str, float]) -> dict:
    """Raw values as YAML should show them: bools as true/false, ints as whole numbers."""
    kinds = {p.name: p.kind for p in parameters}
    cast = {"bool": lambda v: bool(round(v)), "int": lambda v: int(round(v))}
    return {k: cast.get(kinds.get(k), float)(v) for k, v in values.items()}


def write_shape(obj: Path, values_file: Path, program, values: Mapping[str, float]):
    """The program's mesh (unit sphere) to the OBJ `obj` and the values to the YAML
    `values_file`, each written atomically; returns the mesh."""
    mesh = unit_mesh(program, values)
    meshio.write_text(values_file, yaml.safe_dump(typed(program.parameters, values), sort_keys=False))
    meshio.write_obj(obj, mesh)
    return mesh


def part_labels(mesh) -> np.ndarray:
    parts = np.asarray(mesh.metadata.get("part", ()))
    if parts.shape != (len(mesh.faces),):
        raise ValueError(f"program gave {parts.shape} part labels for {len(mesh.faces)} faces; "
                         "set mesh.metadata['part'] to one label per face")
    return parts.astype(np.int16)


def is_complete(shapes_dir: Path, shape_id: str) -> bool:
    """All four files are there and none is empty (a rerun redoes a shape with a broken one)."""
    for suffix in SUFFIXES:
        path = paths.shape_file(shapes_dir, shape_id, suffix)
        if not path.is_file() or path.stat().st_size == 0:
            return False
    return True


def export_shape(program, recipe, shape_id: str, values: Mapping[str, float], shapes_dir: Path) -> None:
    """All four files of one shape, each written atomically (OBJ last: its presence alone
    never marks a shape done, `is_complete` checks all four)."""
    full = recipe.full_values(values)
    try:
        mesh = unit_mesh(program, full)
    except ValueError as exc:
        raise UserError(shape_id, one_line(exc, 300), "fix the program or narrow its recipe") from None
    parts = part_labels(mesh)
    yaml_dump = lambda d: yaml.safe_dump(d, sort_keys=False)  # noqa: E731
    meshio.write_text(paths.shape_file(shapes_dir, shape_id, ".yaml"), yaml_dump(typed(program.parameters, full)))
    labels = {k: float(v) for k, v in recipe.labels(values).items()}
    meshio.write_text(paths.shape_file(shapes_dir, shape_id, ".labels.yaml"), yaml_dump(labels))
    with meshio.atomic_path(paths.shape_file(shapes_dir, shape_id, ".parts.npy")) as tmp:
        with open(tmp, "wb") as f:   # a file object: np.save would append .npy to a path
            np.save(f, parts)
    meshio.write_obj(paths.shape_file(shapes_dir, shape_id), mesh)


def export_shard(split_dir: str | Path, shard: int, domain: str, program=None, recipe=None) -> Path:
    """Export the rows of `<split_dir>/recipes.parquet` with `shard == shard`; skip shapes with
    all files present, redo partial ones; write `done/export-<shard>.txt` last. `program` and
    `recipe` default to the domain's (tests pass doubles). Returns the done file."""
    split_dir = Path(split_dir)
    program = program or load_program(domain)
    recipe = recipe or program.recipe()
    rows = list(shard_rows(paths.recipes_file(split_dir), shard))
    shapes_dir = paths.shapes_dir(split_dir)
    progress = Progress(f"export {domain} shard {shard}", len(rows), log)
    for shape_id, values in rows:
        if not is_complete(shapes_dir, shape_id):
            export_shape(program, recipe, shape_id, values, shapes_dir)
        progress.step()
    progress.finish()
    done = paths.done_file(split_dir, "export", shard)
    meshio.write_text(done, "".join(f"{shape_id}\n" for shape_id, _ in rows))
    return done


def random_rows(program, n: int, seed: int = 0) -> list[tuple[str, dict[str, float]]]:
    """n (id, values) pairs from the program's own sampler, for benchmarks and galleries."""
    rng = np.random.default_rng(seed)
    return [(f"bench-{i:06d}", dict(program.random_values(rng))) for i in range(n)]
