"""Freestyle sketches through real Blender (Cycles on the CPU): image format, cameras,
determinism, mesh swapping, and the shard driver's skip/done-file behaviour."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh
from PIL import Image

from geocode import meshio
from geocode.blender import sketch

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


def test_sketch_is_grey_black_on_white(tmp_path):
    data = _render(_cube(), tmp_path, CAMS[0])
    img = Image.open(io.BytesIO(data))
    assert img.mode == "L" and img.size == (224, 224)
    assert not img.info                                                # no render-time text
    px = np.asarray(img)
    assert (px[:8, :8] == 255).all() and (px[-8:, -8:] == 255).all()   # white background
    assert (px < 128).sum() > 100                                      # some strokes
    assert np.median(px) == 255                                        # mostly white


def test_cameras_differ_and_render_is_deterministic(tmp_path):
    cube = _cube()
    a = _render(cube, tmp_path, CAMS[0])
    b = _render(cube, tmp_path, CAMS[1])
    assert a != b
    assert _render(cube, tmp_path, CAMS[0]) == a


def test_jitter_is_seeded(tmp_path):
    cube = _cube()
    kw = dict(shape_id="train-000001", jitter=2.0)
    a = _render(cube, tmp_path, CAMS[0], seed=7, **kw)
    assert _render(cube, tmp_path, CAMS[0], seed=7, **kw) == a
    assert _render(cube, tmp_path, CAMS[0], seed=8, **kw) != a
    assert _render(cube, tmp_path, CAMS[0]) != a                       # jitter moved the view
    j = sketch.jittered(CAMS[0], 7, "train-000001", 2.0)
    assert abs(j.azimuth - CAMS[0].azimuth) <= 2 and abs(j.elevation - CAMS[0].elevation) <= 2


def test_mesh_swap_shows_the_new_mesh(tmp_path):
    cube_first = _render(_cube(), tmp_path, CAMS[0])
    sphere = _render(_sphere(), tmp_path, CAMS[0])
    assert sphere != cube_first
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
