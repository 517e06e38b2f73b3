"""Fitting to drawings (`geocode bench fit <domain> --modality sketch`): the trained joint
model's predictions on a run's sketches, fitted to the sketch (`geocode.reconstruct.sketchfit`),
and measured against the ground truth.

It measures on the validation split unless told otherwise: the drawing fit's defaults are
chosen from it, and the tables report the test split ("sketch + fit"). The dataset draws the
validation shapes from the trained cameras only; their drawings from the novel camera are
rendered here as the dataset renders the test split's.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from geocode import paths
from geocode.checkpoints import default_checkpoint, load_model, ranked_prediction, reader
from geocode.config import settings, sketch_fit_budget, sketch_fit_searches
from geocode.meshio import read_obj
from geocode.metrics import chamfer_meshes
from geocode.program import Program
from geocode.reconstruct.fit import Start
from geocode.reconstruct.sketchfit import fit_drawing, mean_curve
from geocode.steps.dataset import split_cameras
from geocode.steps.evaluate import split_ids
from geocode.steps.tables import bootstrap_ci
from geocode.steps.train_data import load_sketch


def bench_sketch_fit(cfg, domain: str, n: int = 10, camera: str = "trained", split: str = "val",
                     budget: int | None = None) -> dict:
    """The domain's trained joint model's predictions on the sketches of the first n shapes of
    a split (`camera` "trained": shape i from the i-th trained camera in turn; "novel": the
    untrained one), fitted to the sketch, measured against the ground truth by
    `metrics.chamfer_meshes`: before and after, and the median seconds per drawing (network,
    fit and both rebuilds included). budget: the fit's evaluations (default: the domain's
    eval.sketch_fit_budget). Each shape's distances and seconds come too, for paired
    comparisons of settings."""
    budget = sketch_fit_budget(cfg, domain) if budget is None else budget
    tuning = settings(cfg).fit.drawing
    program = Program.load(domain)
    recipe = program.recipe()
    checkpoint = default_checkpoint(cfg, domain)
    model = load_model(checkpoint, recipe=recipe)
    cams = [c for c in cfg.data.sketch.cameras if bool(c.train) == (camera == "trained")]
    folder = paths.split_dir(cfg, domain, split)
    ids = split_ids(cfg, domain, split)[:n]
    before, after, seconds, curves = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for k, shape_id in enumerate(ids):
            started = time.perf_counter()
            gt = read_obj(paths.shape_file(paths.shapes_dir(folder), shape_id))
            drawing = load_sketch(drawing_file(cfg, domain, split, shape_id, gt, cams[k % len(cams)], Path(tmp)))
            start, options = ranked_prediction(model, recipe, "sketch", drawing, cfg.eval.decode)
            result = fit_drawing(program, recipe, [Start(start, options)], drawing, budget, tuning, seed=cfg.seed,
                                 read=reader(model, recipe, "sketch"), **sketch_fit_searches(cfg, domain))
            for values, out in ((program.check(start), before), (result.values, after)):
                out.append(chamfer_meshes(program.evaluate(values), gt, n=cfg.eval.chamfer_points,
                                          rng=np.random.default_rng(0)))
            seconds.append(time.perf_counter() - started)
            curves.append(result.curve)
    return {"domain": domain, "split": split, "camera": camera, "shapes": len(seconds), "budget": budget,
            **sketch_fit_searches(cfg, domain), "chamfer_before": round(float(np.mean(before)), 6),
            "chamfer_after": round(float(np.mean(after)), 6),
            **ratio_interval(before, after),
            "seconds_per_shape": round(statistics.median(seconds), 2),
            "curve": mean_curve(curves),
            "per_shape": [{"shape": shape_id, "chamfer_before": round(float(b), 6), "chamfer_after": round(float(a), 6),
                           "seconds": round(t, 2)}
                          for shape_id, b, a, t in zip(ids, before, after, seconds, strict=True)]}


def drawing_file(cfg, domain: str, split: str, shape_id: str, mesh, camera, tmp: Path) -> Path:
    """A shape's drawing from a camera of `cfg.data.sketch.cameras`: the dataset's, where it
    draws the split from that camera (`split_cameras`), else rendered into `tmp` as the
    dataset renders (same size, jitter and seed)."""
    s = cfg.data.sketch
    if camera.name in {c.name for c in split_cameras(s.cameras, split)}:
        return paths.sketch_file(paths.split_dir(cfg, domain, split), shape_id, camera.name)
    from geocode.blender.sketch import cameras_from_config, sketch_mesh

    path = tmp / f"{shape_id}_{camera.name}.png"
    sketch_mesh(mesh, {camera.name: path}, cameras_from_config([camera], s.elevation), shape_id,
                cfg.seed, s.jitter, s.size)
    return path


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
