"""The scaling curve (`geocode bench curve`): how near the network's answers come to the
validation shapes, beside the nearest training shape, as the training set and the epochs grow.

The domain's training split is sampled once at the largest factor times the profile's training
variations (`data.variations.train`, or the domain's `data.domain_variations` entry) and exported
with its clouds (no sketches: the point branch is what the curve measures), beside the profile's
validation split. The training split of factor f holds the first f x variations draws of each
(forced parameter, class): the splits are nested, and factor 1 is the profile's own training
split (a draw that a larger sample takes first, as a duplicate, is redrawn; `curve.json` counts
such shapes). `data.max_shapes.train` does not apply: the sizes come from the variations.

A points-only model (`train.modalities=[points]`) is trained on each training split at the
domain's epochs (`config.max_epochs`: the training-shapes axis), and on factor 1 at each of
`epochs` (the epochs axis). Each is scored on the validation split, never the test split (the
curve chooses the default run's size): every shape's Chamfer distance from the network's
answer (the profile's read, `eval.decode`) and from the nearest shape of the same training
split, each with its mean and 95% bootstrap interval, their ratio and the paired Wilcoxon p.

A least-squares line of log(distance) on log(training shapes) for each, over the points of the
training-shapes axis, says where the two lines cross and what they would be at the paper
profile's training-set size: an extrapolation of a power law fitted on a few points, not a
measurement.

<DIR>/data, build and runs hold the work; a second call reuses the finished data, trainings
and scores. A changed setting trains afresh, and another largest factor samples, exports and
trains afresh (its draws number the shapes, and a shape's clouds are drawn from its number).
The results: curve.json, curve.csv, curve.md, curve.svg (against training shapes) and
curve-epochs.svg (against epochs).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import logging
import math
import os
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig, OmegaConf

from geocode import paths
from geocode.bench.plot import COLOURS, Series, line_plot
from geocode.config import compose, max_epochs, split_variations, training_key
from geocode.errors import UserError
from geocode.meshio import read_obj, write_text
from geocode.outputs import Outputs
from geocode.recipe import META_COLUMNS, load_recipes
from geocode.seeds import generator
from geocode.steps.dataset import (
    SamplingError,
    assign_shards,
    sample_dataset,
    save_split_recipes,
    split_sizes,
    spread_subset,
)
from geocode.steps.tables import bootstrap_ci, wilcoxon_p
from geocode.timing import Stopwatch

log = logging.getLogger(__name__)

RESULTS = ("curve.json", "curve.csv", "curve.md", "curve.svg", "curve-epochs.svg")
WORK = ("data", "build", "runs")
FULL = "all"                 # the data folder of the largest training split, which the others link into
RECORD = "curve-point.json"  # in a run folder: what it was trained on, its seconds and its distances
EXTRAPOLATION = ("an extrapolation of a power law fitted by least squares on log-log to {n} points, "
                 "not a measurement")


def bench_curve(overrides: Sequence[str], domain: str, factors: Sequence[int], epochs: Sequence[int],
                val_shapes: int | None, out: Path) -> dict:
    """Data, trainings and scores of the curve in `out` (see the module's docstring); returns
    curve.json's content."""
    check_request(factors, epochs, out)
    from geocode.program import Program

    program = Program.load(domain)
    base = curve_config(domain, overrides, out, FULL)
    write_text(paths.manifest_path(base, domain), json.dumps(program.manifest(), indent=1))
    recipe = program.recipe()
    sizes, x1_redrawn = make_data(base, domain, program, recipe, sorted({1, *factors}), out)
    val_dir = paths.split_dir(base, domain, "val")
    ids = spread_subset(load_recipes(paths.recipes_file(val_dir)), val_shapes)["id"].tolist()
    gts = {i: read_obj(paths.shape_file(paths.shapes_dir(val_dir), i)) for i in ids}
    domain_epochs = max_epochs(base, base.model.variant)
    nearest: dict[int, list[float]] = {}
    plan, points = curve_points(factors, epochs, domain_epochs), []
    for factor, e, axes in plan:
        cfg = curve_config(domain, overrides, out, factor, e)
        point = measure_point(cfg, domain, program, recipe, out / "runs" / f"x{factor}-e{e}", gts, nearest, factor)
        points.append({"factor": factor, "epochs": e, "axes": axes, "training_shapes": sizes[factor], **point})
        log.info("curve %s x%d, %d epochs: network %.5f, nearest %.5f", domain, factor, e,
                 np.mean(point["network"]), np.mean(point["nearest"]))
        if sum("shapes" in p["axes"] for p in points) >= 2:   # the curve so far, after each training
            result = {**summarise(base, domain, recipe, points, ids, domain_epochs), "x1_redrawn": x1_redrawn,
                      "trainings": f"{len(points)} of {len(plan)}"}
            write_results(out, result)
    return result


# -- the request ----------------------------------------------------------------------------------

def check_request(factors: Sequence[int], epochs: Sequence[int], out: Path) -> None:
    """Factors and epochs increasing and at least 1; the output folder new, empty or a curve's."""
    for name, values in (("--factors", factors), ("--epochs", epochs)):
        if min(values) < 1 or any(b <= a for a, b in itertools.pairwise(values)):
            raise UserError(f"{name} {' '.join(map(str, values))}", "not increasing whole numbers >= 1",
                            f"give them smallest first, e.g. {name} " + ("1 2 4 8" if name == "--factors" else "16 48"))
    if len(factors) < 2:
        raise UserError(f"--factors {factors[0]}", "one training-set size makes no curve", "give at least two")
    other = sorted(p.name for p in out.iterdir() if not ours(p.name)) if out.is_dir() else []
    if other:
        raise UserError(out, f"holds {other[0]}, which `geocode bench curve` did not write",
                        "give a new or empty folder, or a curve's folder to go on with it")


def ours(name: str) -> bool:
    """Whether a name in the output folder is the curve's: its work, its results, or a result's
    temporary file (`Outputs`) that a killed process left."""
    return name in (*RESULTS, *WORK) or any(name.startswith(f".{r}.") and name.endswith(".tmp") for r in RESULTS)


def curve_config(domain: str, overrides: Sequence[str], out: Path, factor: int | str, epochs: int | None = None):
    """The config of the curve's data (factor FULL) or of its training at (factor, epochs):
    a points-only model, the program's manifest under <out>/build, the factor's data root."""
    fixed = ["train.modalities=[points]", *([f"++train.domain_epochs.{domain}={epochs}"] if epochs else [])]
    cfg = compose([f"domain={domain}", *overrides, *fixed])
    OmegaConf.update(cfg, "paths.build", str(out / "build"))
    OmegaConf.update(cfg, "paths.data", str(data_root(out, factor)))
    return cfg


def data_root(out: Path, factor: int | str) -> Path:
    return out / "data" / (factor if factor == FULL else f"x{factor}")


def curve_points(factors: Sequence[int], epochs: Sequence[int], domain_epochs: int) -> list[tuple[int, int, list[str]]]:
    """(factor, epochs, the axes it is on) of every training: each factor at the domain's
    epochs ("shapes"), factor 1 at each of `epochs` and at the domain's ("epochs"); a training
    on both comes once."""
    plan: dict[tuple[int, int], list[str]] = {}
    on_epochs = sorted({*epochs, *([domain_epochs] if 1 in factors else [])})
    for point, axis in [*(((f, domain_epochs), "shapes") for f in factors), *(((1, e), "epochs") for e in on_epochs)]:
        plan.setdefault(point, []).append(axis)
    return [(f, e, axes) for (f, e), axes in plan.items()]


# -- the data -------------------------------------------------------------------------------------

def make_data(cfg: DictConfig, domain: str, program, recipe, factors: Sequence[int],
              out: Path) -> tuple[dict[int, int], int]:
    """The training split at the largest factor and the validation split, exported with their
    clouds under data/all, and each factor's nested training split under data/x<factor>:
    ({factor: its training shapes}, how many shapes of factor 1 the profile's sampling lacks)."""
    per_class = split_variations(cfg, domain, clouds=False)
    try:
        splits = sample_dataset(recipe, {**per_class, "train": per_class["train"] * max(factors)},
                                seed=cfg.seed, domain=domain)
    except SamplingError as exc:
        raise UserError(f"--factors {' '.join(map(str, factors))}", str(exc), "give smaller factors") from None
    key = paths.program_key(cfg, domain)
    full = paths.domain_dir(cfg, domain)
    for split, frame in (("train", splits["train"]), ("val", spread_subset(splits["val"], cfg.data.max_shapes.val))):
        export_split(cfg, full / split, frame, key, domain, program, recipe)
    sizes = {}
    for f in factors:
        subset = nested_subset(splits["train"], per_class["train"] * f)
        link_split(full, data_root(out, f) / domain, subset, key)
        sizes[f] = len(subset)
    default = sample_dataset(recipe, per_class, seed=cfg.seed, domain=domain)["train"]
    return sizes, redrawn(nested_subset(splits["train"], per_class["train"]), default)


def export_split(cfg: DictConfig, split_dir: Path, frame: pd.DataFrame, key: str, domain: str, program,
                 recipe) -> None:
    """A split's shapes and clouds, as the export and points steps make them (one shard); a
    stage whose done file is there is finished."""
    from geocode.blender.export import export_shard
    from geocode.points import points_shard

    save_split_recipes(split_dir, assign_shards(frame, 1), key)
    if not paths.done_file(split_dir, "export", 0).exists():
        export_shard(split_dir, 0, domain, program, recipe)
    if not paths.done_file(split_dir, "points", 0).exists():
        points_shard(split_dir, 0, cfg.data.points, cfg.seed)


def nested_subset(frame: pd.DataFrame, per_class: int) -> pd.DataFrame:
    """The first `per_class` draws of each (forced parameter, class), in the frame's order."""
    return frame[frame.groupby(["forced", "forced_class"]).cumcount() < per_class].reset_index(drop=True)


def redrawn(subset: pd.DataFrame, default: pd.DataFrame) -> int:
    """How many of the subset's shapes the default sampling does not hold (by their values)."""
    values = [c for c in default.columns if c not in META_COLUMNS]
    mine, theirs = (set(map(tuple, f[["forced", "forced_class", *values]].itertuples(index=False)))
                    for f in (subset, default))
    return len(mine - theirs)


def link_split(full: Path, domain_dir: Path, subset: pd.DataFrame, key: str) -> None:
    """<domain_dir>/train: the subset's recipes, with links to its meshes and clouds in
    <full>/train; <domain_dir>/val: a link to <full>/val."""
    train = domain_dir / "train"
    save_split_recipes(train, assign_shards(subset, 1), key)
    for shape_id in subset["id"]:
        for source in (paths.shape_file(paths.shapes_dir(full / "train"), shape_id),
                       paths.cloud_file(full / "train", shape_id)):
            link = train / source.parent.name / source.name
            if not link.is_symlink():
                link.parent.mkdir(parents=True, exist_ok=True)
                link.symlink_to(os.path.relpath(source, link.parent))
    val = domain_dir / "val"
    if not val.is_symlink():
        val.symlink_to(os.path.relpath(full / "val", domain_dir))


# -- a training and its scores -------------------------------------------------------------------

def measure_point(cfg: DictConfig, domain: str, program, recipe, run: Path, gts: dict, nearest: dict,
                  factor: int) -> dict:
    """Train the run's model (or reuse it: a run trained on other data or settings is deleted
    and trained afresh) and score it on the validation shapes `gts` (or reuse the scores of the
    same shapes): {"network", "nearest": per-shape distances, "train_seconds", "resumed"}.
    `nearest` caches each factor's nearest-shape distances."""
    from geocode.steps.train import train

    ids, record = list(gts), run / RECORD
    stamp = {"settings": training_key(cfg, epochs=True), "program": paths.program_key(cfg, domain),
             "data": data_hash(paths.split_dir(cfg, domain, "train"))}
    done = json.loads(record.read_text()) if record.exists() else {}
    if any(done.get(k) != v for k, v in stamp.items()) and run.exists():
        log.info("%s: trained on other data or settings; training afresh", run)
        shutil.rmtree(run)
        done = {}
    if done.get("val") == ids:
        nearest.setdefault(factor, done["nearest"])
    else:
        if "train_seconds" not in done:
            write_text(record, json.dumps(stamp))
            with Stopwatch() as clock:
                trained = train(cfg, out_dir=run)
            done = {**stamp, "train_seconds": round(clock.seconds, 1), "resumed": trained["resumed"]}
        if factor not in nearest:
            from geocode.steps.evaluate import nearest_rows

            nearest[factor] = [row["chamfer"] for row in nearest_rows(cfg, domain, gts)]
        done = {**done, "val": ids, "nearest": nearest[factor],
                "network": network_distances(cfg, domain, program, recipe, paths.checkpoint_file(run), gts)}
        write_text(record, json.dumps(done))
    return {k: done[k] for k in ("network", "nearest", "train_seconds", "resumed")}


def data_hash(split_dir: Path) -> str:
    """A short hash of a split's recipes (which shapes, with which values)."""
    frame = load_recipes(paths.recipes_file(split_dir))
    return hashlib.sha1(pd.util.hash_pandas_object(frame, index=False).to_numpy().tobytes()).hexdigest()[:10]


def network_distances(cfg: DictConfig, domain: str, program, recipe, checkpoint: Path, gts: dict) -> list[float]:
    """Each validation shape's Chamfer distance from the model's answer to its clean cloud,
    rebuilt by the program, as the metrics step measures the test shapes."""
    from geocode.blender.export import unit_mesh
    from geocode.checkpoints import load_model, predict_values
    from geocode.metrics import chamfer_meshes
    from geocode.steps.evaluate import clean_cloud

    model = load_model(checkpoint, recipe=recipe)
    clouds = np.stack([clean_cloud(cfg, domain, "val", i) for i in gts])
    answers = predict_values(model, recipe, "points", clouds, cfg.eval.decode)
    return [chamfer_meshes(unit_mesh(program, values), gt, n=cfg.eval.chamfer_points,
                           rng=generator(cfg.seed, "chamfer", "curve", i))
            for values, (i, gt) in zip(answers, gts.items(), strict=True)]


# -- the summary ----------------------------------------------------------------------------------

def summarise(cfg: DictConfig, domain: str, recipe, points: list[dict], ids: list[str], domain_epochs: int) -> dict:
    rows = [point_row(p, ids) for p in points]
    shapes_axis = sorted((r for r in rows if "shapes" in r["axes"]), key=lambda r: r["training_shapes"])
    n = [r["training_shapes"] for r in shapes_axis]
    laws = {name: power_law(n, [r[name] for r in shapes_axis]) for name in ("network", "nearest")}
    paper = split_sizes(compose([f"domain={domain}", "profile=paper"]), recipe, domain)["train"]
    return {
        "domain": domain, "profile": cfg.profile_name, "val_shapes": len(ids), "decode": cfg.eval.decode,
        "shapes_axis_epochs": domain_epochs, "points": rows,
        "crossing": crossing(n, [r["network"] for r in shapes_axis], [r["nearest"] for r in shapes_axis]),
        "power_law": laws,
        "extrapolation": {"training_shapes": paper, "profile": "paper",
                          **{name: float(f"{law['scale'] * paper ** law['exponent']:.4g}")
                             for name, law in laws.items()},
                          "note": EXTRAPOLATION.format(n=len(n))},
    }


def point_row(point: dict, ids: list[str]) -> dict:
    """A point's means, intervals, ratio and p from its per-shape distances."""
    net, near = (pd.Series(point[k], index=ids, dtype=float) for k in ("network", "nearest"))
    return {**{k: point[k] for k in ("factor", "epochs", "axes", "training_shapes", "train_seconds", "resumed")},
            "network": round(float(net.mean()), 6), "network_ci": [round(v, 6) for v in bootstrap_ci(net)],
            "nearest": round(float(near.mean()), 6), "nearest_ci": [round(v, 6) for v in bootstrap_ci(near)],
            "ratio": float(f"{net.mean() / near.mean():.4g}"), "p": float(f"{wilcoxon_p(net, near):.3g}")}


def power_law(n: Sequence[float], distance: Sequence[float]) -> dict:
    """distance = scale * n ** exponent, fitted by least squares on log(distance) against log(n)."""
    exponent, log_scale = np.polyfit(np.log(n), np.log(distance), 1)
    return {"exponent": round(float(exponent), 4), "scale": float(f"{math.exp(log_scale):.6g}")}


def crossing(n: Sequence[float], network: Sequence[float], nearest: Sequence[float]) -> dict:
    """Where the network's line crosses the nearest shape's, both straight between measured
    points on log-log axes: {"shapes": the first crossing or None, "below": the sizes where the
    network is nearer, "text": a sentence}."""
    gap = np.log(network) - np.log(nearest)       # < 0: the network is nearer
    below = [int(size) for size, g in zip(n, gap, strict=True) if g < 0]
    for i in range(len(n)):
        if gap[i] == 0 or (i + 1 < len(n) and gap[i] * gap[i + 1] < 0):
            t = gap[i] / (gap[i] - gap[i + 1]) if gap[i] else 0.0
            at = math.exp(math.log(n[i]) + t * (math.log(n[i + 1]) - math.log(n[i]))) if t else n[i]
            return {"shapes": round(at), "below": below,
                    "text": f"the lines cross at about {at:.0f} training shapes (the network is nearer at "
                            f"{', '.join(map(str, below)) or 'no size measured'})"}
    where = "nearer than" if gap[0] < 0 else "farther than"
    return {"shapes": None, "below": below,
            "text": f"the lines do not cross between {n[0]} and {n[-1]} training shapes: the network is "
                    f"{where} the nearest training shape at every size measured"}


# -- the results ----------------------------------------------------------------------------------

def write_results(out: Path, result: dict) -> None:
    table = pd.DataFrame([{**{k: v for k, v in r.items() if not k.endswith("_ci")}, "axes": " ".join(r["axes"]),
                           "network_low": r["network_ci"][0], "network_high": r["network_ci"][1],
                           "nearest_low": r["nearest_ci"][0], "nearest_high": r["nearest_ci"][1]}
                          for r in result["points"]])
    texts = {"curve.json": json.dumps(result, indent=1) + "\n", "curve.csv": table.to_csv(index=False),
             "curve.md": markdown(result)}
    for name, axis in (("curve.svg", "shapes"), ("curve-epochs.svg", "epochs")):
        if any(axis in r["axes"] for r in result["points"]):      # the epochs axis comes last
            texts[name] = plot(result, axis)
    with Outputs() as files:
        for name, text in texts.items():
            Path(files.reserve(out / name)).write_text(text)


def plot(result: dict, axis: str) -> str:
    """The plot against training shapes ("shapes", with each power law dashed out to the paper
    profile's size) or against epochs ("epochs")."""
    rows = sorted((r for r in result["points"] if axis in r["axes"]), key=lambda r: (r["training_shapes"], r["epochs"]))
    x = [r["training_shapes"] if axis == "shapes" else r["epochs"] for r in rows]
    series = []
    for name, label, colour in (("network", "network (points)", COLOURS[0]),
                                ("nearest", "nearest training shape", COLOURS[1])):
        series.append(Series(label, x, [r[name] for r in rows], [r[f"{name}_ci"][0] for r in rows],
                             [r[f"{name}_ci"][1] for r in rows], colour))
        if axis == "shapes":
            law = result["power_law"][name]
            n = np.geomspace(x[0], max(x[-1], result["extrapolation"]["training_shapes"]), 40).tolist()
            series.append(Series(f"{name}: power law, extrapolated", n,
                                 [law["scale"] * v ** law["exponent"] for v in n], colour=colour))
    fixed = f"at {epochs_text(result)}" if axis == "shapes" else f"on {rows[0]['training_shapes']} training shapes"
    title = f"{result['domain']}: mean Chamfer distance on {result['val_shapes']} validation shapes, {fixed}"
    return line_plot(series, "training shapes (log scale)" if axis == "shapes" else "epochs (log scale)",
                     "mean Chamfer distance (95% interval)", title)


def epochs_text(result: dict) -> str:
    e = result["shapes_axis_epochs"]
    return f"{e} epoch" + "s" * (e != 1)


def markdown(result: dict) -> str:
    head = ("| training shapes | epochs | network [95% interval] | nearest training shape [95% interval] | "
            "ratio | Wilcoxon p | training s |\n|---|---|---|---|---|---|---|\n")
    body = "".join(f"| {r['training_shapes']} | {r['epochs']} | {r['network']:.5f} [{r['network_ci'][0]:.5f}, "
                   f"{r['network_ci'][1]:.5f}] | {r['nearest']:.5f} [{r['nearest_ci'][0]:.5f}, "
                   f"{r['nearest_ci'][1]:.5f}] | {r['ratio']:.2f} | {r['p']:.2g} | "
                   f"{r['train_seconds']:.0f}{' (resumed)' * r['resumed']} |\n"
                   for r in result["points"])
    laws, ext = result["power_law"], result["extrapolation"]
    return (f"# {result['domain']}: the scaling curve ({result['profile']} profile)\n\n"
            f"Mean Chamfer distance on {result['val_shapes']} validation shapes: the points-only network's "
            f"answer ({result['decode']} read) and the nearest shape of its training set; "
            f"{result['trainings']} trainings done.\n\n{head}{body}\n"
            f"Against training shapes (at {epochs_text(result)}): {result['crossing']['text']}.\n\n"
            f"Power laws: network {laws['network']['scale']:.4g} n^{laws['network']['exponent']:.3f}, "
            f"nearest {laws['nearest']['scale']:.4g} n^{laws['nearest']['exponent']:.3f}. At the paper profile's "
            f"{ext['training_shapes']} training shapes they give network {ext['network']:.3g}, nearest "
            f"{ext['nearest']:.3g}: {ext['note']}.\n")
