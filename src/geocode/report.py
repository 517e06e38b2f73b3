"""results/report: an HTML page that shows, for a few test shapes per domain, the input sketch
and point cloud beside the ground truth and the shapes rebuilt from the predictions."""

from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np
import pandas as pd
from PIL import Image, ImageDraw

from geocode.meshio import atomic_path, write_text


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


def page(title: str, header: str, sections: list[tuple[str, list[dict]]]) -> str:
    """sections: (domain, rows); a row has `id`, `chamfer_pc`, `chamfer_sketch` and image paths
    `sketch`, `cloud`, `gt`, `pc`, `sketch_pred` relative to the page."""
    cells = ("sketch", "cloud", "gt", "pc", "sketch_pred")
    heads = ("input sketch", "input point cloud", "ground truth", "from the point cloud", "from the sketch")
    out = [f"<!doctype html><meta charset='utf-8'><title>{html.escape(title)}</title>",
           "<style>body{font-family:sans-serif;margin:2em}td{text-align:center;padding:4px}"
           "img{width:180px;border:1px solid #ddd}</style>",
           f"<h1>{html.escape(title)}</h1><p>{html.escape(header)}</p>"]
    for domain, rows in sections:
        out.append(f"<h2>{html.escape(domain)}</h2><table><tr><th>shape</th>"
                   + "".join(f"<th>{h}</th>" for h in heads) + "</tr>")
        for r in rows:
            out.append(f"<tr><td>{html.escape(r['id'])}<br>CD pc {r['chamfer_pc']:.5f}"
                       f"<br>CD sketch {r['chamfer_sketch']:.5f}</td>"
                       + "".join(f"<td><img src='{html.escape(r[c])}'></td>" for c in cells) + "</tr>")
        out.append("</table>")
    return "\n".join(out) + "\n"


def pick_examples(metrics: pd.DataFrame, n: int) -> list[str]:
    """n test shapes spread from the best to the worst point-cloud prediction."""
    pc = metrics[(metrics.condition == "pc")].sort_values("chamfer")
    rows = np.unique(np.linspace(0, len(pc) - 1, min(n, len(pc))).round().astype(int))
    return pc.iloc[rows]["id"].tolist()


def write_report(out_dir: Path, title: str, header: str, sections: list[tuple[str, list[dict]]]) -> Path:
    index = Path(out_dir) / "index.html"
    write_text(index, page(title, header, sections))
    return index


def report_step(cfg, metrics_files: list[Path], out_dir: Path, per_domain: int = 4) -> str:
    """Render the figures of a few test shapes per domain and write the page."""
    import shutil

    from geocode.blender.gallery import render_mesh_png
    from geocode.config import config_hash, data_dir
    from geocode.evaluation import point_input
    from geocode.meshio import read_obj

    out_dir = Path(out_dir)
    camera = next(c.name for c in cfg.data.sketch.cameras if c.train)
    sections = []
    for path in metrics_files:
        metrics = pd.read_parquet(path)
        if metrics.variant.iloc[0] != "joint":
            continue
        domain = metrics.domain.iloc[0]
        rebuilt = Path(path).parent / "rebuilt"
        test = data_dir(cfg, domain, "test")
        rows = []
        for shape_id in pick_examples(metrics, per_domain):
            name = f"{domain}/{shape_id}"
            (out_dir / domain).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(test / "sketches" / f"{shape_id}_{camera}.png", out_dir / f"{name}_sketch.png")
            cloud = point_input(cfg, domain, {"condition": "pc", "source": "test", "noise": 0, "sparse": 0}, shape_id)
            save_png(cloud_image(cloud), out_dir / f"{name}_cloud.png")
            for tag, obj in (("gt", test / "shapes" / f"{shape_id}.obj"),
                             ("pc", rebuilt / "pc" / f"{shape_id}.obj"),
                             ("sketch_pred", rebuilt / f"sketch-{camera}" / f"{shape_id}.obj")):
                render_mesh_png(read_obj(obj), out_dir / f"{name}_{tag}.png")
            cd = metrics[metrics.id == shape_id].set_index("condition").chamfer
            rows.append(dict(id=shape_id, chamfer_pc=cd["pc"], chamfer_sketch=cd[f"sketch-{camera}"],
                             **{t: f"{name}_{t}.png" for t in ("sketch", "cloud", "gt", "pc", "sketch_pred")}))
        sections.append((domain, rows))
    header = f"profile {cfg.profile_name}, config {config_hash(cfg)}; sketches from camera {camera}"
    index = write_report(out_dir, "geocode: predictions on test shapes", header, sections)
    return f"wrote {index}"
