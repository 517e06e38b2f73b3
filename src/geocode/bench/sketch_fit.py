"""Fitting to drawings (`geocode bench fit <domain> --modality sketch`): the trained joint
model's predictions on a run's test sketches, fitted to the sketch (`geocode.reconstruct.sketchfit`), and
measured against the ground truth."""

from __future__ import annotations

import statistics
import time
from collections.abc import Sequence

import numpy as np

from geocode import paths
from geocode.checkpoints import default_checkpoint, load_model, ranked_prediction, reader
from geocode.config import sketch_fit_budget, sketch_fit_searches
from geocode.meshio import read_obj
from geocode.metrics import chamfer_meshes
from geocode.program import Program
from geocode.reconstruct.fit import Start
from geocode.reconstruct.sketchfit import fit_drawing, mean_curve
from geocode.steps.evaluate import test_ids
from geocode.steps.tables import bootstrap_ci
from geocode.steps.train_data import load_sketch


def bench_sketch_fit(cfg, domain: str, n: int = 10, camera: str = "trained",
                     budget: int | None = None) -> dict:
    """The domain's trained joint model's predictions on test sketches (`camera` "trained":
    shape i from the i-th trained camera in turn; "novel": the untrained one), fitted to the
    sketch, measured against the ground truth by `metrics.chamfer_meshes`: before and after,
    and the median seconds per drawing (network, fit and both rebuilds included). budget: the
    fit's evaluations (default: the domain's eval.sketch_fit_budget)."""
    budget = sketch_fit_budget(cfg, domain) if budget is None else budget
    program = Program.load(domain)
    recipe = program.recipe()
    checkpoint = default_checkpoint(cfg, domain)
    model = load_model(checkpoint, recipe=recipe)
    cams = [c.name for c in cfg.data.sketch.cameras if bool(c.train) == (camera == "trained")]
    test = paths.split_dir(cfg, domain, "test")
    before, after, seconds, curves = [], [], [], []
    for k, shape_id in enumerate(test_ids(cfg, domain)[:n]):
        started = time.perf_counter()
        drawing = load_sketch(paths.sketch_file(test, shape_id, cams[k % len(cams)]))
        start, options = ranked_prediction(model, recipe, "sketch", drawing, cfg.eval.decode)
        result = fit_drawing(program, recipe, [Start(start, options)], drawing, budget, seed=cfg.seed,
                             read=reader(model, recipe, "sketch"), **sketch_fit_searches(cfg, domain))
        gt = read_obj(paths.shape_file(paths.shapes_dir(test), shape_id))
        for values, out in ((program.check(start), before), (result.values, after)):
            out.append(chamfer_meshes(program.evaluate(values), gt, n=cfg.eval.chamfer_points,
                                      rng=np.random.default_rng(0)))
        seconds.append(time.perf_counter() - started)
        curves.append(result.curve)
    return {"domain": domain, "camera": camera, "shapes": len(seconds), "budget": budget,
            **sketch_fit_searches(cfg, domain), "chamfer_before": round(float(np.mean(before)), 6),
            "chamfer_after": round(float(np.mean(after)), 6),
            **ratio_interval(before, after),
            "seconds_per_shape": round(statistics.median(seconds), 2),
            "curve": mean_curve(curves)}


def ratio_interval(before: Sequence[float], after: Sequence[float]) -> dict:
    """mean(after) / mean(before) over the shapes, with its 95% bootstrap interval (the shapes
    resampled in pairs): the targets are on this ratio, and on 30 shapes it is uncertain by
    about a tenth."""
    before, after = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    low, high = bootstrap_ci(before, after, statistic=ratio_of_means)
    return {"ratio": round(float(after.mean() / before.mean()), 3),
            "ratio_ci": [round(low, 3), round(high, 3)]}


def ratio_of_means(before: np.ndarray, after: np.ndarray, axis: int = -1) -> np.ndarray:
    return after.mean(axis=axis) / before.mean(axis=axis)
