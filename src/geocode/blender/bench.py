"""Throughput of the dataset stages on a domain's own shapes (`geocode bench dataset`)."""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Sequence
from pathlib import Path

from geocode import meshio
from geocode.blender import export, sketch
from geocode.timing import Stopwatch

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
    domain (one process, as a shard runs). clouds_per_s is NaN until geocode.points exists."""
    program = export.load_program(domain)
    recipe = program.recipe()
    rows = export.random_rows(program, n)
    with tempfile.TemporaryDirectory() as tmp:
        with Stopwatch() as clock:
            for shape_id, values in rows:
                export.export_shape(program, recipe, shape_id, values, Path(tmp))
        export_rate = n / clock.seconds
        sketch_rate = bench_sketch(tmp, [shape_id for shape_id, _ in rows])
    try:
        from geocode.points import bench_clouds
    except ImportError as exc:
        log.warning("clouds_per_s not measured: %s", exc)
        clouds = float("nan")
    else:
        clouds = float(bench_clouds(n=50))
    result = {"export_shapes_per_s": round(export_rate, 2), "sketch_views_per_s": round(sketch_rate, 2),
              "clouds_per_s": round(clouds, 2)}
    log.info("bench dataset %s: %s", domain, result)
    return result
