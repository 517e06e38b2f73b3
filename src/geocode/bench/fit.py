"""The fit of `geocode reconstruct` on a run's clean clouds (`geocode bench fit`).

It measures on the validation split unless told otherwise: the fit's defaults are chosen from
it, and the tables report the test split ("pc + fit"), which no default is tuned on.
"""

from __future__ import annotations

import statistics

import numpy as np

from geocode import paths
from geocode.checkpoints import default_checkpoint, load_model, ranked_prediction
from geocode.config import settings
from geocode.meshio import read_obj
from geocode.metrics import chamfer_meshes
from geocode.program import Program
from geocode.reconstruct.fit import Start, fit
from geocode.steps.evaluate import clean_cloud, split_ids


def bench_fit(cfg, domain: str, n: int = 20, split: str = "val", budget: int | None = None) -> dict:
    """Fit the domain's trained joint model's predictions to the clean clouds of the first n
    shapes of a split of the run in `cfg` (as the evaluation's "pc + fit" does: no pose
    search), and measure against the ground truth. budget: the fit's evaluations (default
    eval.fit_budget). Each shape's distances come too, for paired comparisons of settings."""
    budget = cfg.eval.fit_budget if budget is None else budget
    tuning = settings(cfg).fit.cloud
    program = Program.load(domain)
    recipe = program.recipe()
    model = load_model(default_checkpoint(cfg, domain), recipe=recipe)
    shapes = paths.shapes_dir(paths.split_dir(cfg, domain, split))
    ids = split_ids(cfg, domain, split)[:n]
    before, after, seconds, evaluations = [], [], [], 0
    for shape_id in ids:
        cloud = clean_cloud(cfg, domain, split, shape_id)
        gt = read_obj(paths.shape_file(shapes, shape_id))
        start, options = ranked_prediction(model, recipe, "points", cloud, cfg.eval.decode)
        result = fit(program, recipe, [Start(start, options)], cloud, budget, tuning, seed=cfg.seed, pose=False)
        for values, out in ((program.check(start), before), (result.values, after)):
            rng = np.random.default_rng(0)
            out.append(chamfer_meshes(program.evaluate(values), gt, n=cfg.eval.chamfer_points, rng=rng))
        seconds.append(result.seconds)
        evaluations += result.evaluations
    return {"domain": domain, "split": split, "shapes": len(seconds), "budget": budget,
            "evals_per_s": round(evaluations / sum(seconds), 1),
            "chamfer_before": round(float(np.mean(before)), 6),
            "chamfer_after": round(float(np.mean(after)), 6),
            "seconds_per_shape": round(statistics.median(seconds), 2),
            "per_shape": [{"shape": shape_id, "chamfer_before": round(float(b), 6), "chamfer_after": round(float(a), 6)}
                          for shape_id, b, a in zip(ids, before, after, strict=True)]}
