"""The results page of a folder run of `geocode reconstruct`: `<out>/index.html` (one card per
input: the input beside the result from the same camera and at the same scale, the distances
before and after the fit, the pose found, links to the files written, the parameters and any
further candidates), `<out>/summary.csv` (one row per input) and the pictures under
`<out>/page/`.

Meshes are rendered shaded (Cycles, through blender/gallery.py); a point cloud is rendered
shaded too, as small spheres at (a subsample of) its points. Inputs and results come in one
frame (the canonical one: Z up, unit sphere) and are drawn in it as they are, never
renormalised one by one, so a size or offset mismatch shows. Only the pictures need bpy; the
HTML and CSV are plain Python.
"""

from __future__ import annotations

import csv
import hashlib
import html
import io
import logging
import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote

import numpy as np
import trimesh
from PIL import Image, ImageOps

from geocode.meshio import atomic_path, write_text

log = logging.getLogger(__name__)

KINDS = ("mesh", "cloud", "drawing")
PICTURES = "page"               # the pictures' folder, beside index.html
SIZE = 256                      # px, input and result pictures (the gallery's size)
THUMB = 128                     # px, candidates' pictures
INPUT_COLOR = (0.74, 0.71, 0.64)   # one neutral (sand) colour for every input
CLOUD_POINTS = 3000             # spheres drawn for a cloud at most
SPHERE_RADIUS = 0.012           # in unit-sphere radii: about 3 px across at SIZE
DEGREES = ("turn", "azimuth", "elevation", "roll")   # pose fields shown with a degree sign

Render = Callable[..., None]    # (mesh, png path, color=None, size=None): a shaded picture


@dataclass
class Candidate:
    """A further fitted program (`--candidates K`): its mesh in the canonical frame, its
    distance to the input and its files (label -> path relative to the page)."""

    mesh: trimesh.Trimesh | None
    distance: float
    links: dict[str, str] = field(default_factory=dict)
    picture: str | None = None      # set by render_entry


@dataclass
class Entry:
    """One reconstructed input. `input`: a trimesh ("mesh"), an (N, 3) array ("cloud") or a
    drawing ("drawing": a PNG path, a PIL image or an image array), in the canonical frame
    for 3D inputs; `result`: the result mesh in that same frame, already posed onto the input;
    `result_drawing`: for drawings, our line drawing of the result from the found camera.
    `before` / `after`: the distance of the network alone and after the fit; `pose`: the pose
    found (up axis, turn, scale...); `parameters`: name -> value; `links`: label (yaml, obj,
    in-place.obj, blend) -> path relative to the page. An input that failed has `error` (its
    one-line message) and may leave the rest empty; `kind` may then be "" when unknown."""

    name: str
    kind: str
    input: object = None
    result: trimesh.Trimesh | None = None
    before: float | None = None
    after: float | None = None
    seconds: float | None = None
    pose: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    links: dict[str, str] = field(default_factory=dict)
    candidates: list[Candidate] = field(default_factory=list)
    error: str | None = None
    result_drawing: object = None
    unit: str = ""                  # of `before` / `after` (drawings: " px")
    pictures: dict[str, str] = field(default_factory=dict)   # role -> path, set by render_entry
    points: int | None = None       # a cloud's points (its caption), kept once its picture is drawn

    def __post_init__(self):
        if self.kind not in KINDS and not (self.error and self.kind == ""):
            raise ValueError(f"page entry {self.name!r}: kind {self.kind!r} is not one of {KINDS}")
        if self.error is None and (self.input is None or self.result is None) and not self.pictures:
            raise ValueError(f"page entry {self.name!r}: give its input and result (or an error)")
        if self.kind == "cloud" and self.input is not None:
            self.points = len(self.input)


# -- pictures ------------------------------------------------------------------------------------

def cloud_mesh(points: np.ndarray, n: int = CLOUD_POINTS, radius: float = SPHERE_RADIUS,
               seed: int = 0) -> trimesh.Trimesh:
    """A cloud as one mesh of small spheres (icosahedra) at `n` of its points at most, picked
    at random with `seed`, so that it can be rendered shaded like a mesh."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) > n:
        points = points[np.sort(np.random.default_rng(seed).choice(len(points), n, replace=False))]
    ball = trimesh.creation.icosahedron()
    vertices = (ball.vertices * radius)[None] + points[:, None]
    faces = ball.faces[None] + (np.arange(len(points)) * len(ball.vertices))[:, None, None]
    return trimesh.Trimesh(vertices.reshape(-1, 3), faces.reshape(-1, 3), process=False)


def single_sided(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh without faces on the same vertices as another (models made double-sided by
    repeating every face with the other winding): in Cycles coincident faces shadow each
    other, and such an input renders black."""
    merged = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    merged.merge_vertices()
    merged.update_faces(merged.unique_faces())
    return merged


def blender_render(mesh, png: Path, color=None, size: int | None = None) -> None:
    """The gallery's shaded renderer, in the frame the mesh comes in (not renormalised)."""
    from geocode.blender.gallery import render_mesh_png

    render_mesh_png(mesh, png, normalise=False, color=color, size=size)


def save_drawing(image, png: Path, size: int = SIZE) -> None:
    """A drawing (path, PIL image, or array: floats 0-1 or bytes, (H, W) or (1, H, W)) on a
    white `size` px square, aspect kept."""
    if isinstance(image, str | Path):
        with Image.open(image) as opened:
            image = opened.convert("RGBA")
    elif isinstance(image, np.ndarray):
        pixels = np.squeeze(image)
        if pixels.dtype != np.uint8:
            pixels = (np.clip(pixels, 0, 1) * 255).round().astype(np.uint8)
        image = Image.fromarray(pixels)
    image = image.convert("RGBA")
    flat = Image.alpha_composite(Image.new("RGBA", image.size, "white"), image).convert("RGB")
    flat = ImageOps.contain(flat, (size, size))
    sheet = Image.new("RGB", (size, size), "white")
    sheet.paste(flat, ((size - flat.width) // 2, (size - flat.height) // 2))
    with atomic_path(png) as tmp:
        sheet.save(tmp, format="PNG")


def picture_stem(name: str) -> str:
    """A file name for an input's pictures: its path made safe, with a short hash of it so that
    `a/b.ply` and `a_b.ply` do not collide."""
    safe = re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._")[-60:] or "input"
    return f"{safe}-{hashlib.sha1(name.encode()).hexdigest()[:8]}"


def picture_path(name: str, role: str) -> str:
    """An input's picture, relative to the page: `role` is input, result, result-drawing (a
    drawing's: our line drawing of the result) or candidate<rank> (2, 3, ...)."""
    return f"{PICTURES}/{picture_stem(name)}-{role}.png"


def picture_roles(candidates: int) -> list[str]:
    """The roles of an input's pictures, for `candidates` ranked answers."""
    return ["input", "result", "result-drawing", *(f"candidate{rank}" for rank in range(2, candidates + 1))]


# a picture of ours, or the temporary file of one (`geocode.outputs`): nothing else in page/ is removed
OUR_PICTURE = re.compile(r"\.?.+-[0-9a-f]{8}-(input|result|result-drawing|candidate\d+)\.png(\.\w+\.tmp)?")


def render_entry(entry: Entry, out_dir: str | Path, render: Render | None = None,
                 place: Callable[[Path], Path] | None = None) -> Entry:
    """Write `entry`'s pictures under `<out_dir>/page/` (input, result, line drawing of the
    result for a drawing, candidates) and record their paths in `entry.pictures` and each
    candidate's `picture`. Nothing to draw for a failed input. `place` maps each picture's
    path to the one to write instead (e.g. a name reserved by `geocode.outputs.Outputs`)."""
    if entry.error is not None:
        return entry
    render = render or blender_render
    place = place or (lambda path: path)
    out_dir = Path(out_dir)
    pictures = {"input": picture_path(entry.name, "input"), "result": picture_path(entry.name, "result")}
    started = time.perf_counter()
    if entry.kind == "drawing":
        save_drawing(entry.input, place(out_dir / pictures["input"]))
        if entry.result_drawing is not None:
            pictures["result_drawing"] = picture_path(entry.name, "result-drawing")
            save_drawing(entry.result_drawing, place(out_dir / pictures["result_drawing"]))
    else:
        shape = cloud_mesh(entry.input) if entry.kind == "cloud" else single_sided(entry.input)
        render(shape, place(out_dir / pictures["input"]), color=INPUT_COLOR, size=SIZE)
    render(entry.result, place(out_dir / pictures["result"]), size=SIZE)
    for rank, candidate in enumerate(entry.candidates, start=2):
        candidate.picture = picture_path(entry.name, f"candidate{rank}")
        render(candidate.mesh, place(out_dir / candidate.picture), size=THUMB)
    entry.pictures = pictures
    log.debug("page %s: %d pictures in %.2f s", entry.name, len(pictures) + len(entry.candidates),
              time.perf_counter() - started)
    return entry


# -- the page ------------------------------------------------------------------------------------

def write_page(entries: Sequence[Entry], out_dir: str | Path, title: str, *,
               render: Render | None = None, note: str = "") -> Path:
    """Write `<out_dir>/index.html`, `<out_dir>/summary.csv` and the pictures they need under
    `<out_dir>/page/` (entries already drawn by render_entry are not drawn again). Every file is
    written under a temporary name and renamed; the page comes last, so it never points at a
    picture not yet written, and pictures of an earlier run that it no longer shows are removed.
    `note`: a line under the header (what the distances are, the run's settings). Returns the
    page's path."""
    out_dir = Path(out_dir)
    names = [e.name for e in entries]
    if len(set(names)) < len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"page entries: names given twice ({', '.join(twice)}); their pictures would collide")
    for entry in entries:
        if not entry.pictures:
            render_entry(entry, out_dir, render)
    write_text(out_dir / "summary.csv", summary_csv(entries))
    index = out_dir / "index.html"
    write_text(index, page_html(entries, title, note))
    remove_stale_pictures(out_dir, entries)
    return index


def remove_stale_pictures(out_dir: Path, entries: Sequence[Entry]) -> None:
    """Our pictures (and temporary files of an interrupted run) in page/ that the page does not
    show; any other file there is left alone."""
    shown = {Path(p).name for e in entries for p in e.pictures.values()}
    shown |= {Path(c.picture).name for e in entries for c in e.candidates if c.picture}
    for path in (out_dir / PICTURES).glob("*"):
        if path.is_file() and path.name not in shown and OUR_PICTURE.fullmatch(path.name):
            path.unlink()


def summary_csv(entries: Sequence[Entry]) -> str:
    """One row per input: name, kind, before, after, seconds, pose_<field>..., files, error."""
    pose_fields = list(dict.fromkeys(k for e in entries for k in e.pose))
    header = ["name", "kind", "before", "after", "seconds", *(f"pose_{k}" for k in pose_fields),
              "files", "error"]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(header)
    for e in entries:
        writer.writerow([e.name, e.kind, _csv_number(e.before), _csv_number(e.after),
                         _csv_number(e.seconds), *(_plain(e.pose.get(k, "")) for k in pose_fields),
                         ";".join(e.links.values()), e.error or ""])
    return out.getvalue()


def median(values) -> float | None:
    finite = [float(v) for v in values if v is not None and math.isfinite(v)]
    return float(np.median(finite)) if finite else None


STYLE = """
body{font-family:system-ui,sans-serif;margin:1.5em auto;max-width:1150px;color:#222;padding:0 1em}
h1{margin:0 0 .2em}h2{font-size:1.05em;margin:0 0 .5em;word-break:break-all}
.lead{font-size:1.1em;margin:.2em 0}.note{color:#555;margin:.2em 0 1em}
table{border-collapse:collapse}td,th{padding:2px 8px;text-align:left}
th{border-bottom:1px solid #ccc}td.num,th.num{text-align:right;font-variant-numeric:tabular-nums}
table.index{margin-bottom:1.5em;font-size:.9em}table.index tr:nth-child(even){background:#f6f6f6}
.card{border:1px solid #ddd;border-radius:6px;padding:12px;margin:0 0 14px;display:flex;gap:18px;flex-wrap:wrap}
.card.failed{background:#fff5f5;border-color:#e4b4b4;display:block}
.pics{display:flex;gap:6px}figure{margin:0;text-align:center;width:258px}
figure img{width:256px;height:256px;border:1px solid #eee;display:block}
figcaption{font-size:.8em;color:#555;margin-top:2px}
.facts{flex:1;min-width:300px;font-size:.92em}.facts p{margin:.25em 0}
.dist{font-size:1.15em}.better{color:#17702b}.worse{color:#a12020}
.kind{font-size:.75em;color:#fff;background:#777;border-radius:3px;padding:1px 5px;vertical-align:middle}
.error{color:#a12020;font-family:ui-monospace,monospace;word-break:break-word}
a{color:#1a5fb4}.files a{margin-right:.7em}
details{flex-basis:100%;font-size:.92em}summary{cursor:pointer;color:#1a5fb4}
details table{font-size:.9em;margin-top:.3em}details td{border-bottom:1px solid #f0f0f0}
details td.num{padding-right:20px}
.cands{flex-basis:100%;display:flex;gap:8px;flex-wrap:wrap;align-items:flex-end}
.cands figure{width:130px}.cands figure img{width:128px;height:128px}
.cands .label{font-size:.85em;color:#555;align-self:center}
"""


def page_html(entries: Sequence[Entry], title: str, note: str = "") -> str:
    out = ["<!doctype html>", "<html lang='en'><head><meta charset='utf-8'>",
           f"<title>{_esc(title)}</title><style>{STYLE}</style></head><body>",
           f"<h1>{_esc(title)}</h1>", header_html(entries)]
    if note:
        out.append(f"<p class='note'>{_esc(note)}</p>")
    out.append(index_table(entries))
    out.extend(card_html(e, i) for i, e in enumerate(entries))
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def header_html(entries: Sequence[Entry]) -> str:
    done = [e for e in entries if e.error is None]
    failed = len(entries) - len(done)
    parts = [f"{len(entries)} input{'s' * (len(entries) != 1)}"
             + (f", <span class='worse'>{failed} failed</span>" if failed else "")]
    for unit in dict.fromkeys(e.unit for e in done):   # drawings' px apart from Chamfer distances
        alike = [e for e in done if e.unit == unit]
        fitted = [e for e in alike if e.before is not None and e.after is not None]
        before, after = median(e.before for e in fitted or alike), median(e.after for e in fitted)
        if before is not None or after is not None:
            what = "drawings" if unit else "shapes" if len(alike) < len(done) else ""
            parts.append(f"median distance{' of the ' + what if what else ''} " + _before_after(before, after, unit)
                         + (f" (over the {len(fitted)} fitted)" if 0 < len(fitted) < len(alike) else ""))
    seconds = median(e.seconds for e in done)
    if seconds is not None:
        parts.append(f"median {seconds:.1f} s per input")
    return f"<p class='lead'>{' &middot; '.join(parts)}</p>"


def index_table(entries: Sequence[Entry]) -> str:
    rows = ["<table class='index'><tr><th>input</th><th>kind</th><th class='num'>network</th>"
            "<th class='num'>after fit</th><th class='num'>seconds</th><th></th></tr>"]
    for i, e in enumerate(entries):
        status = "<span class='error'>failed</span>" if e.error else ""
        rows.append(f"<tr><td><a href='#input-{i}'>{_esc(e.name)}</a></td><td>{_esc(e.kind)}</td>"
                    f"<td class='num'>{_distance(e.before)}</td><td class='num'>{_distance(e.after)}</td>"
                    f"<td class='num'>{_seconds(e.seconds)}</td><td>{status}</td></tr>")
    rows.append("</table>")
    return "\n".join(rows)


def card_html(entry: Entry, index: int | None = None) -> str:
    anchor = f" id='input-{index}'" if index is not None else ""
    heading = f"<h2>{_esc(entry.name)} <span class='kind'>{_esc(entry.kind or 'unknown')}</span></h2>"
    if entry.error is not None:
        return (f"<section class='card failed'{anchor}>{heading}"
                f"<p class='error'>{_esc(entry.error)}</p></section>")
    return (f"<section class='card'{anchor}>{pictures_html(entry)}<div class='facts'>{heading}"
            f"{facts_html(entry)}</div>{candidates_html(entry)}{parameters_html(entry)}</section>")


def pictures_html(entry: Entry) -> str:
    captions = {"input": input_caption(entry), "result_drawing": "our line drawing of the result",
                "result": "result" if entry.kind != "drawing" else "result, shaded"}
    order = ("input", "result_drawing", "result")
    figures = [_figure(entry.pictures[role], captions[role]) for role in order if role in entry.pictures]
    return f"<div class='pics'>{''.join(figures)}</div>"


def input_caption(entry: Entry) -> str:
    if entry.kind == "cloud" and entry.points is not None:
        n = entry.points
        shown = min(n, CLOUD_POINTS)
        if shown < n:
            return f"input cloud: {shown:,} of {n:,} points, as spheres"
        return f"input cloud: {n:,} points, as spheres"
    return {"mesh": "input mesh", "drawing": "input drawing"}.get(entry.kind, "input")


def facts_html(entry: Entry) -> str:
    out = [f"<p class='dist'>distance {_before_after(entry.before, entry.after, entry.unit)}"
           + (f" &middot; {entry.seconds:.1f} s" if entry.seconds is not None else "") + "</p>"]
    if entry.pose:
        out.append("<p>pose: " + " &middot; ".join(f"{_esc(k)} {_esc(_pose_value(k, v))}"
                                                   for k, v in entry.pose.items()) + "</p>")
    if entry.links:
        out.append(f"<p class='files'>files: {_links(entry.links)}</p>")
    return "".join(out)


def parameters_html(entry: Entry) -> str:
    if not entry.parameters:
        return ""
    return (f"<details><summary>{len(entry.parameters)} parameters</summary>"
            f"{parameters_table(entry.parameters)}</details>")


def parameters_table(parameters: dict, columns: int = 3) -> str:
    """name | value pairs in `columns` pairs of columns, read down each column."""
    items = list(parameters.items())
    rows = math.ceil(len(items) / columns)
    out = []
    for r in range(rows):
        cells = [f"<td>{_esc(k)}</td><td class='num'>{_esc(_plain(v))}</td>"
                 for k, v in items[r::rows]]
        out.append(f"<tr>{''.join(cells)}</tr>")
    return f"<table class='params'>{''.join(out)}</table>"


def candidates_html(entry: Entry) -> str:
    if not entry.candidates:
        return ""
    figures = []
    for rank, c in enumerate(entry.candidates, start=2):
        caption = f"#{rank} &middot; {_distance(c.distance)}" + (f"<br>{_links(c.links)}" if c.links else "")
        figures.append(_figure(c.picture, caption, escape=False) if c.picture else "")
    return (f"<div class='cands'><span class='label'>next candidates, by distance<br>"
            f"(the result is #1)</span>{''.join(figures)}</div>")


# -- formatting ----------------------------------------------------------------------------------

def _esc(text) -> str:
    return html.escape(str(text), quote=True)


def _href(path: str) -> str:
    return _esc(quote(str(path).replace("\\", "/"), safe="/"))


def _figure(src: str, caption: str, escape: bool = True) -> str:
    text = _esc(caption) if escape else caption
    return f"<figure><img src='{_href(src)}' alt=''><figcaption>{text}</figcaption></figure>"


def _links(links: dict[str, str]) -> str:
    return " ".join(f"<a href='{_href(path)}'>{_esc(label)}</a>" for label, path in links.items())


def _distance(value: float | None) -> str:
    return "&ndash;" if value is None or not math.isfinite(value) else f"{value:.4g}"


def _seconds(value: float | None) -> str:
    return "&ndash;" if value is None else f"{value:.1f}"


def _before_after(before: float | None, after: float | None, unit: str = "") -> str:
    """'network 0.0151 → after fit 0.0098 (−35%)', or the one that is known."""
    if after is None:
        return f"network {_distance(before)}{unit}"
    if before is None:
        return f"after fit {_distance(after)}{unit}"
    change = ""
    if before > 0 and math.isfinite(before) and math.isfinite(after):
        pct = 100 * (after - before) / before
        change = f" <span class='{'better' if pct <= 0 else 'worse'}'>({pct:+.0f}%)</span>"
    return f"network {_distance(before)}{unit} &rarr; after fit <b>{_distance(after)}</b>{unit}{change}"


def _plain(value) -> str:
    """A number or a short list as text: integral floats without '.0', others to 4 digits."""
    if isinstance(value, bool) or isinstance(value, str):
        return str(value)
    if isinstance(value, np.ndarray | list | tuple):
        return "(" + ", ".join(_plain(v) for v in np.asarray(value).ravel().tolist()) + ")"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        return str(int(value)) if float(value).is_integer() else f"{float(value):.4g}"
    return str(value)


def _pose_value(key: str, value) -> str:
    return _plain(value) + ("\N{DEGREE SIGN}" if key in DEGREES and not isinstance(value, str) else "")


def _csv_number(value: float | None) -> str:
    return "" if value is None else f"{float(value):.6g}"
