"""Rebuilding predictions: OBJs on the unit sphere, keys with folders, resume; a gallery from a
test double; the real vase."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from test_export import TowerDouble, _vase

from geocode import meshio
from geocode.blender import rebuild as rb
from geocode.blender.export import random_rows


def test_rebuild_writes_unit_sphere_objs(tmp_path):
    rows = [("sketch/test-000001", {"height": 0.7}), ("pc/test-000002", {"height": 1.9, "legs": 3})]
    paths = rb.rebuild("tower", rows, tmp_path, program=TowerDouble())
    assert paths == [tmp_path / "sketch/test-000001.obj", tmp_path / "pc/test-000002.obj"]
    for path in paths:
        mesh = meshio.read_obj(path)
        assert np.linalg.norm(mesh.vertices, axis=1).max() == pytest.approx(1.0, abs=1e-5)
    stamp = paths[0].stat().st_mtime_ns
    rb.rebuild("tower", rows, tmp_path, program=TowerDouble(), overwrite=False)   # resumes
    assert paths[0].stat().st_mtime_ns == stamp
    rb.rebuild("tower", [(rows[0][0], {"height": 1.5})], tmp_path, program=TowerDouble())
    assert paths[0].stat().st_mtime_ns != stamp                         # new values replace


def test_rebuild_names_the_failing_key(tmp_path):
    class Broken(TowerDouble):
        def evaluate(self, values):
            raise ValueError("height=9 is outside [0.5, 2]")

    with pytest.raises(ValueError, match="test-000007.*height"):
        rb.rebuild("tower", [("test-000007", {"height": 9})], tmp_path, program=Broken())
    assert not list(tmp_path.iterdir())


@pytest.mark.blender
def test_gallery_of_a_double(tmp_path):
    from geocode.blender.gallery import render_gallery

    out = render_gallery("tower", tmp_path / "g.png", n=4, program=TowerDouble())
    img = Image.open(out)
    assert img.size == (1024, 256) and img.mode == "RGB"
    px = np.asarray(img)
    assert (px[-4:, -4:] == 255).all()                                   # white background
    assert (px.std(axis=2) > 20).any()                                   # coloured parts


@pytest.mark.blender
def test_rebuild_real_vase(tmp_path):
    program, _ = _vase()
    rows = random_rows(program, 3, seed=5)
    paths = rb.rebuild("vase", rows, tmp_path, program=program)
    for path, (_, values) in zip(paths, rows, strict=True):
        mesh = meshio.read_obj(path)
        assert len(mesh.faces) == len(program.evaluate(values).faces)
