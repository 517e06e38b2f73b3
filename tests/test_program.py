"""Program contract (docs/design.md): loading, parameters, evaluation, visibility inference,
manifest, .blend, registry, sampling, bench; on a small hand-built program."""

import hashlib
import itertools
import json
import statistics
import time

import numpy as np
import pytest

from geocode.bench.program import bench_program
from geocode.expr import parse
from geocode.paths import PROGRAMS_ENV
from geocode.program import Program, registry
from geocode.recipe import parse_manifest
from geocode.stability import is_stable, loose_parts

pytestmark = pytest.mark.blender

# A program with nested switches whose visibility rules are known:
#   w: a and n > 1   (Switch in Switch)        h: n == 1 or n == 2   (Index Switch items)
#   k: not a         (a Switch inside a node group, fed by `not a`)
#   a, n (selectors only), offset_* (always used): always visible
TOY = '''
from geocode.nodes import Graph, node_group


@node_group("ToyGate")
def gate(g):
    """Pass Geometry through when On is true."""
    geometry = g.input("Geometry", "geometry")
    on = g.input("On", "bool", default=True)
    g.output("Geometry", "geometry", g.switch(on, None, geometry, data_type="GEOMETRY"))


def cube(g, size, x):
    mesh = g.node("GeometryNodeMeshCube", {"Size": g.vec(size, size, size)})
    return g.label(g.transform(mesh, translation=g.vec(x, 0, 0)), 1)


def build(g: Graph):
    a = g.input("a", "bool", default=True, description="gate")
    n = g.input("n", "int", default=1, min=0, max=3)
    w = g.input("w", "float", default=0.5, min=0.1, max=1.0)
    h = g.input("h", "float", default=0.5, min=0.1, max=1.0)
    k = g.input("k", "float", default=0.5, min=0.1, max=1.0)
    offset = g.input("offset", "vector", default=(0, 0, 0), min=-1, max=1)
    base = g.transform(cube(g, 1.0, 0), translation=offset)
    many = g.compare("GREATER_THAN", n, 1, data_type="INT")
    inner = g.switch(many, None, cube(g, w, 2), data_type="GEOMETRY")
    outer = g.switch(a, None, inner, data_type="GEOMETRY")
    indexed = g.index_switch(n, [None, cube(g, h, -2), cube(g, h, -2)], data_type="GEOMETRY")
    gated = gate(g, geometry=cube(g, k, 4), on=g.boolean("NOT", a))["Geometry"]
    g.output("Geometry", "geometry", g.join([base, outer, indexed, gated]))
'''
EXPECTED_RULES = {"a": None, "n": None, "w": "a and n > 1", "h": "n == 1 or n == 2",
                  "k": "not a", "offset_x": None, "offset_y": None, "offset_z": None}


@pytest.fixture
def programs(tmp_path, monkeypatch):
    (tmp_path / "toy.py").write_text(TOY)
    (tmp_path / "toy.yaml").write_text("parameters:\n  w: {min: 0.1, max: 1.0, samples: 3}\n")
    (tmp_path / "draft.py").write_text(TOY)  # no recipe: not in the registry
    monkeypatch.setenv(PROGRAMS_ENV, str(tmp_path))
    return tmp_path


@pytest.fixture
def toy(programs, blender):
    return Program.load("toy")


def _digest(mesh) -> str:
    return hashlib.sha256(np.round(mesh.vertices, 6).tobytes() + mesh.faces.tobytes()).hexdigest()


def test_registry_lists_programs_with_a_recipe(programs):
    assert registry() == ["toy"]


def test_unknown_domain_names_the_known_ones(programs):
    with pytest.raises(ValueError, match="known domains: toy"):
        Program.load("sofa")


def test_parameters_follow_the_group_inputs(toy):
    by_name = {p.name: p for p in toy.parameters}
    assert [p.name for p in toy.parameters] == list(EXPECTED_RULES)
    assert (by_name["a"].kind, by_name["a"].min, by_name["a"].max, by_name["a"].default) \
        == ("bool", 0.0, 1.0, 1.0)
    assert by_name["a"].description == "gate"
    assert (by_name["n"].kind, by_name["n"].max) == ("int", 3.0)
    assert (by_name["w"].kind, by_name["w"].min, by_name["w"].max) == ("float", 0.1, 1.0)
    assert by_name["offset_y"].kind == "float" and by_name["offset_y"].min == -1.0


def test_visibility_is_inferred_from_nested_switches(toy):
    rules = toy.visibility()
    assert set(rules) == set(EXPECTED_RULES)
    for name, expected in EXPECTED_RULES.items():
        if expected is None:
            assert rules[name] is None, name
            continue
        truth = parse(expected)
        for a, n in itertools.product((0, 1), range(4)):
            point = {"a": a, "n": n}
            assert bool(rules[name].evaluate(point)) == bool(truth.evaluate(point)), (name, point)
    assert str(rules["w"]) in ("a and n > 1", "n > 1 and a")


def test_inferred_rules_match_what_evaluation_does(toy):
    """Where a rule is false, the parameter has no effect; where it is true, it has."""
    rules = toy.visibility()
    for name in ("w", "h", "k"):
        for a, n in itertools.product((0, 1), range(4)):
            base = {"a": a, "n": n}
            low = _digest(toy.evaluate({**base, name: 0.2}))
            high = _digest(toy.evaluate({**base, name: 0.9}))
            assert (low != high) == bool(rules[name].evaluate(base)), (name, base)


def test_evaluate_fills_defaults_and_labels_faces(toy):
    mesh = toy.evaluate({})
    assert len(mesh.metadata["part"]) == len(mesh.faces) > 0
    assert (mesh.metadata["part"] == 1).all()
    assert np.isfinite(mesh.vertices).all()


def test_changing_a_parameter_changes_the_mesh(toy):
    before = toy.evaluate({"offset_z": 0.0})
    after = toy.evaluate({"offset_z": 0.5})
    assert after.vertices[:, 2].max() == pytest.approx(before.vertices[:, 2].max() + 0.5)


def test_evaluation_is_deterministic(toy):
    values = {"a": 0, "n": 2, "h": 0.3, "k": 0.7, "offset_x": 0.25}
    first = _digest(toy.evaluate(values))
    toy.evaluate({"n": 0})
    assert _digest(toy.evaluate(values)) == first


@pytest.mark.parametrize("values, message", [
    ({"width": 1.0}, "unknown parameter 'width'"),
    ({"w": 2.0}, r"w=2.0 is invalid: give a number in \[0.1, 1\]"),
    ({"n": 1.5}, r"n=1.5 is invalid: give an integer in \[0, 3\]"),
    ({"a": 2}, r"a=2 is invalid: give 0 or 1 in \[0, 1\]"),
])
def test_bad_values_raise_one_line_errors(toy, values, message):
    with pytest.raises(ValueError, match=message) as error:
        toy.evaluate(values)
    assert "\n" not in str(error.value)


def test_manifest_round_trips_through_the_recipe_reader(toy):
    manifest = json.loads(json.dumps(toy.manifest()))
    assert manifest["domain"] == "toy"
    parameters, visibility = parse_manifest(manifest)
    assert parameters == toy.parameters
    assert {k: None if v is None else str(v) for k, v in visibility.items()} == \
        {k: None if v is None else str(v) for k, v in toy.visibility().items()}


def test_the_manifest_fingerprints_the_geometry(programs, toy, blender):
    """The same program gives the same fingerprint; a change to its geometry alone (no
    parameter changes) gives another, and so another manifest."""
    first = toy.manifest()
    assert first["geometry"] == toy.fingerprint() and len(first["geometry"]) == 16
    (programs / "toy2.py").write_text(TOY.replace("cube(g, 1.0, 0)", "cube(g, 1.5, 0)"))
    changed = Program.load("toy2")
    assert [p.name for p in changed.parameters] == [p.name for p in toy.parameters]
    assert changed.fingerprint() != first["geometry"]
    blender.ops.wm.read_factory_settings(use_empty=True)
    assert Program.load("toy").fingerprint() == first["geometry"]


def test_save_blend_holds_the_program_tree(toy, tmp_path, blender):
    path = tmp_path / "out" / "toy.blend"
    toy.save_blend(path)
    assert path.exists() and not list(path.parent.glob(".*partial*"))
    with blender.data.libraries.load(str(path)) as (data_from, _):
        groups = list(data_from.node_groups)
    assert "GeoCode toy" in groups and "ToyGate" in groups


def test_program_survives_a_factory_reset(toy, blender):
    expected = _digest(toy.evaluate({"n": 2}))
    blender.ops.wm.read_factory_settings(use_empty=True)
    assert _digest(Program.load("toy").evaluate({"n": 2})) == expected


def test_random_values_cover_ranges_reproducibly(toy):
    draws = [toy.random_values(np.random.default_rng(7)) for _ in range(2)]
    assert draws[0] == draws[1]
    many = [toy.random_values(np.random.default_rng(seed)) for seed in range(200)]
    learned = {p.name: p for p in toy.recipe().parameters}
    for p in toy.parameters:
        values = np.array([d[p.name] for d in many])
        if p.name not in learned:          # not in the recipe: stays at its default
            assert set(values) == {p.default}
            continue
        r = learned[p.name]
        assert values.min() >= r.min and values.max() <= r.max
        if p.kind != "float":
            assert set(values) == set(range(int(r.min), int(r.max) + 1))


def test_bench_reports_speed_and_validity_of_the_seeded_shapes(toy):
    started = time.perf_counter()
    result = bench_program("toy", n=5, seed=3, stability=True)
    wall = time.perf_counter() - started
    rng = np.random.default_rng(3)
    meshes = [toy.evaluate(toy.random_values(rng)) for _ in range(5)]
    assert result["n"] == 5
    assert result["median_faces"] == statistics.median(len(m.faces) for m in meshes)
    assert result["loose_part_rate"] == sum(loose_parts(m) > 0 for m in meshes) / 5
    assert result["nonfinite_rate"] == 0.0
    assert result["stable_rate"] == sum(is_stable(m) for m in meshes) / 5
    assert 5 / result["shapes_per_s"] <= wall          # the shapes' own time, inside the call
    assert "stable_rate" not in bench_program("toy", n=2)
