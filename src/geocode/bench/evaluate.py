"""Throughput of the evaluation stages on a domain's own shapes (`geocode bench eval`)."""

from __future__ import annotations

import logging
import tempfile

import numpy as np

from geocode.blender.export import load_program, random_rows, unit_mesh
from geocode.blender.rebuild import rebuild
from geocode.metrics import chamfer
from geocode.stability import drop_test
from geocode.timing import Stopwatch, seconds_per_call

log = logging.getLogger(__name__)


def bench_eval(domain: str, n: int = 40) -> dict:
    """Rebuild rate, Chamfer time (10k vs 10k) and drop-test time on real shapes of a domain."""
    program = load_program(domain)
    meshes = [unit_mesh(program, values) for _, values in random_rows(program, n, seed=2)]
    with Stopwatch() as clock:
        stable = [drop_test(mesh)["stable"] for mesh in meshes]
    drop_s = clock.seconds / n
    return {"n": n, "rebuild_shapes_per_s": round(bench_rebuild(domain, n, program=program), 2),
            "chamfer_ms": round(bench_chamfer(), 2), "drop_test_s": round(drop_s, 3),
            "stable_rate": round(float(np.mean(stable)), 3)}


def bench_rebuild(domain: str, n: int = 20, program=None) -> float:
    """Shapes per second through `rebuild` (evaluate, normalise, write the OBJ)."""
    program = program or load_program(domain)
    rows = random_rows(program, n, seed=1)
    with tempfile.TemporaryDirectory() as tmp:
        with Stopwatch() as clock:
            rebuild(domain, rows, tmp, program=program)
    rate = n / clock.seconds
    log.info("rebuild %s: %.1f shapes/s over %d shapes", domain, rate, n)
    return rate


def bench_chamfer(n: int = 10000, repeats: int = 20) -> float:
    """Milliseconds per chamfer() of two n-point clouds (median of `repeats`)."""
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, n, 3)).astype(np.float32)
    return seconds_per_call(lambda: chamfer(a, b), repeats) * 1000
