"""Throughput and validity of a program's random shapes (`geocode bench program`)."""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

import numpy as np

from geocode.meshio import write_obj
from geocode.program import Program
from geocode.stability import is_stable, loose_parts
from geocode.timing import Stopwatch


def bench_program(domain: str, n: int = 200, seed: int = 0, stability: bool = False) -> dict:
    """Random shapes per second (evaluation + OBJ export to a temp dir), the median face
    count, and the fraction of shapes with loose parts or non-finite vertices; with
    `stability`, also the fraction that pass the drop test (after the timing)."""
    program = Program.load(domain)
    rng = np.random.default_rng(seed)
    samples = [program.random_values(rng) for _ in range(n)]
    meshes = []
    with tempfile.TemporaryDirectory() as tmp:
        with Stopwatch() as clock:
            for i, values in enumerate(samples):
                mesh = program.evaluate(values)
                write_obj(Path(tmp) / f"{i:06d}.obj", mesh)
                meshes.append(mesh)
    elapsed = clock.seconds
    loose = sum(loose_parts(mesh) > 0 for mesh in meshes)
    nonfinite = sum(not np.isfinite(mesh.vertices).all() for mesh in meshes)
    result = {"n": n, "shapes_per_s": round(n / elapsed, 2),
              "median_faces": int(statistics.median(len(m.faces) for m in meshes)),
              "loose_part_rate": loose / n, "nonfinite_rate": nonfinite / n}
    if stability:
        result["stable_rate"] = sum(is_stable(mesh) for mesh in meshes) / n
    return result
