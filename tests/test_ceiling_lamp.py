"""The ceiling lamp program: parameters, inferred visibility, recipe, and its structural rules
(each rule: change one parameter, check the geometric consequence)."""

import hashlib
import json

import numpy as np
import pytest

from geocode.paths import programs_dir
from geocode.recipe import Recipe
from geocode.stability import loose_parts

pytestmark = pytest.mark.blender

# the rod, hub and every arm's parts: what holds the shades up
HANGERS = ("CANOPY", "ROD", "HUB", "ARMS", "SOCKETS")


DOMAIN = "ceiling_lamp"   # the conftest's `program` and `label` fixtures build it


@pytest.fixture(scope="module")
def lamp(program):
    return program


def _digest(mesh) -> str:
    return hashlib.sha256(np.round(mesh.vertices, 6).tobytes() + mesh.faces.tobytes()).hexdigest()


def _mask(mesh, labels):
    return np.isin(mesh.metadata["part"], list(labels))


def _vertices(mesh, *labels) -> np.ndarray:
    """Vertices of the faces labelled with any of `labels`."""
    return mesh.vertices[np.unique(mesh.faces[_mask(mesh, labels)])]


def _only(mesh, *labels):
    return mesh.submesh([np.flatnonzero(_mask(mesh, labels))], append=True)


def _radii(points, axis_x) -> np.ndarray:
    """Horizontal distances of points from the vertical axis through (axis_x, 0)."""
    return np.hypot(points[:, 0] - axis_x, points[:, 1])


# -- parameters, visibility, recipe ---------------------------------------------------------------

def test_parameters_cover_the_lamp(lamp):
    kinds = [p.kind for p in lamp.parameters]
    assert len(kinds) == 24
    assert len(kinds) - kinds.count("float") == 4 and kinds.count("float") == 20
    names = {p.name for p in lamp.parameters}
    assert {"pendant", "flush", "canopy_taper", "arm_count", "arm_length", "arm_curvature",
            "hub_radius", "shade_shape", "shade_size", "bulb_size", "rod_length",
            "canopy_radius"} <= names
    for p in lamp.parameters:
        assert p.description and p.min <= p.default <= p.max, p.name


CHANDELIER_ONLY = ("arm_attach", "hub_radius", "hub_height", "arm_count", "arm_length",
                   "arm_rise", "arm_curvature", "arm_thickness")


def test_visibility_rules_are_inferred_from_the_form_and_shade_switches(lamp):
    rules = {name: None if rule is None else str(rule)
             for name, rule in lamp.visibility().items()}
    assert rules.pop("shade_top") == "shade_shape == 0 or shade_shape == 1 or shade_shape == 3"
    assert rules.pop("shade_flare") == "shade_shape == 1"
    for name in CHANDELIER_ONLY:
        assert rules.pop(name) == "not flush and not pendant", name
    # a flush mount has no rod and no bulb, and is no pendant
    for name in ("pendant", "rod_length", "rod_thickness", "bulb_size"):
        assert rules.pop(name) == "not flush", name
    assert set(rules.values()) == {None}


@pytest.mark.parametrize("hidden, change", [
    ({"shade_shape": 2}, {"shade_top": 0.8}),
    ({"shade_shape": 0}, {"shade_flare": 1.0}),
    ({"shade_shape": 3}, {"shade_flare": 0.0}),
    ({"shade_shape": 4}, {"shade_top": 0.8}),
    ({"pendant": 1}, {"arm_count": 8, "arm_length": 0.45, "hub_radius": 0.08}),
    ({"flush": 1}, {"rod_length": 0.9, "rod_thickness": 0.003, "bulb_size": 0.04,
                    "pendant": 1}),
])
def test_invisible_parameters_leave_the_mesh_unchanged(lamp, hidden, change):
    assert _digest(lamp.evaluate(hidden)) == _digest(lamp.evaluate({**hidden, **change}))


def test_every_parameter_changes_the_mesh(lamp):
    visible = {"shade_shape": 1}  # a bell uses every shade parameter
    for p in lamp.parameters:
        low = lamp.evaluate({**visible, p.name: p.min})
        high = lamp.evaluate({**visible, p.name: p.max})
        assert _digest(low) != _digest(high), p.name


def test_recipe_loads_against_the_program(lamp):
    recipe = Recipe.load(programs_dir() / "ceiling_lamp.yaml", lamp.parameters,
                         lamp.visibility())
    assert [p.name for p in recipe.parameters] == [p.name for p in lamp.parameters]
    assert all(3 <= p.samples <= 5 for p in recipe.parameters if p.kind == "float")


def test_the_program_declares_that_it_hangs(lamp, tmp_path):
    """No drop test for it: the manifest carries the program's HANGS to the evaluation."""
    from geocode.config import compose
    from geocode.steps.evaluate import hangs

    assert lamp.hangs and lamp.manifest()["hangs"] is True
    cfg = compose([f"paths.build={tmp_path}"])
    path = tmp_path / "programs" / "ceiling_lamp.manifest.json"
    path.parent.mkdir()
    path.write_text(json.dumps(lamp.manifest()))
    assert hangs(cfg, "ceiling_lamp")
    path.write_text(json.dumps({**lamp.manifest(), "hangs": False}))
    assert not hangs(cfg, "ceiling_lamp")


def test_every_part_carries_its_own_label(lamp, label):
    mesh = lamp.evaluate({})
    assert set(mesh.metadata["part"]) == {label.CANOPY, label.ROD, label.HUB, label.ARMS,
                                          label.SOCKETS, label.SHADES, label.BULBS}
    pendant = lamp.evaluate({"pendant": 1})
    assert set(pendant.metadata["part"]) == {label.CANOPY, label.ROD, label.SOCKETS,
                                             label.SHADES, label.BULBS}
    flush = lamp.evaluate({"flush": 1})
    assert set(flush.metadata["part"]) == {label.CANOPY, label.SHADES}


# -- structural rules ------------------------------------------------------------------------------

def test_the_canopy_rests_on_the_ceiling_and_the_rest_hangs_below(lamp, label):
    # the highest-reaching arm: a short rod, the hub high on it, arms rising and arched
    highest = {"canopy_height": 0.02, "rod_length": 0.25, "arm_attach": 0.5, "hub_height": 0.08,
               "arm_rise": 0.08, "arm_curvature": 1.0, "arm_length": 0.45,
               "arm_thickness": 0.012}
    rng = np.random.default_rng(5)
    for values in [{**lamp.check({}), **highest}] + [lamp.random_values(rng) for _ in range(20)]:
        mesh = lamp.evaluate(values)
        canopy = _vertices(mesh, label.CANOPY)
        assert canopy[:, 2].max() == pytest.approx(0.0, abs=1e-6), values
        assert canopy[:, 2].min() == pytest.approx(-values["canopy_height"], abs=1e-6)
        below = mesh.vertices[np.unique(mesh.faces[~_mask(mesh, [label.CANOPY])])]
        assert below[:, 2].max() < 0.0, values


def test_a_longer_rod_lowers_everything_under_the_canopy(lamp, label):
    short = lamp.evaluate({"rod_length": 0.3, "arm_attach": 1.0})
    long = lamp.evaluate({"rod_length": 0.8, "arm_attach": 1.0})
    assert np.array_equal(_vertices(short, label.CANOPY), _vertices(long, label.CANOPY))
    for part in (label.HUB, label.ARMS, label.SOCKETS, label.SHADES, label.BULBS):
        drop = _vertices(short, part)[:, 2].mean() - _vertices(long, part)[:, 2].mean()
        assert drop == pytest.approx(0.5, abs=1e-5), part


@pytest.mark.parametrize("attach", [0.5, 0.75, 1.0])
def test_the_hub_sits_where_the_rod_is_sampled(lamp, label, attach):
    values = {"arm_attach": attach, "rod_length": 0.6, "canopy_height": 0.04}
    hub = _vertices(lamp.evaluate(values), label.HUB)
    rod_top, rod_bottom = -0.02, -0.64  # from inside the canopy to its end
    expected = rod_top + attach * (rod_bottom - rod_top)
    assert (hub[:, 2].min() + hub[:, 2].max()) / 2 == pytest.approx(expected, abs=1e-5)


@pytest.mark.parametrize("count", [2, 5, 8])
def test_each_arm_holds_a_shade_and_a_bulb_up(lamp, label, count):
    mesh = lamp.evaluate({"arm_count": count, "arm_rise": 0.08, "arm_curvature": 1.0})
    assert len(_only(mesh, label.SHADES).split(only_watertight=False)) == count
    hangers = [getattr(label, name) for name in HANGERS]
    assert loose_parts(_only(mesh, *hangers, label.SHADES, label.BULBS)) == 0
    # the arms carry them: without the arms, sockets, shades and bulbs fall off
    assert loose_parts(_only(mesh, label.CANOPY, label.ROD, label.HUB, label.SOCKETS,
                             label.SHADES, label.BULBS)) == 3 * count


def test_longer_arms_carry_the_shades_outwards(lamp, label):
    near = _vertices(lamp.evaluate({"arm_length": 0.2}), label.SHADES)
    far = _vertices(lamp.evaluate({"arm_length": 0.4}), label.SHADES)
    assert np.hypot(*far[:, :2].T).max() == pytest.approx(np.hypot(*near[:, :2].T).max() + 0.2,
                                                         abs=2e-3)


@pytest.mark.parametrize("roundness", [0.0, 1.0])
def test_crowded_shades_shrink_so_that_none_touch(lamp, label, roundness):
    crowded = {"arm_count": 8, "arm_length": 0.15, "hub_radius": 0.025, "shade_size": 0.16,
               "shade_shape": 2, "shade_roundness": roundness}
    mesh = lamp.evaluate(crowded)
    shades = _vertices(mesh, label.SHADES)
    assert np.hypot(*shades[:, :2].T).max() < 0.175 + 0.16  # shrunk below the asked rim
    assert loose_parts(_only(mesh, label.SHADES)) == 8 - 1  # each one on its own
    spacious = _vertices(lamp.evaluate({**crowded, "arm_count": 2}), label.SHADES)
    assert np.hypot(*spacious[:, :2].T).max() > np.hypot(*shades[:, :2].T).max() + 0.05


@pytest.mark.parametrize("shape", [0, 1, 2, 3, 4])
def test_shade_shapes_follow_their_profiles(lamp, label, shape):
    values = {"arm_count": 2, "shade_shape": shape, "shade_size": 0.1, "shade_top": 0.4,
              "shade_flare": 1.0, "shade_height": 0.2, "hub_radius": 0.05, "arm_length": 0.35}
    shade = _vertices(lamp.evaluate(values), label.SHADES)
    shade = shade[shade[:, 0] > 0]  # the arm on +X, its shade's axis at x = 0.4
    z = (shade[:, 2] - shade[:, 2].min()) / np.ptp(shade[:, 2])
    radii = _radii(shade, 0.4)

    def width(at):
        return radii[np.abs(z - at) < 0.06].max()

    rim, middle, top = width(0.0), width(0.5), width(1.0)
    if shape == 0:    # cone: straight from the rim to 0.4 of it
        assert top == pytest.approx(0.04, abs=3e-3) and rim == pytest.approx(0.1, abs=3e-3)
        assert middle == pytest.approx(0.07, abs=5e-3)
    elif shape == 1:  # bell: falls fast above the rim, then narrows slowly
        assert rim == pytest.approx(0.1, abs=3e-3) and middle < 0.06
    elif shape == 2:  # cylinder
        assert rim == pytest.approx(0.1, abs=3e-3) and top == pytest.approx(0.1, abs=3e-3)
    elif shape == 3:  # globe: widest in the middle, open at both ends
        assert middle == pytest.approx(0.1, abs=3e-3) and rim < 0.05 and top < 0.06
    else:             # dome: a half ellipsoid from the rim up to a small flat top
        assert rim == pytest.approx(0.1, abs=3e-3) and top == pytest.approx(0.02, abs=3e-3)
        assert middle == pytest.approx(0.1 * np.sqrt(1 - 0.25 * 0.96), abs=5e-3)


def test_bulbs_hang_from_their_sockets_inside_the_shades(lamp, label):
    mesh = lamp.evaluate({"arm_count": 2, "bulb_size": 0.04, "shade_size": 0.05,
                          "shade_shape": 2})
    bulbs, sockets = _vertices(mesh, label.BULBS), _vertices(mesh, label.SOCKETS)
    assert bulbs[:, 2].max() > sockets[:, 2].min()  # the bulb's top reaches into the socket
    right = bulbs[bulbs[:, 0] > 0]
    assert _radii(right, right[:, 0].mean()).max() <= 0.6 * 0.05 + 1e-6  # fits its shade
    pair = _only(mesh, label.SOCKETS, label.BULBS)
    right = pair.submesh([np.flatnonzero(pair.triangles_center[:, 0] > 0)], append=True)
    assert len(right.split(only_watertight=False)) == 2 and loose_parts(right) == 0


def test_random_lamps_are_whole_and_finite(lamp):
    rng = np.random.default_rng(7)
    for _ in range(100):
        values = lamp.random_values(rng)
        mesh = lamp.evaluate(values)
        assert np.isfinite(mesh.vertices).all(), values
        assert loose_parts(mesh) == 0, values


# -- the other forms: a pendant, a flush mount -----------------------------------------------------

def test_a_pendant_hangs_one_shade_from_the_rods_end(lamp, label):
    values = {"pendant": 1, "rod_length": 0.3, "canopy_height": 0.04,
              "shade_size": 0.16, "shade_height": 0.2, "shade_shape": label.CYLINDER}
    mesh = lamp.evaluate(values)
    assert len(_only(mesh, label.SHADES).split(only_watertight=False)) == 1
    shade, rod = _vertices(mesh, label.SHADES), _vertices(mesh, label.ROD)
    assert rod[:, 2].min() == pytest.approx(-0.34, abs=1e-5)   # below the canopy by rod_length
    assert np.abs(shade[:, :2].mean(axis=0)).max() < 1e-6      # on the rod's axis
    assert shade[:, 2].max() == pytest.approx(-0.34 - 0.0175, abs=1e-5)  # under the socket
    assert shade[:, 2].min() == pytest.approx(-0.34 - 0.0175 - 0.2, abs=1e-5)
    assert _radii(shade, 0.0).max() == pytest.approx(0.16, abs=1e-3)  # not crowded
    assert loose_parts(mesh) == 0
    # the rod (cord) carries it: without the rod the rest falls off the canopy
    assert loose_parts(_only(mesh, label.CANOPY, label.SOCKETS, label.SHADES,
                             label.BULBS)) > 0
    longer = _vertices(lamp.evaluate({**values, "rod_length": 0.6}), label.SHADES)
    assert shade[:, 2].min() - longer[:, 2].min() == pytest.approx(0.3, abs=1e-5)


def test_a_pendant_can_hang_a_box_from_a_thin_cord(lamp, label):
    values = {"pendant": 1, "rod_thickness": 0.003, "shade_shape": label.CYLINDER,
              "shade_roundness": 0.0, "shade_size": 0.1, "shade_height": 0.2}
    mesh = lamp.evaluate(values)
    shade = _vertices(mesh, label.SHADES)
    # a box: a square cross-section, the same at the rim and at the top
    for part in (shade[shade[:, 2] < shade[:, 2].min() + 0.01],
                 shade[shade[:, 2] > shade[:, 2].max() - 0.01]):
        assert np.abs(part[:, :2]).max(axis=0) == pytest.approx([0.1, 0.1], abs=1e-4)
        assert _radii(part, 0.0).max() == pytest.approx(0.1 * np.sqrt(2), abs=1e-4)
    rod, socket = _vertices(mesh, label.ROD), _vertices(mesh, label.SOCKETS)
    assert _radii(rod, 0.0).max() == pytest.approx(0.003, abs=1e-5)
    # the cord's socket keeps a bulb holder's width
    assert _radii(socket, 0.0).max() == pytest.approx(1.8 * 0.006, abs=1e-4)
    assert loose_parts(mesh) == 0


def test_a_flush_mount_is_a_shade_upside_down_under_the_canopy(lamp, label):
    values = {"flush": 1, "shade_shape": label.DOME, "canopy_radius": 0.14,
              "canopy_height": 0.02, "canopy_taper": 0.0, "shade_size": 0.11,
              "shade_height": 0.12}
    mesh = lamp.evaluate(values)
    assert loose_parts(mesh) == 0
    dome = _vertices(mesh, label.SHADES)
    # its open rim half the canopy's height up into the canopy, its bottom half shade_height
    # below
    assert dome[:, 2].max() == pytest.approx(-0.01, abs=1e-3)
    assert dome[:, 2].min() == pytest.approx(-0.07, abs=1e-3)
    top = dome[dome[:, 2] > -0.012]
    bottom = dome[dome[:, 2] < -0.068]
    assert _radii(top, 0.0).max() == pytest.approx(0.11, abs=1e-3)      # widest at the rim
    assert _radii(bottom, 0.0).max() == pytest.approx(0.022, abs=2e-3)  # a small flat bottom
    deeper = _vertices(lamp.evaluate({**values, "shade_height": 0.2}), label.SHADES)
    assert deeper[:, 2].min() == pytest.approx(-0.11, abs=1e-3)


def test_canopy_taper_turns_a_cap_into_a_flat_plate(lamp, label):
    def widths(taper):
        canopy = _vertices(lamp.evaluate({"canopy_taper": taper, "canopy_radius": 0.1}),
                           label.CANOPY)
        top, bottom = canopy[canopy[:, 2] > -1e-6], canopy[canopy[:, 2] < canopy[:, 2].min() + 1e-6]
        return _radii(top, 0.0).max(), _radii(bottom, 0.0).max()

    assert widths(0.0) == pytest.approx((0.1, 0.1), abs=1e-3)
    assert widths(0.6) == pytest.approx((0.1, 0.04), abs=1e-3)


def test_on_a_short_rod_the_hub_stays_low_enough_for_the_arms(lamp, label):
    values = {"rod_length": 0.05, "canopy_height": 0.04, "arm_attach": 0.5, "arm_rise": 0.08,
              "arm_curvature": 1.0, "arm_length": 0.45, "arm_thickness": 0.012}
    mesh = lamp.evaluate(values)
    assert loose_parts(mesh) == 0
    below = mesh.vertices[np.unique(mesh.faces[~_mask(mesh, [label.CANOPY, label.ROD])])]
    assert below[:, 2].max() < -0.02  # under the canopy's middle
    # on a long rod the same arms sit where the rod is sampled
    hub = _vertices(lamp.evaluate({**values, "rod_length": 0.9}), label.HUB)
    assert hub[:, 2].mean() == pytest.approx(-0.02 + 0.5 * (-0.94 + 0.02), abs=1e-5)
