"""The stool of docs/guide/programs.md is a real program: it builds, its recipe loads, every
shape is valid and its tree is laid out in groups, and it renders."""

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from geocode.paths import PROGRAMS_ENV
from geocode.program import Program, registry
from geocode.stability import loose_parts

pytestmark = pytest.mark.blender

EXAMPLES = Path(__file__).resolve().parents[1] / "docs" / "examples"
SEAT, LEGS, FOOTREST = 1, 2, 3


@pytest.fixture(scope="module")
def stool():
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(PROGRAMS_ENV, str(EXAMPLES))
        assert registry() == ["stool"]
        yield Program.load("stool")


def _settings(stool):
    rng = np.random.default_rng(0)
    return [{}, {p.name: p.min for p in stool.parameters},
            {p.name: p.max for p in stool.parameters},
            *(stool.random_values(rng) for _ in range(8))]


def test_stool_builds_with_its_recipe_and_rules(stool):
    assert [p.name for p in stool.parameters][:2] == ["seat_height", "seat_width"]
    assert len(stool.parameters) == 9
    assert str(stool.visibility()["footrest_height"]) == "footrest"
    recipe = stool.recipe()
    assert {p.name for p in recipe.parameters} == {p.name for p in stool.parameters}


def test_every_stool_stands_in_one_piece_with_its_labels(stool):
    for values in _settings(stool):
        mesh = stool.evaluate(values)
        full = stool.check(values)
        assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6), values
        assert loose_parts(mesh) == 0, values
        expected = {SEAT, LEGS} | ({FOOTREST} if full["footrest"] else set())
        assert set(np.unique(mesh.metadata["part"])) == expected, values


def test_the_stool_tree_reads_as_its_groups(stool):
    nodes = [n for n in stool.tree.nodes if n.bl_idname != "NodeFrame"]
    groups = sorted(n.label for n in nodes if n.bl_idname == "GeometryNodeGroup" and n.label)
    assert groups == ["Footrest", "Legs", "Seat"]
    assert all(n.label in groups or (n.parent and n.parent.label) for n in nodes)


def test_the_stool_renders(stool, tmp_path):
    from geocode.blender.gallery import render_gallery

    out = render_gallery("stool", tmp_path / "stool.png", n=2, program=stool)
    with Image.open(out) as image:
        pixels = np.asarray(image.convert("L"))
    assert (pixels < 200).mean() > 0.02  # the stools are drawn, not a blank sheet
