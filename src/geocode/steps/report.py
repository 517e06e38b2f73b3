"""The report step (workflow/rules/tables.smk): an HTML page that shows, per domain, the
learning curves of each modality (train and validation accuracy and loss per epoch, with the
majority bar), the validation accuracy of every parameter, and for a few test shapes the input
sketch and point cloud beside the ground truth and the shapes rebuilt from the predictions."""

from __future__ import annotations

import html
import logging
import math
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image, ImageDraw

from geocode import paths
from geocode.meshio import atomic_path, write_text

log = logging.getLogger(__name__)


def cloud_image(points: np.ndarray, size: int = 224, azimuth: float = 35.0, elevation: float = 30.0) -> Image.Image:
    """The cloud seen from the sketch camera's direction: dots shaded by depth, z up."""
    a, e = math.radians(azimuth), math.radians(elevation)
    right = np.array([-math.sin(a), math.cos(a), 0.0])
    view = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])   # towards camera
    up = np.cross(view, right)
    p = np.asarray(points, dtype=np.float64)
    x, y, depth = p @ right, p @ up, p @ view
    scale = (size / 2 - 6) / max(np.abs(np.c_[x, y]).max(), 1e-9)
    u, v = size / 2 + x * scale, size / 2 - y * scale
    shade = np.interp(depth, (depth.min(), depth.max() + 1e-9), (170, 20)).astype(int)
    image = Image.new("L", (size, size), 255)
    draw = ImageDraw.Draw(image)
    for i in np.argsort(depth):                          # far points first, near ones on top
        draw.ellipse((u[i] - 1, v[i] - 1, u[i] + 1, v[i] + 1), fill=int(shade[i]))
    return image


def save_png(image: Image.Image, path: Path) -> None:
    with atomic_path(path) as tmp:
        image.save(tmp, format="PNG")


RECOVERED = 0.10  # a parameter counts as recovered this far above its majority accuracy
CURVES = (  # (modality, stage, colour, dash): the lines of a learning-curve chart
    ("points", "train", "#1f77b4", "4 3"), ("points", "val", "#1f77b4", ""),
    ("sketch", "train", "#d62728", "4 3"), ("sketch", "val", "#d62728", ""),
)


def curve_svg(curves: pd.DataFrame, metric: str, majority: float | None = None,
              width: int = 360, height: int = 220) -> str:
    """An inline SVG chart of `<stage>/<metric>_<modality>` per epoch (the columns of
    `geocode.steps.train.epoch_metrics`), with a grey dashed line at `majority`."""
    lines = [(f"{st}/{metric}_{m}", f"{m} {st}", colour, dash) for m, st, colour, dash in CURVES
             if f"{st}/{metric}_{m}" in curves]
    values = [curves[col].dropna() for col, *_ in lines]
    ys = np.concatenate([v.to_numpy() for v in values] + [[majority] if majority is not None else []])
    lo, hi = (0.0, 1.0) if metric == "acc" else (0.0, float(np.nanmax(ys)) * 1.05 or 1.0)
    x0, x1, y0, y1 = 40, width - 10, height - 25, 10
    last = max(int(curves.index.max()), 1)
    sx = lambda e: x0 + (x1 - x0) * e / last  # noqa: E731
    sy = lambda v: y0 + (y1 - y0) * (v - lo) / (hi - lo)  # noqa: E731
    out = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{width}' height='{height}' class='curve'>",
           f"<rect x='{x0}' y='{y1}' width='{x1 - x0}' height='{y0 - y1}' fill='none' stroke='#999'/>",
           f"<text x='{x0}' y='{height - 8}' font-size='11'>epoch 0</text>",
           f"<text x='{x1}' y='{height - 8}' font-size='11' text-anchor='end'>{last}</text>",
           f"<text x='{x0 - 4}' y='{y1 + 10}' font-size='11' text-anchor='end'>{hi:.2g}</text>",
           f"<text x='{x0 - 4}' y='{y0}' font-size='11' text-anchor='end'>{lo:.2g}</text>",
           f"<text x='{x1 - 4}' y='{y1 + 14}' font-size='12' text-anchor='end'>"
           f"{'accuracy' if metric == 'acc' else metric}</text>"]
    if majority is not None:
        out.append(f"<line x1='{x0}' x2='{x1}' y1='{sy(majority):.1f}' y2='{sy(majority):.1f}' "
                   "stroke='#888' stroke-dasharray='2 2'><title>majority</title></line>")
    for (_, label, colour, dash), v in zip(lines, values, strict=True):
        pts = " ".join(f"{sx(e):.1f},{sy(y):.1f}" for e, y in v.items())
        out.append(f"<polyline points='{pts}' fill='none' stroke='{colour}' stroke-width='1.5' "
                   f"stroke-dasharray='{dash}'><title>{label}</title></polyline>")
    out.append("</svg>")
    return "".join(out)


def training_html(curves: pd.DataFrame, summary: dict) -> str:
    """Learning curves (accuracy with the majority bar, loss) and, at the best validation
    epoch, each parameter's accuracy per modality beside its majority accuracy."""
    best = curves.loc[curves["val/acc"].idxmax()]
    majority = summary["majority_per_parameter"]
    legend = " ".join(f"<span style='color:{c}'>{'- -' if d else '&mdash;'} {m} {st}</span>" for m, st, c, d in CURVES)
    out = [f"<h3>Learning curves</h3><p>{legend} <span style='color:#888'>&middot;&middot; majority "
           f"{summary['majority_val_acc']:.3f}</span></p>",
           "<div>" + curve_svg(curves, "acc", summary["majority_val_acc"]) + curve_svg(curves, "loss") + "</div>",
           f"<h3>Validation accuracy per parameter (best epoch, {int(best.name)})</h3>",
           "<table class='params'><tr><th>parameter</th><th>majority</th><th>points</th><th>sketch</th></tr>"]
    for name, bar in majority.items():
        cells = []
        for m in ("points", "sketch"):
            acc = best.get(f"val_param/{m}/{name}", np.nan)
            mark = "" if np.isnan(acc) else " class='learnt'" if acc >= bar + RECOVERED else " class='missed'"
            cells.append(f"<td{mark}>{acc:.2f}</td>")
        out.append(f"<tr><td>{html.escape(name)}</td><td>{bar:.2f}</td>{''.join(cells)}</tr>")
    out.append(f"</table><p>green: at least {RECOVERED} above the majority; red: not.</p>")
    return "\n".join(out)


GALLERY = {"sketch": "input sketch", "cloud": "input point cloud", "gt": "ground truth",
           "pc": "from the point cloud", "sketch_pred": "from the sketch"}  # image -> column head


def page(title: str, header: str, sections: list[dict]) -> str:
    """sections: {"domain", "training": HTML of `training_html` or "", "rows"}; a row has
    `id`, `chamfer_pc`, `chamfer_sketch` and image paths `sketch`, `cloud`, `gt`, `pc`,
    `sketch_pred` relative to the page; where the run fitted the clouds' predictions, also
    `chamfer_fit` and `pc_fit`."""
    out = [f"<!doctype html><meta charset='utf-8'><title>{html.escape(title)}</title>",
           "<style>body{font-family:sans-serif;margin:2em}td{text-align:center;padding:4px}"
           "img{width:180px;border:1px solid #ddd}svg.curve{margin-right:1em}"
           "td.learnt{background:#d4f4d4}td.missed{background:#f8d8d8}</style>",
           f"<h1>{html.escape(title)}</h1><p>{html.escape(header)}</p>"]
    for section in sections:
        fitted = all("pc_fit" in r for r in section["rows"])
        columns = {**GALLERY, **({"pc_fit": "from the point cloud, fitted"} if fitted else {})}
        out.append(f"<h2>{html.escape(section['domain'])}</h2>{section['training']}")
        out.append("<h3>Test shapes, best to worst point-cloud prediction</h3><table><tr><th>shape</th>"
                   + "".join(f"<th>{h}</th>" for h in columns.values()) + "</tr>")
        for r in section["rows"]:
            fit = f"<br>CD fitted {r['chamfer_fit']:.5f}" if fitted else ""
            out.append(f"<tr><td>{html.escape(r['id'])}<br>CD pc {r['chamfer_pc']:.5f}"
                       f"<br>CD sketch {r['chamfer_sketch']:.5f}{fit}</td>"
                       + "".join(f"<td><img src='{html.escape(r[c])}'></td>" for c in columns) + "</tr>")
        out.append("</table>")
    return "\n".join(out) + "\n"


def pick_examples(metrics: pd.DataFrame, n: int) -> list[str]:
    """n test shapes spread from the best to the worst point-cloud prediction."""
    pc = metrics[(metrics.condition == "pc")].sort_values("chamfer")
    rows = np.unique(np.linspace(0, len(pc) - 1, min(n, len(pc))).round().astype(int))
    return pc.iloc[rows]["id"].tolist()


def write_report(out_dir: Path, title: str, header: str, sections: list[dict]) -> Path:
    index = Path(out_dir) / "index.html"
    write_text(index, page(title, header, sections))
    return index


def run_training_html(run: Path) -> str:
    """`training_html` of a run folder (its CSV logs and summary.json); "" without a summary."""
    import json

    from geocode.steps.train import epoch_metrics

    summary = paths.summary_file(run)
    if not summary.is_file():
        log.warning("%s: no %s (trained before it was written); no learning curves", run, summary.name)
        return ""
    return training_html(epoch_metrics(run), json.loads(summary.read_text()))


def report_step(cfg, metrics_files: list[Path], out_dir: Path, per_domain: int = 4) -> str:
    """Render the figures of a few test shapes per domain and write the page."""
    import shutil

    from geocode.blender.gallery import render_mesh_png
    from geocode.config import config_hash
    from geocode.meshio import read_obj
    from geocode.steps.evaluate import point_input

    out_dir = Path(out_dir)
    camera = next(c.name for c in cfg.data.sketch.cameras if c.train)
    sections = []
    for path in metrics_files:
        metrics = pd.read_parquet(path)
        if metrics.variant.iloc[0] != "joint":
            continue
        domain = metrics.domain.iloc[0]
        run = paths.run_dir(cfg, domain, "joint")
        rebuilt = paths.rebuilt_dir(paths.predictions_file(run))
        test = paths.split_dir(cfg, domain, "test")
        shapes = paths.shapes_dir(test)
        rows = []
        for shape_id in pick_examples(metrics, per_domain):
            name = f"{domain}/{shape_id}"
            (out_dir / domain).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(paths.sketch_file(test, shape_id, camera), out_dir / f"{name}_sketch.png")
            cloud = point_input(cfg, domain, {"condition": "pc", "source": "test", "noise": 0, "sparse": 0}, shape_id)
            save_png(cloud_image(cloud), out_dir / f"{name}_cloud.png")
            cd = metrics[metrics.id == shape_id].set_index("condition").chamfer
            meshes = {"gt": paths.shape_file(shapes, shape_id), "pc": paths.rebuilt_mesh(rebuilt, "pc", shape_id),
                      "sketch_pred": paths.rebuilt_mesh(rebuilt, f"sketch-{camera}", shape_id)}
            row = dict(id=shape_id, chamfer_pc=cd["pc"], chamfer_sketch=cd[f"sketch-{camera}"])
            if "pc-fit" in cd:
                meshes["pc_fit"] = paths.rebuilt_mesh(rebuilt, "pc-fit", shape_id)
                row["chamfer_fit"] = cd["pc-fit"]
            for tag, obj in meshes.items():
                render_mesh_png(read_obj(obj), out_dir / f"{name}_{tag}.png")
            rows.append({**row, **{t: f"{name}_{t}.png" for t in ("sketch", "cloud", *meshes)}})
        sections.append({"domain": domain, "rows": rows, "training": run_training_html(run)})
    header = f"profile {cfg.profile_name}, config {config_hash(cfg)}; sketches from camera {camera}"
    index = write_report(out_dir, "geocode: predictions on test shapes", header, sections)
    return f"wrote {index}"
