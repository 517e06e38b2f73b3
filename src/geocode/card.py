"""The model card beside each trained model (`<runs>/<domain>/<variant>/README.md`), as model
hubs expect of a published checkpoint: what the model is for, the data it saw, its validation
and test-set numbers, its numbers on real shapes where `geocode bench real` has been run, and
where it fails. Rewritten from what the run folder holds whenever one of those changes
(training, the metrics step, the real-shape benchmark)."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from geocode import paths
from geocode.meshio import write_text

USE = ("Recovers the parameters of the `{domain}` program (programs/{domain}.py) from a point cloud "
       "or a line drawing: `geocode reconstruct {domain} <file or folder> -o out/`.")
LIMITS = [
    "It knows only the shapes its program can make; a real object of another form comes back as "
    "the program's nearest form (docs/design.md#real-inputs-need-the-pose-search-and-the-fit).",
    "It was trained on synthetic shapes in the program's own frame: a real input needs the pose "
    "search and the fit of `geocode reconstruct`, and without them it does worse than simply "
    "taking the nearest training shape.",
    "A drawing is answered by the network, then fitted (`--budget`): the search draws the program "
    "and compares the strokes, so a part the network misreads and one view shows little of (a "
    "vase's handle count or foot) often stays wrong, and against a sparse free-hand doodle the "
    "fit may add a part the doodle lacks (docs/design.md#drawing-fit).",
]


def write_card(run: Path) -> Path:
    """(Re)write the card of the run folder from what it holds."""
    run = Path(run)
    summary = _json(paths.summary_file(run))
    config = _config(run)
    domain = config.get("domain", {}).get("name", run.parent.name)
    variant = config.get("model", {}).get("variant", run.name)
    lines = [f"# {domain} / {variant}: a geocode model", "", USE.format(domain=domain), "",
             "## Training data", ""]
    lines += _data_lines(config)
    lines += ["", "## Numbers", ""]
    accuracies = [f"{name} {summary[key]:.3f}" for name, key in
                  (("points", "best_val_acc_points"), ("sketches", "best_val_acc_sketch")) if key in summary]
    if accuracies:   # a variant may read one modality only (huang: sketches)
        lines.append(f"- Validation top-1 accuracy: {', '.join(accuracies)} (always the most "
                     f"frequent class: {summary.get('majority_val_acc', float('nan')):.3f}).")
    lines += _test_lines(paths.metrics_file(run))
    lines += _real_lines(paths.real_bench_file(run))
    lines += ["", "## Where it fails", "", *(f"- {limit}" for limit in LIMITS), ""]
    path = paths.card_file(run)
    write_text(path, "\n".join(lines))
    return path


def _json(path: Path) -> dict:
    return json.loads(path.read_text()) if path.is_file() else {}


def _config(run: Path) -> dict:
    import yaml

    path = paths.run_config_file(run)
    return (yaml.safe_load(path.read_text()) or {}) if path.is_file() else {}


def _data_lines(config: dict) -> list[str]:
    data, train = config.get("data", {}), config.get("train", {})
    if not data:
        return ["- (the run's config.yaml is missing)"]
    points = data.get("points", {})
    return [f"- Profile `{config.get('profile_name')}`, seed {config.get('seed')}: shapes per "
            f"parameter class {data.get('variations')} (per domain: {data.get('domain_variations')}).",
            f"- Point clouds of {points.get('fps')} farthest + {points.get('train_random')} random "
            f"surface points; 224x224 Freestyle sketches from the cameras "
            f"{[c['name'] for c in data.get('sketch', {}).get('cameras', [])]}.",
            f"- {train.get('max_epochs')} epochs (per domain: {train.get('domain_epochs')}), batch "
            f"{train.get('batch_size')}, Adam lr {train.get('lr')}."]


def _test_lines(metrics: Path) -> list[str]:
    if not metrics.is_file():
        return ["- Test set: not evaluated yet (`snakemake -j2 results/tables`)."]
    m = pd.read_parquet(metrics)
    clean = m[(m.source == "test") & (m.noise == 0) & (m["sparse"] == 0)]
    means = clean.groupby("modality").chamfer.agg(["mean", "count"])
    names = {"pc": "point clouds", "sketch": "sketches (every camera)", "pc+fit": "point clouds + fit",
             "sketch+fit": "sketches + fit",
             "baseline": "the mean shape", "nearest": "the nearest training shape"}
    parts = [f"{names[k]} {means.loc[k, 'mean']:.5f}" for k in names if k in means.index]
    return [f"- Test set, mean Chamfer distance (unit sphere, squared): {'; '.join(parts)}."]


def _real_lines(path: Path) -> list[str]:
    real = _json(path)
    if not real:
        return ["- Real shapes: `geocode bench real` not run for this model."]
    return [f"- Real shapes (`geocode bench real`, {real['shapes']} files): median Chamfer "
            f"distance network {real['median_network']:.4f}, network + fit {real['median_fit']:.4f}, "
            f"the nearest training shape {real['median_nearest']:.4f}, the program's defaults "
            f"{real['median_defaults']:.4f}; {real['seconds_median']} s per shape."]
