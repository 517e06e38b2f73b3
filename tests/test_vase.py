"""The vase program: its parameter space, inferred rules, and validity over random shapes."""

import hashlib

import numpy as np
import pytest
import trimesh

from geocode.program import Program
from geocode.recipe import Recipe
from geocode.stability import loose_parts

pytestmark = pytest.mark.blender

BODY, HANDLE, LID, KNOB, FOOT = 1, 4, 5, 6, 7


@pytest.fixture(scope="module")
def vase():
    return Program.load("vase")


def _digest(mesh) -> str:
    return hashlib.sha256(np.round(mesh.vertices, 6).tobytes() + mesh.faces.tobytes()).hexdigest()


def _assert_valid(mesh, values=None):
    assert len(mesh.faces) > 0, values
    assert np.isfinite(mesh.vertices).all(), values
    assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6), values  # resting on z=0
    assert len(mesh.metadata["part"]) == len(mesh.faces)
    assert (mesh.metadata["part"] > 0).all()  # every face belongs to a labelled part
    assert loose_parts(mesh) == 0, values


def test_parameter_space(vase):
    kinds = [p.kind for p in vase.parameters]
    assert len(vase.parameters) == 39
    assert kinds.count("float") == 32 and len(kinds) - kinds.count("float") == 7
    assert all(p.description for p in vase.parameters)


def test_recipe_loads_against_the_program(vase):
    from geocode.paths import programs_dir

    recipe = Recipe.load(programs_dir() / "vase.yaml", vase.parameters, vase.visibility())
    assert len(recipe.parameters) == len(vase.parameters)
    floats = [p for p in recipe.parameters if p.kind == "float"]
    assert all(3 <= p.samples <= 6 for p in floats)


def test_inferred_visibility_rules(vase):
    rules = {name: None if rule is None else str(rule)
             for name, rule in vase.visibility().items()}
    assert sum(rule is not None for rule in rules.values()) >= 5
    assert rules["handle_reach"] == "handle_count > 0"
    assert rules["lid_dome"] == "lid"
    assert rules["knob_size"] in ("knob and lid", "lid and knob")
    assert rules["leg_count"] == "foot_style == 2"
    assert rules["foot_height"] == "foot_style == 1 or foot_style == 2"
    assert rules["body_height"] is None and rules["handle_count"] is None


def test_hidden_parameters_do_not_change_the_shape(vase):
    base = _digest(vase.evaluate({"handle_count": 0, "lid": 0, "foot_style": 0}))
    for name, value in (("handle_reach", 0.3), ("knob_size", 0.07), ("leg_splay", 0.1),
                        ("foot_height", 0.15)):
        changed = vase.evaluate({"handle_count": 0, "lid": 0, "foot_style": 0, name: value})
        assert _digest(changed) == base, name


def test_default_and_corner_vases_are_valid(vase):
    _assert_valid(vase.evaluate({}))
    for corner in ("min", "max"):
        values = {p.name: getattr(p, corner) for p in vase.parameters}
        _assert_valid(vase.evaluate(values), corner)


def test_same_values_give_the_same_mesh(vase):
    values = vase.random_values(np.random.default_rng(3))
    first = _digest(vase.evaluate(values))
    vase.evaluate({})
    assert _digest(vase.evaluate(values)) == first


def test_edits_propagate(vase):
    low = vase.evaluate({"body_height": 0.8, "lid": 1, "handle_count": 2})
    high = vase.evaluate({"body_height": 1.4, "lid": 1, "handle_count": 2})
    def top(mesh, part):
        return mesh.vertices[mesh.faces[mesh.metadata["part"] == part]][..., 2].max()

    for part in (LID, KNOB, HANDLE):  # they move up with the body
        assert top(high, part) > top(low, part) + 0.3
    assert not np.array_equal(low.vertices, high.vertices)


def test_handles_touch_the_body_at_both_ends(vase):
    for roundness in (0.0, 1.0):  # square bodies reach farthest at the handles' azimuths
        mesh = vase.evaluate({"handle_count": 3, "roundness": roundness, "twist": 0.7})
        parts = mesh.metadata["part"]
        body = mesh.submesh([np.flatnonzero(parts == BODY)], append=True)
        handles = mesh.submesh([np.flatnonzero(parts == HANDLE)], append=True)
        pieces = handles.split(only_watertight=False)
        assert len(pieces) == 3
        for piece in pieces:
            middle = np.median(piece.triangles_center[:, 2])
            for lower in (True, False):  # each half of the handle touches the body alone
                keep = (piece.triangles_center[:, 2] < middle) == lower
                half = piece.submesh([np.flatnonzero(keep)], append=True)
                assert loose_parts(trimesh.util.concatenate([body, half])) == 0


@pytest.mark.parametrize("foot_style", [0, 1, 2])
def test_feet_rest_on_the_ground(vase, foot_style):
    mesh = vase.evaluate({"foot_style": foot_style, "foot_height": 0.2, "leg_splay": 0.15})
    _assert_valid(mesh)
    parts = mesh.metadata["part"]
    lowest = mesh.vertices[mesh.faces[parts == (FOOT if foot_style else BODY)]][..., 2].min()
    assert lowest == pytest.approx(0.0, abs=1e-6)


def test_random_vases_are_valid(vase):
    rng = np.random.default_rng(2024)
    for _ in range(200):
        values = vase.random_values(rng)
        _assert_valid(vase.evaluate(values), values)
