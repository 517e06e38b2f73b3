"""The fit of `geocode reconstruct` on a run's clean test clouds (`geocode bench fit`)."""

from __future__ import annotations

import statistics

import numpy as np

from geocode import paths
from geocode.checkpoints import default_checkpoint, load_model, ranked_prediction
from geocode.conditions import conditions
from geocode.reconstruct.fit import Start, fit
from geocode.meshio import read_obj
from geocode.metrics import chamfer_meshes
from geocode.program import Program
from geocode.steps.evaluate import point_input, test_ids


def bench_fit(cfg, domain: str, n: int = 10) -> dict:
    """Fit the domain's trained joint model's predictions to the clean test clouds of the
    run in `cfg` (as `geocode reconstruct` does), and measure against the ground truth."""
    program = Program.load(domain)
    recipe = program.recipe()
    checkpoint = default_checkpoint(cfg, domain)
    model = load_model(checkpoint, recipe=recipe)
    clean = next(c for c in conditions(cfg) if c["condition"] == "pc")
    before, after, seconds, evaluations = [], [], [], 0
    for shape_id in test_ids(cfg, domain)[:n]:
        cloud = point_input(cfg, domain, clean, shape_id)
        gt = read_obj(paths.shape_file(paths.shapes_dir(paths.split_dir(cfg, domain, "test")), shape_id))
        start, options = ranked_prediction(model, recipe, "points", cloud, cfg.eval.decode)
        result = fit(program, recipe, [Start(start, options)], cloud, cfg.eval.fit_budget,
                     seed=cfg.seed, pose=False)
        for values, out in ((program.check(start), before), (result.values, after)):
            rng = np.random.default_rng(0)
            out.append(chamfer_meshes(program.evaluate(values), gt, n=cfg.eval.chamfer_points, rng=rng))
        seconds.append(result.seconds)
        evaluations += result.evaluations
    return {"domain": domain, "shapes": len(seconds), "budget": cfg.eval.fit_budget,
            "evals_per_s": round(evaluations / sum(seconds), 1),
            "chamfer_before": round(float(np.mean(before)), 6),
            "chamfer_after": round(float(np.mean(after)), 6),
            "seconds_per_shape": round(statistics.median(seconds), 2)}
