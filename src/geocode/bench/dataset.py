"""Throughput of the dataset stages on a domain's own shapes (`geocode bench dataset`)."""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import trimesh

from geocode import meshio
from geocode.blender import export, sketch
from geocode.points import make_clouds
from geocode.timing import Stopwatch, seconds_per_call

log = logging.getLogger(__name__)


def bench_sketch(shapes_dir: str | Path, ids: Sequence[str],
                 cameras: Sequence[sketch.Camera] = sketch.DEFAULT_CAMERAS) -> float:
    """Views per second for sketching exported shapes (renderer built and warmed up first,
    OBJ reading included, as in `sketch_shard`)."""
    shapes_dir = Path(shapes_dir)
    r = sketch.renderer()
    with tempfile.TemporaryDirectory() as tmp:
        first = meshio.read_obj(shapes_dir / f"{ids[0]}.obj")
        r.set_mesh(first.vertices, first.faces)
        r.render(cameras[0], Path(tmp) / "warm.png")
        with Stopwatch() as clock:
            for shape_id in ids:
                mesh = meshio.read_obj(shapes_dir / f"{shape_id}.obj")
                paths = {c.name: Path(tmp) / f"{shape_id}_{c.name}.png" for c in cameras}
                sketch.sketch_mesh(mesh, paths, cameras, shape_id)
    return len(ids) * len(cameras) / clock.seconds


def bench_dataset(domain: str, n: int = 12) -> dict[str, float]:
    """{"export_shapes_per_s", "sketch_views_per_s", "clouds_per_s"} on n random shapes of the
    domain (one process, as a shard runs)."""
    program = export.load_program(domain)
    recipe = program.recipe()
    rows = export.random_rows(program, n)
    with tempfile.TemporaryDirectory() as tmp:
        with Stopwatch() as clock:
            for shape_id, values in rows:
                export.export_shape(program, recipe, shape_id, values, Path(tmp))
        export_rate = n / clock.seconds
        sketch_rate = bench_sketch(tmp, [shape_id for shape_id, _ in rows])
    clouds = bench_clouds(n=50)
    result = {"export_shapes_per_s": round(export_rate, 2), "sketch_views_per_s": round(sketch_rate, 2),
              "clouds_per_s": round(clouds, 2)}
    log.info("bench dataset %s: %s", domain, result)
    return result


def bench_mesh(sections: int = 64, rings: int = 80) -> trimesh.Trimesh:
    """A closed vase-like surface of revolution with about 2 * sections * rings faces."""
    z = np.linspace(0.0, 1.0, rings)
    r = 0.25 + 0.12 * np.sin(2 * np.pi * z) + 0.05 * np.cos(6 * np.pi * z)
    profile = np.column_stack([np.r_[0.0, r, 0.0], np.r_[0.0, z, 1.0]])
    return trimesh.creation.revolve(profile, sections=sections)


def bench_clouds(n: int = 50) -> float:
    """Clouds per second for make_clouds at the paper's sizes on a ~10K-face mesh."""
    mesh = bench_mesh()
    rng = np.random.default_rng(0)
    return 1.0 / seconds_per_call(lambda: make_clouds(mesh, rng=rng), n)
