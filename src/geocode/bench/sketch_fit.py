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
from geocode.config import sketch_fit_budget, sketch_fit_searches
from geocode.meshio import read_obj
from geocode.metrics import chamfer_meshes
from geocode.program import Program
from geocode.reconstruct.fit import Start
from geocode.reconstruct.sketchfit import fit_drawing, mean_curve
from geocode.steps.dataset import split_cameras
from geocode.steps.evaluate import split_ids
from geocode.steps.train_data import load_sketch


def bench_sketch_fit(cfg, domain: str, n: int = 10, camera: str = "trained", split: str = "val",
                     budget: int | None = None) -> dict:
    """The domain's trained joint model's predictions on the sketches of the first n shapes of
    a split (`camera` "trained": shape i from the i-th trained camera in turn; "novel": the
    untrained one), fitted to the sketch, measured against the ground truth by
    `metrics.chamfer_meshes`: before and after, and the median seconds per drawing (network,
    fit and both rebuilds included). budget: the fit's evaluations (default: the domain's
    eval.sketch_fit_budget)."""
    budget = sketch_fit_budget(cfg, domain) if budget is None else budget
    program = Program.load(domain)
    recipe = program.recipe()
    checkpoint = default_checkpoint(cfg, domain)
    model = load_model(checkpoint, recipe=recipe)
    cams = [c for c in cfg.data.sketch.cameras if bool(c.train) == (camera == "trained")]
    folder = paths.split_dir(cfg, domain, split)
    before, after, seconds, curves = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for k, shape_id in enumerate(split_ids(cfg, domain, split)[:n]):
            started = time.perf_counter()
            gt = read_obj(paths.shape_file(paths.shapes_dir(folder), shape_id))
            drawing = load_sketch(drawing_file(cfg, domain, split, shape_id, gt, cams[k % len(cams)], Path(tmp)))
            start, options = ranked_prediction(model, recipe, "sketch", drawing, cfg.eval.decode)
            result = fit_drawing(program, recipe, [Start(start, options)], drawing, budget, seed=cfg.seed,
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
            "curve": mean_curve(curves)}


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


def ratio_interval(before: Sequence[float], after: Sequence[float], resamples: int = 2000,
                   seed: int = 0) -> dict:
    """mean(after) / mean(before) over the shapes, with its 95% percentile bootstrap interval
    (the shapes resampled in pairs): the targets are on this ratio, and on 30 shapes it is
    uncertain by about a tenth."""
    before, after = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    picks = np.random.default_rng(seed).integers(0, len(before), (resamples, len(before)))
    low, high = np.percentile(after[picks].mean(axis=1) / before[picks].mean(axis=1), [2.5, 97.5])
    return {"ratio": round(float(after.mean() / before.mean()), 3),
            "ratio_ci": [round(float(low), 3), round(float(high), 3)]}


def renderer_agreement(domains: Sequence[str], n: int, seed: int = 0) -> dict:
    """How near `linedraw`'s drawings lie to Freestyle's (blender/sketch.py) of the same shapes
    and camera: per domain, over n random program shapes (`Program.random_values`, seeded),
    each seen from one of the dataset's trained views in turn, the mean `drawing_distance`
    between the two renders ("ours"), and between Freestyle's renders of two different shapes
    of the domain from the same view ("other shapes", the scale that gives it meaning)."""
    import tempfile
    from pathlib import Path

    from geocode.blender.sketch import Camera, renderer
    from geocode.meshio import normalise_unit_sphere
    from geocode.reconstruct.linedraw import Outline, View, drawing_distance, strokes
    from geocode.reconstruct.sketchfit import CAMERA_GUESSES

    freestyle = renderer()
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "view.png"
        for domain in domains:
            program, rng = Program.load(domain), np.random.default_rng(seed)
            ours, theirs, views = [], [], []
            while len(ours) < n:
                try:
                    mesh = normalise_unit_sphere(program.evaluate(program.random_values(rng)))
                except ValueError:
                    continue
                view = View(CAMERA_GUESSES[len(ours) % 2][0], CAMERA_GUESSES[len(ours) % 2][1])
                freestyle.set_mesh(mesh.vertices, mesh.faces)
                freestyle.render(Camera("view", view.azimuth, view.elevation), png)
                theirs.append(load_sketch(png))
                ours.append(strokes(Outline(mesh.vertices, mesh.faces), view))
                views.append(view)
            same = [drawing_distance(a, b) for a, b in zip(ours, theirs, strict=True)]
            other = [drawing_distance(theirs[i], theirs[(i + 2) % n]) for i in range(n)]
            out[domain] = {"shapes": n, "ours": round(float(np.mean(same)), 3),
                           "ours_max": round(float(np.max(same)), 3),
                           "other_shapes": round(float(np.mean(other)), 3)}
    return out
