"""Freestyle sketches through real Blender (Cycles on the CPU): image format, strokes where the
shape projects from each camera, determinism, mesh swapping, and the shard driver's
skip/done-file behaviour."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh
from PIL import Image, ImageDraw
from scipy import ndimage
from scipy.spatial import ConvexHull

from geocode import meshio
from geocode.blender import sketch
from geocode.blender.scene import MARGIN, camera_location

pytestmark = pytest.mark.blender

CAMS = sketch.DEFAULT_CAMERAS


def _cube():
    return meshio.normalise_unit_sphere(trimesh.creation.box((1.0, 0.8, 1.2)))


def _sphere():
    return meshio.normalise_unit_sphere(trimesh.creation.icosphere(3))


def _render(mesh, tmp_path, cam, name="x.png", **kw):
    out = tmp_path / name
    sketch.sketch_mesh(mesh, {cam.name: out}, [cam], **kw)
    return out.read_bytes()


def _pixels(data: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(data)))


def _projected(mesh, cam: sketch.Camera, size: int = 224) -> np.ndarray:
    """The mesh's vertices in pixels (x right, y down) as blender/scene.py's camera promises to
    see them: orthographic from `camera_location`, +z up, the image spanning 2 * MARGIN radii."""
    eye = np.array(camera_location(cam))
    forward = -eye / np.linalg.norm(eye)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    k, v = size / (2 * MARGIN), np.asarray(mesh.vertices)
    return np.stack([size / 2 + k * (v @ right), size / 2 - k * (v @ up)], axis=1)


def _misses(data: bytes, mesh, cam: sketch.Camera) -> tuple[float, float]:
    """For a convex mesh: (how far, in px, the farthest stroke pixel lies outside the mesh's
    projected outline; how far the farthest point of that outline lies from a stroke)."""
    ink = _pixels(data) < 128
    xy = _projected(mesh, cam)
    hull = xy[ConvexHull(xy).vertices]
    region = Image.new("1", ink.shape[::-1], 0)
    ImageDraw.Draw(region).polygon([tuple(p) for p in hull], fill=1)
    outside = ndimage.distance_transform_edt(~np.asarray(region))[ink].max()
    outline = np.concatenate([np.linspace(p, q, int(np.linalg.norm(q - p)) + 2)
                              for p, q in zip(hull, np.roll(hull, -1, axis=0), strict=True)])
    cols, rows = np.clip(outline.astype(int), 0, np.array(ink.shape[::-1]) - 1).T
    return float(outside), float(ndimage.distance_transform_edt(~ink)[rows, cols].max())


def test_sketch_is_black_strokes_on_white_where_the_shape_projects(tmp_path):
    data = _render(_cube(), tmp_path, CAMS[0])
    img = Image.open(io.BytesIO(data))
    assert img.mode == "L" and img.size == (224, 224)
    assert not img.info                                                # no render-time text
    px = np.asarray(img)
    assert px.min() == 0 and np.median(px) == 255                      # black strokes, mostly white
    assert max(_misses(data, _cube(), CAMS[0])) <= 1.5                 # the outline drawn, nothing else


def test_each_camera_draws_its_own_view_and_render_is_deterministic(tmp_path):
    cube = _cube()
    drawn = {cam.name: _render(cube, tmp_path, cam) for cam in CAMS}
    for cam in CAMS:
        assert max(_misses(drawn[cam.name], cube, cam)) <= 1.5, cam
    assert min(_misses(drawn[CAMS[0].name], cube, CAMS[1])) > 5      # 20 degrees apart: far off
    assert _render(cube, tmp_path, CAMS[0]) == drawn[CAMS[0].name]


def test_jitter_is_seeded(tmp_path):
    cube = _cube()
    kw = dict(shape_id="train-000001", jitter=2.0)
    a = _render(cube, tmp_path, CAMS[0], seed=7, **kw)
    assert _render(cube, tmp_path, CAMS[0], seed=7, **kw) == a
    assert _render(cube, tmp_path, CAMS[0], seed=8, **kw) != a
    assert _render(cube, tmp_path, CAMS[0]) != a                       # jitter moved the view
    j = sketch.jittered(CAMS[0], 7, "train-000001", 2.0)
    assert abs(j.azimuth - CAMS[0].azimuth) <= 2 and abs(j.elevation - CAMS[0].elevation) <= 2
    assert j != CAMS[0] and max(_misses(a, cube, j)) <= 1.5            # drawn from the jittered view


def test_mesh_swap_shows_the_new_mesh(tmp_path):
    cube_first = _render(_cube(), tmp_path, CAMS[0])
    sphere = _render(_sphere(), tmp_path, CAMS[0])
    assert max(_misses(sphere, _sphere(), CAMS[0])) <= 1.5             # the sphere's circle
    assert _render(_cube(), tmp_path, CAMS[0]) == cube_first           # no stale geometry


def test_cameras_from_config():
    cams = sketch.cameras_from_config([{"name": "a", "azimuth": 35}, {"name": "b", "azimuth": 15,
                                                                     "elevation": 10}])
    assert cams == [sketch.Camera("a", 35.0, 30.0), sketch.Camera("b", 15.0, 10.0)]
    with pytest.raises(ValueError, match="azimuth"):
        sketch.cameras_from_config([{"name": "a"}])


def _split(tmp_path, ids):
    for i, shape_id in enumerate(ids):
        mesh = _cube() if i % 2 == 0 else _sphere()
        meshio.write_obj(tmp_path / "shapes" / f"{shape_id}.obj", mesh)
    meshio.write_text(tmp_path / "done" / "export-0.txt", "".join(f"{i}\n" for i in ids))


def test_sketch_shard_skips_finished_work_and_writes_done_last(tmp_path):
    ids = ["train-000000", "train-000001"]
    _split(tmp_path, ids)
    cams = CAMS[:2]
    done = sketch.sketch_shard(tmp_path, 0, cams)
    pngs = sorted((tmp_path / "sketches").glob("*.png"))
    assert [p.name for p in pngs] == sorted(f"{i}_{c.name}.png" for i in ids for c in cams)
    assert done.read_text().split() == ids
    assert done.stat().st_mtime_ns >= max(p.stat().st_mtime_ns for p in pngs)
    assert not list((tmp_path / "sketches").glob(".*"))               # no temporary leftovers

    stamps = {p.name: p.stat().st_mtime_ns for p in pngs}
    redo = tmp_path / "sketches" / f"{ids[1]}_{cams[0].name}.png"
    before = redo.read_bytes()
    redo.unlink()
    sketch.sketch_shard(tmp_path, 0, cams)
    assert redo.read_bytes() == before                                  # redone, same bytes
    for p in pngs:
        if p != redo:
            assert p.stat().st_mtime_ns == stamps[p.name]               # skipped


def test_sketch_shard_draws_only_the_shapes_asked_for(tmp_path):
    ids = ["train-000000", "train-000001"]
    _split(tmp_path, ids)
    done = sketch.sketch_shard(tmp_path, 0, CAMS[:1], only=lambda found: found[1:])
    assert [p.name for p in (tmp_path / "sketches").glob("*.png")] == [f"{ids[1]}_{CAMS[0].name}.png"]
    assert done.read_text().split() == [ids[1]]


def test_sketch_shard_without_a_mesh_leaves_no_done_file(tmp_path):
    _split(tmp_path, ["train-000000"])
    meshio.write_text(tmp_path / "done" / "export-0.txt", "train-000000\ntrain-000009\n")
    with pytest.raises(ValueError, match="train-000009"):
        sketch.sketch_shard(tmp_path, 0, CAMS[:1])
    assert not (tmp_path / "done" / "sketch-0.txt").exists()


def test_renderer_survives_a_factory_reset(tmp_path):
    import bpy

    a = _render(_cube(), tmp_path, CAMS[0])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert _render(_cube(), tmp_path, CAMS[0]) == a


def test_ctrl_c_during_a_render_arrives_after_it_and_leaves_no_image(tmp_path):
    """Freestyle would swallow a KeyboardInterrupt raised inside its shaders and 'finish' a
    blank sketch; the signal must wait for the render and stop the caller before the rename."""
    import os
    import signal

    import bpy

    cam = sketch.DEFAULT_CAMERAS[0]
    out = tmp_path / "interrupted.png"

    def interrupt(*_):   # Ctrl+C as the render starts (a timer raced the render on a busy machine)
        os.kill(os.getpid(), signal.SIGINT)

    # Ctrl+C as in a terminal, whatever the runner inherited (a shell ignores SIGINT in what it
    # starts in the background) or an earlier test left
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    bpy.app.handlers.render_pre.append(interrupt)
    try:
        with pytest.raises(KeyboardInterrupt):
            sketch.sketch_mesh(_sphere(), {cam.name: out}, [cam])
    finally:
        bpy.app.handlers.render_pre.remove(interrupt)
        signal.signal(signal.SIGINT, previous)
    assert not out.exists() and not list(tmp_path.glob(".*"))
