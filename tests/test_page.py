"""The results page of a folder run (geocode.reconstruct.page): files written, what the HTML and CSV say,
reruns, failed inputs, and (with bpy) pictures of input and result in one frame."""

import csv
import io
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from geocode.points import sample_surface
from geocode.reconstruct.page import (
    CLOUD_POINTS,
    Candidate,
    Entry,
    cloud_mesh,
    median,
    picture_path,
    picture_stem,
    render_entry,
    single_sided,
    summary_csv,
    write_page,
)


def box(size=1.0, offset=(0, 0, 0)) -> trimesh.Trimesh:
    mesh = trimesh.creation.box((size, size, size))
    mesh.apply_translation(offset)
    mesh.metadata["part"] = np.arange(len(mesh.faces)) % 3
    return mesh


class FakeRender:
    """Writes a small PNG per call and records what it was asked to draw."""

    def __init__(self):
        self.calls = []

    def __call__(self, mesh, png, color=None, size=None):
        self.calls.append((Path(png).name, len(mesh.faces), color, size))
        Path(png).parent.mkdir(parents=True, exist_ok=True)
        Image.new("RGB", (size or 8, size or 8), "white").save(png)


def entries() -> list[Entry]:
    rng = np.random.default_rng(0)
    return [
        Entry("chairs/office/a.ply", "mesh", input=box(), result=box(0.9), before=0.02, after=0.005,
              seconds=10.0, pose={"up": "+y", "turn": 90.0, "scale": 1.1},
              parameters={"seat_height": 0.45, "legs": 4.0}, links={"yaml": "chairs/office/a.yaml",
                                                                   "obj": "chairs/office/a.obj"},
              candidates=[Candidate(box(0.8), 0.007, {"yaml": "chairs/office/a.2.yaml"})]),
        Entry("scans/b <1>.xyz", "cloud", input=rng.uniform(-0.5, 0.5, (5000, 3)), result=box(),
              before=0.01, after=0.004, seconds=20.0, pose={"up": "-z", "turn": 0.0, "offset": [0, 0.1, 0]},
              links={"yaml": "scans/b <1>.yaml"}),
        Entry("bad/empty.stl", "mesh", error="bad/empty.stl: the file is empty; give a mesh"),
    ]


def csv_rows(path: Path) -> list[dict]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


def test_write_page_writes_page_csv_and_pictures(tmp_path):
    render = FakeRender()
    index = write_page(entries(), tmp_path, "chairs <demo>", render=render)
    assert index == tmp_path / "index.html"
    text = index.read_text()
    assert "<title>chairs &lt;demo&gt;</title>" in text
    assert "scans/b &lt;1&gt;.xyz" in text                 # names escaped
    assert text.count("<section class='card") == 3
    pngs = sorted(p.name for p in (tmp_path / "page").iterdir())
    assert len(pngs) == 5                                   # 2 + 1 candidate, 2, none for the error
    # input in one neutral colour, result by part; candidate as a smaller thumbnail
    colours = {name.rsplit("-", 1)[1]: (color, size) for name, _, color, size in render.calls}
    assert colours["input.png"][0] is not None and colours["result.png"][0] is None
    assert colours["candidate2.png"][1] < colours["result.png"][1]


def test_cloud_drawn_as_spheres_at_a_subsample(tmp_path):
    render = FakeRender()
    write_page(entries()[1:2], tmp_path, "t", render=render)
    faces = dict((name.rsplit("-", 1)[1], n) for name, n, _, _ in render.calls)
    assert faces["input.png"] == CLOUD_POINTS * 20          # an icosahedron per point
    assert f"{CLOUD_POINTS:,} of 5,000 points" in (tmp_path / "index.html").read_text()


def test_a_double_sided_input_is_drawn_with_each_face_once(tmp_path):
    """Every face repeated with the other winding on copied vertices (as in many asset files):
    one copy of each is drawn, so that Cycles does not shade the coincident faces black."""
    single = box()
    doubled = trimesh.Trimesh(np.concatenate([single.vertices, single.vertices]),
                              np.concatenate([single.faces, single.faces[:, ::-1] + len(single.vertices)]),
                              process=False)
    assert len(single_sided(doubled).faces) == 12 and len(single_sided(single).faces) == 12
    render = FakeRender()
    write_page([Entry("double.obj", "mesh", input=doubled, result=box())], tmp_path, "t", render=render)
    assert ("double.obj-" in render.calls[0][0]) and render.calls[0][1] == 12


def test_cloud_mesh_spheres_sit_on_the_points():
    points = np.random.default_rng(1).uniform(-1, 1, (50, 3))
    mesh = cloud_mesh(points, radius=0.01)
    centres = mesh.vertices.reshape(50, 12, 3).mean(axis=1)
    assert np.allclose(centres, points, atol=1e-9)
    assert np.allclose(np.linalg.norm(mesh.vertices.reshape(50, 12, 3) - centres[:, None], axis=2), 0.01)
    assert len(cloud_mesh(np.zeros((10_000, 3)), n=100).faces) == 100 * 20


def test_page_is_self_contained_and_every_reference_exists(tmp_path):
    write_page(entries(), tmp_path, "t", render=FakeRender())
    text = (tmp_path / "index.html").read_text()
    assert "<script" not in text and "http" not in text and "<link" not in text
    for src in re.findall(r"<img src='([^']+)'", text):
        assert (tmp_path / src).is_file(), src
    hrefs = re.findall(r"<a href='([^'#][^']*)'", text)
    assert "scans/b%20%3C1%3E.yaml" in hrefs                # quoted, relative
    assert all(not h.startswith("/") for h in hrefs)


def test_card_shows_distances_pose_links_parameters_candidates(tmp_path):
    write_page(entries(), tmp_path, "t", render=FakeRender())
    card = (tmp_path / "index.html").read_text().split("id='input-0'")[1].split("</section>")[0]
    assert "network 0.02 &rarr; after fit <b>0.005</b>" in card and "(-75%)" in card
    assert "up +y" in card and "turn 90\N{DEGREE SIGN}" in card and "scale 1.1" in card
    assert "<a href='chairs/office/a.yaml'>yaml</a>" in card
    assert "<details><summary>2 parameters</summary>" in card and "seat_height" in card
    assert "#2 &middot; 0.007" in card and "chairs/office/a.2.yaml" in card


def test_header_medians_leave_failed_inputs_out(tmp_path):
    write_page(entries(), tmp_path, "t", render=FakeRender())
    text = (tmp_path / "index.html").read_text()
    assert "3 inputs, <span class='worse'>1 failed</span>" in text
    assert "median distance network 0.015 &rarr; after fit <b>0.0045</b>" in text
    assert "median 15.0 s per input" in text


def test_header_keeps_drawings_px_apart_from_shapes_distances(tmp_path):
    user_png = tmp_path / "in.png"
    Image.new("L", (40, 20), 255).save(user_png)
    drawing = Entry("d/doodle.png", "drawing", input=user_png, result=box(), before=6.0, after=4.5,
                    seconds=5.0, unit=" px")
    write_page([*entries(), drawing], tmp_path / "out", "t", render=FakeRender())
    lead = (tmp_path / "out" / "index.html").read_text().split("class='lead'>")[1].split("</p>")[0]
    assert "median distance of the shapes network 0.015 &rarr; after fit <b>0.0045</b>" in lead
    assert "median distance of the drawings network 6 px &rarr; after fit <b>4.5</b> px" in lead


def test_failed_input_gets_its_message_and_no_pictures(tmp_path):
    write_page(entries(), tmp_path, "t", render=FakeRender())
    card = (tmp_path / "index.html").read_text().split("id='input-2'")[1].split("</section>")[0]
    assert "the file is empty; give a mesh" in card and "<img" not in card
    row = csv_rows(tmp_path / "summary.csv")[2]
    assert row["error"].startswith("bad/empty.stl: the file is empty") and row["after"] == ""


def test_summary_csv_columns_and_values(tmp_path):
    write_page(entries(), tmp_path, "t", render=FakeRender())
    rows = csv_rows(tmp_path / "summary.csv")
    assert list(rows[0]) == ["name", "kind", "before", "after", "seconds", "pose_up", "pose_turn",
                             "pose_scale", "pose_offset", "files", "error"]
    assert rows[0]["name"] == "chairs/office/a.ply" and float(rows[0]["after"]) == 0.005
    assert rows[0]["files"] == "chairs/office/a.yaml;chairs/office/a.obj"
    assert rows[1]["pose_offset"] == "(0, 0.1, 0)" and rows[1]["pose_scale"] == ""


def test_rerun_replaces_files_and_removes_stale_pictures_and_no_other_file(tmp_path):
    write_page(entries(), tmp_path, "first", render=FakeRender())
    (tmp_path / "page" / ".x.ply-0123abcd-result.png.abc_12.tmp").write_text("left by a killed run")
    (tmp_path / "page" / "sketch.png").write_text("the user's")
    write_page(entries()[1:2], tmp_path, "second", render=FakeRender())
    assert "<h1>second</h1>" in (tmp_path / "index.html").read_text()
    assert len(csv_rows(tmp_path / "summary.csv")) == 1
    shown = [Path(picture_path("scans/b <1>.xyz", role)).name for role in ("input", "result")]
    assert sorted(p.name for p in (tmp_path / "page").iterdir()) == sorted([*shown, "sketch.png"])
    assert (tmp_path / "page" / "sketch.png").read_text() == "the user's"


def test_failed_rendering_leaves_the_previous_page_whole(tmp_path):
    write_page(entries(), tmp_path, "first", render=FakeRender())
    before = {p: p.read_bytes() for p in (tmp_path / "index.html", tmp_path / "summary.csv")}

    def broken(mesh, png, color=None, size=None):
        raise RuntimeError("renderer crashed")

    with pytest.raises(RuntimeError):
        write_page(entries(), tmp_path, "second", render=broken)
    assert {p: p.read_bytes() for p in before} == before


def test_drawn_entries_are_not_drawn_again(tmp_path):
    render = FakeRender()
    drawn = [render_entry(e, tmp_path, render) for e in entries()]
    calls = len(render.calls)
    write_page(drawn, tmp_path, "t", render=render)
    assert len(render.calls) == calls


def test_drawing_entry_shows_the_drawing_and_our_line_drawing(tmp_path):
    strokes = np.ones((1, 224, 224), dtype=np.float32)
    strokes[0, 50:150, 100:102] = 0.0
    user_png = tmp_path / "in.png"
    Image.new("L", (400, 200), 255).save(user_png)
    entry = Entry("d/doodle.png", "drawing", input=user_png, result_drawing=strokes, result=box(),
                  before=0.003)
    write_page([entry], tmp_path / "out", "t", render=FakeRender())
    text = (tmp_path / "out" / "index.html").read_text()
    assert "input drawing" in text and "our line drawing of the result" in text
    assert "network 0.003" in text and "after fit" not in text.split("id='input-0'")[1]
    with Image.open(tmp_path / "out" / entry.pictures["result_drawing"]) as img:
        pixels = np.asarray(img.convert("L"))
    assert img.size == (256, 256) and pixels.min() == 0 and pixels.max() == 255


def test_picture_names_are_safe_and_distinct():
    a, b = picture_stem("a/b.ply"), picture_stem("a_b.ply")
    assert a != b and "/" not in a and re.fullmatch(r"[A-Za-z0-9._-]+", picture_stem("ü ö/<x>.obj"))


def test_entry_checks_its_kind_and_geometry():
    with pytest.raises(ValueError, match="kind 'scan'"):
        Entry("x", "scan", input=box(), result=box())
    with pytest.raises(ValueError, match="give its input and result"):
        Entry("x", "mesh", input=box())
    Entry("x.foo", "", error="x.foo: unknown input kind .foo")


def test_names_given_twice_are_refused(tmp_path):
    twice = [Entry("a.ply", "mesh", error="bad"), Entry("a.ply", "mesh", error="bad")]
    with pytest.raises(ValueError, match=r"names given twice \(a.ply\)"):
        write_page(twice, tmp_path, "t", render=FakeRender())


def test_median_skips_missing_values():
    assert median([None, 1.0, float("nan"), 3.0]) == 2.0 and median([None]) is None


def test_summary_csv_of_no_entries_is_a_header():
    assert summary_csv([]).splitlines() == ["name,kind,before,after,seconds,files,error"]


@pytest.mark.blender
def test_input_and_result_share_camera_and_scale(blender, tmp_path):
    """Not renormalised one by one: a result half the input's size draws half as wide, the same
    mesh draws the same picture; the input in its neutral colour, the result by part."""
    mesh = box(1.0)
    small = box(0.5)
    write_page([Entry("same", "mesh", input=mesh, result=mesh),
                Entry("half", "mesh", input=mesh, result=small)], tmp_path, "t")

    def picture(entry_index, role):
        name = f"{picture_stem(['same', 'half'][entry_index])}-{role}.png"
        with Image.open(tmp_path / "page" / name) as img:
            return np.asarray(img.convert("RGB")).astype(int)

    def width(pixels):
        columns = np.nonzero((pixels < 245).any(axis=2).any(axis=0))[0]
        return columns.max() - columns.min() + 1

    same_in, same_out, half_out = picture(0, "input"), picture(0, "result"), picture(1, "result")
    assert abs(width(same_in) - width(same_out)) <= 1
    assert width(half_out) == pytest.approx(width(same_in) / 2, abs=3)
    inside = (same_in < 245).any(axis=2)
    assert len(np.unique(same_in[inside] // 40, axis=0)) < len(np.unique(same_out[inside] // 40, axis=0))


@pytest.mark.blender
def test_cloud_rendered_shaded(blender, tmp_path):
    points = sample_surface(box(), 4000, np.random.default_rng(0))
    entry = Entry("c.xyz", "cloud", input=points, result=box())
    write_page([entry], tmp_path, "t")
    with Image.open(tmp_path / entry.pictures["input"]) as img:
        pixels = np.asarray(img.convert("L"))
    drawn = pixels[pixels < 245]
    assert drawn.size > 2000 and drawn.std() > 5          # spheres, lit: several shades


CHROMIUM = shutil.which("chromium")
# Appended to a copy of the page (details opened): after load, the body says how many images
# decoded and whether anything is wider than the window.
LAYOUT_CHECK = ("<script>addEventListener('load', () => { const im = [...document.images];"
                " document.body.dataset.images = im.filter(i => i.complete && i.naturalWidth > 0).length"
                " + '/' + im.length; document.body.dataset.overflow ="
                " document.documentElement.scrollWidth > innerWidth; });</script>")


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium (scripts/setup.sh installs it as root)")
def test_page_in_chromium_loads_every_image_and_fits_the_window(tmp_path):
    many = {f"parameter_with_a_long_name_{i}": i / 7 for i in range(60)}
    shown = entries()
    shown[0].parameters = many
    index = write_page(shown, tmp_path, "t", render=FakeRender())
    checked = tmp_path / "checked.html"
    checked.write_text(index.read_text().replace("<details>", "<details open>") + LAYOUT_CHECK)
    dom = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--window-size=1200,1600",
                          "--dump-dom", checked.resolve().as_uri()],
                         check=True, capture_output=True, text=True, timeout=120).stdout
    assert 'data-images="5/5"' in dom and 'data-overflow="false"' in dom
