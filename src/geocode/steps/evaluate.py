"""The evaluation steps (workflow/rules/evaluate.smk): simplify, predict, rebuild, metrics
(docs/paper-numbers.md#evaluation and #robustness).

Each model is tested on the inputs of every condition (`geocode.conditions`); the fitted
conditions' predictions are refined by `geocode.reconstruct.fit` in the rebuild step, which has the
program at hand. A simplified copy of the test split lives beside it as the split `test-s<factor>`, so the
ordinary sketch and points stages make its inputs.
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig

from geocode import paths
from geocode.card import write_card
from geocode.conditions import FITS, MODALITY_NAMES, SKETCH_FITTED, conditions, robustness, unfitted
from geocode.config import NAME, settings, sketch_fit_budget, sketch_fit_searches
from geocode.errors import UserError
from geocode.meshio import (
    REDO_EXPORT,
    normalise_unit_sphere,
    read_obj,
    read_parquet,
    write_obj,
    write_parquet,
    write_text,
)
from geocode.recipe import load_recipes
from geocode.seeds import generator
from geocode.steps.dataset import save_split_recipes, spread_subset

log = logging.getLogger("geocode.steps.evaluate")

KEYS = ["condition", "modality", "source", "camera", "noise", "sparse", "id"]
OPTIONS = "fit_options"  # predictions' column: JSON of each discrete parameter's candidate values


def test_ids(cfg: DictConfig, domain: str) -> list[str]:
    """The evaluated test shapes: at most eval.max_test_shapes, evenly spread over the split
    (so that every forced parameter class shows up), the same for every model variant."""
    return split_ids(cfg, domain, "test")


def split_ids(cfg: DictConfig, domain: str, split: str) -> list[str]:
    """A split's shapes chosen as `test_ids` chooses the test split's (the benchmarks measure
    the validation split's the same way)."""
    recipes = load_recipes(paths.recipes_file(paths.split_dir(cfg, domain, split)))
    return spread_subset(recipes, cfg.eval.max_test_shapes)["id"].tolist()


def fitted_ids(cfg: DictConfig, ids: list[str]) -> list[str]:
    """The test shapes whose predictions are also fitted: at most eval.max_fit_shapes of `ids`,
    evenly spread (the fit costs 10-100x a prediction)."""
    return spread_subset(pd.DataFrame({"id": ids}), cfg.eval.max_fit_shapes)["id"].tolist()


# -- robustness inputs ------------------------------------------------------------------------

def simplify_step(cfg: DictConfig, domain: str, factor: int) -> str:
    """Quadric-decimate the evaluated test meshes to 1/factor of their faces, as split test-s<f>."""
    from geocode.points import simplify

    dst = paths.split_dir(cfg, domain, paths.check_split(cfg, paths.simplified_split(factor)))
    src = paths.split_dir(cfg, domain, "test")
    recipes = load_recipes(paths.recipes_file(src))
    recipes = recipes[recipes["id"].isin(test_ids(cfg, domain))]
    save_split_recipes(dst, recipes, paths.program_key(cfg, domain))
    faces_before = faces_after = 0
    for shard in range(cfg.data.shards):
        rows = recipes[recipes["shard"] == shard]
        for shape_id in rows["id"]:
            mesh = read_obj(paths.shape_file(paths.shapes_dir(src), shape_id), REDO_EXPORT)
            small = normalise_unit_sphere(simplify(mesh, 1.0 / factor))
            write_obj(paths.shape_file(paths.shapes_dir(dst), shape_id), small)
            faces_before += len(mesh.faces)
            faces_after += len(small.faces)
        write_text(paths.done_file(dst, "export", shard), "".join(f"{i}\n" for i in rows["id"]))
    return f"{domain} 1/{factor}: {faces_before} -> {faces_after} faces over {len(recipes)} shapes"


def point_input(cfg: DictConfig, domain: str, cond: dict, shape_id: str) -> np.ndarray:
    """The evaluation cloud of one shape under one condition, float32 (N, 3)."""
    from geocode.points import add_noise, sparse_cloud

    rng = generator(cfg.seed, "eval", cond["condition"], shape_id)
    if cond["sparse"]:
        mesh = read_obj(paths.shape_file(paths.shapes_dir(paths.split_dir(cfg, domain, "test")), shape_id), REDO_EXPORT)
        return sparse_cloud(mesh, cond["sparse"], rng)
    cloud = clean_cloud(cfg, domain, paths.source_split(cond["source"]), shape_id)
    return add_noise(cloud, cond["noise"], rng) if cond["noise"] else cloud


def clean_cloud(cfg: DictConfig, domain: str, split: str, shape_id: str) -> np.ndarray:
    """The evaluation cloud of one shape of a split, without noise, float32 (N, 3)."""
    from geocode.points import eval_cloud, load_clouds

    clouds = load_clouds(paths.cloud_file(paths.split_dir(cfg, domain, split), shape_id))
    return eval_cloud(clouds, cfg.data.points.train_random, cfg.seed, shape_id)


def sketch_path(cfg: DictConfig, domain: str, cond: dict, shape_id: str) -> Path:
    split = paths.split_dir(cfg, domain, paths.source_split(cond["source"]))
    return paths.sketch_file(split, shape_id, cond["camera"])


def model_input(cfg: DictConfig, domain: str, cond: dict, shape_id: str) -> tuple[str, np.ndarray]:
    """("points", cloud) or ("sketch", drawing) of one shape under a pc or sketch condition."""
    from geocode.steps.train_data import load_sketch

    if cond["modality"] == "pc":
        return "points", point_input(cfg, domain, cond, shape_id)
    return "sketch", load_sketch(sketch_path(cfg, domain, cond, shape_id))


# -- prediction ---------------------------------------------------------------------------------

def predict_step(cfg: DictConfig, domain: str, checkpoint: Path, out: Path) -> str:
    """Predict every condition's test inputs, denormalise, and write one parquet of values."""
    from geocode.checkpoints import load_model, predict_values, ranked_prediction
    from geocode.recipe import load_recipe
    from geocode.steps.train_data import load_sketch

    recipe = load_recipe(cfg)
    model = load_model(checkpoint, recipe=recipe)
    ids = test_ids(cfg, domain)
    full = robustness(model.hparams.variant)
    decode = cfg.eval.decode
    modalities = [MODALITY_NAMES[m] for m in model.modalities]
    frames = []
    for cond in conditions(cfg, modalities, full):
        start = time.perf_counter()
        shape_ids = ids
        if cond["modality"] in FITS.values():  # the fit's start: the prediction and its likeliest classes
            shape_ids = fitted_ids(cfg, ids)
            ranked = [ranked_prediction(model, recipe, *model_input(cfg, domain, unfitted(cond), i), decode)
                      for i in shape_ids]
            frame = pd.DataFrame([values for values, _ in ranked])
            frame[OPTIONS] = [json.dumps(options) for _, options in ranked]
        elif cond["modality"] == "pc":
            batch = np.stack([point_input(cfg, domain, cond, i) for i in ids])
            frame = pd.DataFrame(predict_values(model, recipe, "points", batch, decode))
        else:
            batch = np.stack([load_sketch(sketch_path(cfg, domain, cond, i)) for i in ids])
            frame = pd.DataFrame(predict_values(model, recipe, "sketch", batch, decode))
        frames.append(frame.assign(**cond, id=shape_ids))
        log.info("%s: %d shapes in %.1f s", cond["condition"], len(shape_ids), time.perf_counter() - start)
    if full:
        frames.append(mean_shape(cfg, domain, recipe))
    table = pd.concat(frames, ignore_index=True)
    write_parquet(out, table[KEYS + [c for c in table.columns if c not in KEYS]])
    return f"{domain}: {len(table)} predictions"


def mean_shape(cfg: DictConfig, domain: str, recipe) -> pd.DataFrame:
    """The baseline: every parameter at its most frequent class in the training split (the
    stronger constant: each continuous parameter at its median class is further from the test
    shapes, docs/design.md#decoding)."""
    train = load_recipes(paths.recipes_file(paths.split_dir(cfg, domain, "train")))
    classes = recipe.class_matrix(train)                        # (n, P)
    common = {p.name: int(np.bincount(classes[:, j]).argmax()) for j, p in enumerate(recipe.parameters)}
    values = recipe.values_from_classes(common)
    return pd.DataFrame([values]).assign(condition="baseline", modality="baseline", source="test",
                                         camera="", noise=0.0, sparse=0, id="mean-shape")


def read_predictions(path: Path) -> pd.DataFrame:
    table = read_parquet(path, "rerun the predict step")
    missing = [k for k in KEYS if k not in table]
    if missing:
        raise UserError(path, f"no column {missing[0]!r}: not a predictions file", "give the predict step's output")
    names = pd.concat([table["condition"], table["id"]]).astype(str)
    bad = names[~names.str.fullmatch(NAME.pattern)]
    if len(bad):  # they become folder and file names
        raise UserError(path, f"condition or id {bad.iloc[0]!r} is not a plain name", "give the predict step's output")
    return table


# -- rebuilding ---------------------------------------------------------------------------------

def rebuild_step(cfg: DictConfig, domain: str, predictions: Path, shard: int) -> str:
    """Rebuild every n-th prediction with the program, into the rebuilt folder beside the
    predictions (`paths.rebuilt_mesh`). Fitted conditions are fitted first, from the
    prediction, to the condition's input cloud; their distances before and after and the
    time go to the shard's `paths.fit_file`."""
    from geocode.blender.rebuild import rebuild
    from geocode.program import Program

    program = Program.load(domain)
    recipe = program.recipe()
    table = read_predictions(predictions).iloc[shard::cfg.data.shards]
    names = [c for c in table.columns if c not in KEYS + [OPTIONS]]
    out_dir = paths.rebuilt_dir(predictions)
    jobs, fits = [], []
    read = None
    if (table["modality"] == SKETCH_FITTED).any():   # the drawing fit's network feedback
        from geocode.checkpoints import load_model, reader

        model = load_model(paths.checkpoint_file(paths.run_of(predictions)), recipe=recipe)
        read = reader(model, recipe, "sketch")
    for r in table.to_dict("records"):
        values = {n: r[n] for n in names}
        if r["modality"] in FITS.values():
            values, stats = fit_prediction(cfg, domain, program, recipe, r, values, read)
            fits.append(stats)
        jobs.append((paths.rebuilt_key(r["condition"], r["id"]), values))
    rebuild(domain, jobs, out_dir, program=program)
    if fits:
        write_parquet(paths.fit_file(out_dir, shard), pd.DataFrame(fits))
    write_text(paths.rebuilt_done(out_dir, shard), "".join(f"{key}\n" for key, _ in jobs))
    return f"{domain}: rebuilt {len(jobs)} shapes, {len(fits)} of them fitted"


def fit_prediction(cfg: DictConfig, domain: str, program, recipe, row: dict, values: dict,
                   read=None) -> tuple[dict, dict]:
    """(fitted values, the fit's record) of one prediction of a fitted condition: a cloud's
    by `geocode.reconstruct.fit` (eval.fit_budget), a sketch's by `geocode.reconstruct.sketchfit` (its distances in
    px; `config.sketch_fit_budget`; `read`: the model's `checkpoints.reader`)."""
    from geocode.reconstruct.fit import Start, fit
    from geocode.reconstruct.sketchfit import fit_drawing

    kind, target = model_input(cfg, domain, unfitted(row), row["id"])
    start, tuning = [Start(values, json.loads(row[OPTIONS]))], settings(cfg).fit
    if kind == "sketch":
        result = fit_drawing(program, recipe, start, target, sketch_fit_budget(cfg, domain), tuning.drawing,
                             seed=cfg.seed, read=read, **sketch_fit_searches(cfg, domain))
    else:   # test clouds sit in the program's own frame, so the pose is not searched
        result = fit(program, recipe, start, target, cfg.eval.fit_budget, tuning.cloud, seed=cfg.seed, pose=False)
    stats = {"condition": row["condition"], "id": row["id"], "before": result.before, "after": result.after,
             "evaluations": result.evaluations, "seconds": result.seconds}
    return result.values, stats


# -- metrics ----------------------------------------------------------------------------------

NEAREST = "nearest"   # the retrieval baseline's condition and modality


def nearest_rows(cfg: DictConfig, domain: str, gt_meshes: dict) -> list[dict]:
    """The retrieval baseline: each test shape's distance to the nearest training shape
    (`geocode.reconstruct.retrieval`: plain Chamfer). Test shapes stand in the program's own
    frame, as its answers do, so no turn is tried (a real shape's retrieval tries four)."""
    from geocode.reconstruct.retrieval import TrainingShapes

    start = time.perf_counter()
    shapes = TrainingShapes.from_split(paths.split_dir(cfg, domain, "train"))
    rows = [dict(condition=NEAREST, modality=NEAREST, source="test", camera="", noise=0.0, sparse=0,
                 id=i, chamfer=shapes.nearest(mesh, n=cfg.eval.chamfer_points, turns=(0.0,)).chamfer,
                 stable=np.nan)
            for i, mesh in gt_meshes.items()]
    log.info("nearest training shapes of %d shapes in %.1f s", len(rows), time.perf_counter() - start)
    return rows


def hangs(cfg: DictConfig, domain: str) -> bool:
    """Whether the domain's program hangs (its manifest says so): a drop test does not apply."""
    return bool(json.loads(paths.manifest_path(cfg, domain).read_text()).get("hangs", False))


def metrics_step(cfg: DictConfig, domain: str, variant: str, predictions: Path, out: Path) -> str:
    """Chamfer distance of every rebuilt prediction of a model variant to its ground truth;
    for the joint model the drop test on the ground truth and on the clean predictions (none for a program that
    hangs); one row per prediction (and per GT shape)."""
    from geocode.metrics import chamfer_meshes
    from geocode.stability import drop_test

    hanging = hangs(cfg, domain)  # a ceiling lamp: `stable` stays NaN
    table = read_predictions(predictions)
    rebuilt = paths.rebuilt_dir(predictions)
    gt_dir = paths.shapes_dir(paths.split_dir(cfg, domain, "test"))
    cams = {c.name for c in cfg.data.sketch.cameras if c.train}
    gt_meshes = {i: read_obj(paths.shape_file(gt_dir, i), REDO_EXPORT) for i in test_ids(cfg, domain)}
    full = robustness(variant)
    rows = []
    for rec in table[KEYS].to_dict("records"):
        pred = read_obj(paths.rebuilt_mesh(rebuilt, rec["condition"], rec["id"]),
                        "delete it and rerun the rebuild step")
        targets = gt_meshes.items() if rec["modality"] == "baseline" else [(rec["id"], gt_meshes[rec["id"]])]
        clean = rec["source"] == "test" and not rec["noise"] and not rec["sparse"]
        stable = np.nan
        if full and clean and not hanging and (rec["modality"] == "pc" or rec["camera"] in cams):
            stable = float(drop_test(pred)["stable"])
        for gt_id, gt in targets:
            rng = generator(cfg.seed, "chamfer", rec["condition"], gt_id)
            cd = chamfer_meshes(pred, gt, n=cfg.eval.chamfer_points, rng=rng)
            rows.append({**rec, "id": gt_id, "chamfer": cd, "stable": stable})
    if full:
        rows += nearest_rows(cfg, domain, gt_meshes)
        rows += [dict(condition="gt", modality="gt", source="test", camera="", noise=0.0, sparse=0,
                      id=i, chamfer=np.nan, stable=np.nan if hanging else float(drop_test(m)["stable"]))
                 for i, m in gt_meshes.items()]
    frame = pd.DataFrame(rows).assign(domain=domain, variant=variant)
    write_parquet(out, frame)
    write_card(paths.run_of(out))
    return f"{domain}/{variant}: {len(frame)} metric rows"
