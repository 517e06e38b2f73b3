"""The chair program: parameters, inferred visibility, recipe, and its structural rules (each
rule: change one parameter, check the geometric consequence)."""

import numpy as np
import pytest

from geocode.program import part_mesh
from geocode.stability import drop_test, loose_parts, winding_number

pytestmark = pytest.mark.blender

DOMAIN = "chair"  # the `program` and `label` fixtures (conftest.py) load it
# a chair with every optional part of the open backrest on
FULL = {"cushion": 1, "armrest_style": 1, "armrest_support": 1, "armrest_cushion": 1,
        "top_rail": 1, "backrest_solid": 0, "vertical_rails": 0, "monoleg": 0}


def _vertices(mesh, *labels) -> np.ndarray:
    return part_mesh(mesh, *labels).vertices


# -- parameters, visibility, recipe ---------------------------------------------------------------

def test_parameters_cover_the_chair(program):
    names = {p.name for p in program.parameters}
    kinds = [p.kind for p in program.parameters]
    assert len(names) == 79
    assert kinds.count("float") == 58 and len(kinds) - kinds.count("float") == 21
    expected = {
        "scale_x", "scale_y", "scale_z", "seat_height", "seat_roundness", "cushion",
        "cushion_fill", "cross_rail_count", "cross_rail_thickness_y", "cross_rail_thickness_z",
        "cross_rail_bottom_offset", "cross_rail_top_offset", "cross_rail_roundness",
        "vertical_rail_count", "vertical_rail_size", "vertical_rail_roundness", "top_rail",
        "top_rail_size", "top_rail_roundness", "top_rail_fill", "backrest_solid",
        "backrest_curvature", "backrest_slant", "back_frame_offset", "back_leg_offset",
        "leg_splay", "leg_taper", "leg_bevel", "monoleg", "monoleg_top_radius",
        "monoleg_bottom_radius", "tent_legs", "tent_leg_count", "tent_leg_spread",
        "armrest_style", "armrest_support", "armrest_cushion", "armrest_width",
        "armrest_back_height", "armrest_front_height", "armrest_mid", "armrest_edge",
        "rail_bevel", "sled_base", "sled_joined", "casters", "caster_size",
        "side_panels", "side_panel_drop", "stretchers", "stretcher_height",
        "side_panel_thickness", "back_post", "back_post_gap", "apron", "apron_height",
        "back_wrap", "back_wrap_depth", "back_arch", "back_arch_drop", "seat_bulge",
    }
    assert expected <= names, expected - names
    for p in program.parameters:
        assert p.description and p.min <= p.default <= p.max, p.name


def test_visibility_rules_are_inferred_from_the_switches(program):
    rules = {name: None if rule is None else str(rule)
             for name, rule in program.visibility().items()}
    assert sum(rule is not None for rule in rules.values()) >= 20
    assert rules["seat_height"] is None and rules["monoleg"] is None
    assert rules["leg_splay"] == "not monoleg"
    assert rules["tent_leg_count"] == "monoleg and tent_legs"
    assert rules["cross_rail_count"] == "not backrest_solid and not vertical_rails"
    assert rules["vertical_rail_size"] == "not backrest_solid and vertical_rails"
    assert rules["top_rail_fill"] == "not backrest_solid and top_rail"
    assert rules["armrest_mid"] == "armrest_style == 2"
    assert rules["armrest_support"] == "armrest_style == 1"
    assert rules["armrest_width"] == "armrest_style == 1 or armrest_style == 2"
    assert rules["side_panels"] is None
    assert rules["side_panel_drop"] == "side_panels"
    assert rules["side_panel_thickness"] == "side_panels"
    assert rules["back_post"] is None and rules["back_post_gap"] == "back_post"
    assert rules["sled_joined"] == "not monoleg and sled_base"
    assert rules["stretchers"] == "not monoleg"
    assert rules["stretcher_height"] == ("not monoleg and stretchers == 1 "
                                         "or not monoleg and stretchers == 2")
    assert rules["caster_size"] == "casters and monoleg and tent_legs"
    assert rules["apron"] == "not monoleg"
    assert rules["apron_height"] == "apron and not monoleg"
    assert rules["back_wrap"] is None and rules["back_arch"] is None
    assert rules["back_wrap_depth"] == "back_wrap"
    assert rules["back_arch_drop"] == "back_arch"


@pytest.mark.parametrize("hidden, change", [
    ({"armrest_style": 0}, {"armrest_width": 0.07}),
    ({"armrest_style": 1}, {"armrest_mid": 0.6}),
    ({"monoleg": 1}, {"leg_splay": 0.08}),
    ({"monoleg": 0}, {"tent_legs": 1, "monoleg_bottom_radius": 0.3}),
    ({"backrest_solid": 1}, {"cross_rail_count": 4, "top_rail_size": 0.14}),
    ({"vertical_rails": 1}, {"cross_rail_thickness_z": 0.08}),
    ({"monoleg": 1}, {"sled_base": 1, "sled_joined": 1}),
    ({"monoleg": 1, "tent_legs": 0}, {"casters": 1, "caster_size": 0.04}),
    ({"side_panels": 0}, {"side_panel_drop": 0.0, "side_panel_thickness": 0.125}),
    ({"side_panels": 1}, {"armrest_width": 0.07}),
    ({"back_post": 0}, {"back_post_gap": 0.2}),
    ({"back_wrap": 0}, {"back_wrap_depth": 0.16}),
    ({"back_arch": 0}, {"back_arch_drop": 0.4}),
    ({"monoleg": 1}, {"stretchers": 2}),
    ({"stretchers": 0}, {"stretcher_height": 0.5}),
    ({"monoleg": 1}, {"apron": 1}),
    ({"apron": 0}, {"apron_height": 0.12}),
])
def test_invisible_parameters_leave_the_mesh_unchanged(program, hidden, change):
    before = program.evaluate(hidden)
    after = program.evaluate({**hidden, **change})
    assert np.array_equal(before.vertices, after.vertices)


def test_recipe_loads_against_the_program(program):
    recipe = program.recipe()
    assert {p.name for p in recipe.parameters} == {p.name for p in program.parameters}
    for p in recipe.parameters:
        if p.kind == "float":
            assert 3 <= p.samples <= 5, p.name
    texts = [str(c) for c in recipe.constraints]
    assert any("cross_rail_top_offset" in t for t in texts)
    assert any("monoleg_bottom_radius" in t for t in texts)


def test_every_part_carries_its_own_label(program, label):
    open_back = program.evaluate(FULL)
    assert set(open_back.metadata["part"]) == {
        label.SEAT, label.CUSHION, label.LEGS, label.BACK_FRAME, label.CROSS_RAILS,
        label.TOP_RAIL, label.ARMRESTS, label.ARM_SUPPORTS, label.ARM_PADS}
    rails = program.evaluate({"vertical_rails": 1, "top_rail": 0, "monoleg": 1, "tent_legs": 1})
    assert set(rails.metadata["part"]) == {label.SEAT, label.BACK_FRAME, label.VERTICAL_RAILS,
                                           label.MONOLEG, label.TENT_LEGS}
    solid = program.evaluate({"backrest_solid": 1, "armrest_style": 2})
    assert set(solid.metadata["part"]) == {label.SEAT, label.LEGS, label.BACK_FRAME,
                                           label.BACK_PANEL, label.ARMRESTS}
    office_back = program.evaluate({"back_post": 1, "backrest_solid": 1})
    assert set(office_back.metadata["part"]) == {label.SEAT, label.LEGS, label.BACK_FRAME,
                                                 label.BACK_PANEL, label.BACK_POST}
    braced = program.evaluate({"stretchers": 1, "sled_base": 1})
    assert set(braced.metadata["part"]) == {label.SEAT, label.LEGS, label.BACK_FRAME,
                                            label.CROSS_RAILS, label.TOP_RAIL,
                                            label.STRETCHERS}
    office = program.evaluate({"backrest_solid": 1, "side_panels": 1, "monoleg": 1,
                               "tent_legs": 1, "casters": 1})
    assert set(office.metadata["part"]) == {label.SEAT, label.BACK_FRAME, label.BACK_PANEL,
                                            label.SIDE_PANELS, label.MONOLEG, label.TENT_LEGS,
                                            label.CASTERS}


# -- structural rules ------------------------------------------------------------------------------

def test_raising_the_seat_moves_legs_frame_and_rails(program, label):
    low = program.evaluate({**FULL, "seat_height": 0.35, "seat_thickness": 0.05})
    high = program.evaluate({**FULL, "seat_height": 0.6, "seat_thickness": 0.05})
    def rise(part):
        return _vertices(high, part)[:, 2].mean() - _vertices(low, part)[:, 2].mean()

    # grounding shifts both by the dip of the slanted feet's rims (a few mm)
    assert rise(label.SEAT) == pytest.approx(0.25, abs=5e-3)
    for part in (label.BACK_FRAME, label.CROSS_RAILS, label.TOP_RAIL, label.ARMRESTS):
        assert rise(part) == pytest.approx(rise(label.SEAT), abs=1e-5), part
    for mesh, top in ((low, 0.35), (high, 0.6)):
        legs = _vertices(mesh, label.LEGS)
        assert legs[:, 2].min() == pytest.approx(0.0, abs=1e-6)
        # the legs reach up into the seat slab
        assert top - 0.05 < legs[:, 2].max() < top


def test_rounder_seat_moves_legs_and_frame_inwards(program, label):
    square = program.evaluate({"seat_roundness": 0.0, "leg_splay": 0.0})
    round_ = program.evaluate({"seat_roundness": 1.0, "leg_splay": 0.0})
    for part in (label.LEGS, label.BACK_FRAME):
        s, r = _vertices(square, part), _vertices(round_, part)
        assert r[:, 0].max() < s[:, 0].max() - 0.02, part
    s, r = _vertices(square, label.LEGS), _vertices(round_, label.LEGS)
    assert r[:, 1].max() < s[:, 1].max() - 0.02
    # the leg tops stay under the round seat's outline (a disc of radius 0.25)
    tops = r[r[:, 2] > r[:, 2].max() - 1e-3]
    assert np.linalg.norm(tops[:, :2], axis=1).max() < 0.25


@pytest.mark.parametrize("curvature", [-0.5, 0.5])
@pytest.mark.parametrize("slant", [-0.05, 0.35])
def test_rails_span_the_backrest_frame_at_any_curvature_and_slant(program, label, curvature,
                                                                  slant):
    bend = {"backrest_curvature": curvature, "backrest_slant": slant, "back_frame_offset": 0.5,
            "cross_rail_count": 4, "cross_rail_bottom_offset": 0.1,
            "cross_rail_top_offset": 0.9}
    for rails, part in (({"vertical_rails": 0}, label.CROSS_RAILS),
                        ({"vertical_rails": 1, "vertical_rail_count": 5},
                         label.VERTICAL_RAILS)):
        mesh = program.evaluate({**FULL, **bend, **rails})
        frame, rail = _vertices(mesh, label.BACK_FRAME), _vertices(mesh, part)
        assert frame[:, 0].min() - 1e-6 <= rail[:, 0].min()
        assert rail[:, 0].max() <= frame[:, 0].max() + 1e-6
        assert frame[:, 2].min() - 1e-6 <= rail[:, 2].min()
        assert rail[:, 2].max() <= frame[:, 2].max() + 0.05
        assert loose_parts(part_mesh(mesh, label.SEAT, label.BACK_FRAME, part)) == 0


@pytest.mark.parametrize("back", [
    {"backrest_solid": 1, "seat_roundness": 1.0, "back_frame_offset": 0.5,
     "backrest_slant": 0.35, "backrest_curvature": 0.5, "frame_width": 0.06},
    {"backrest_solid": 0, "vertical_rails": 1, "top_rail": 0, "seat_roundness": 0.0,
     "backrest_slant": -0.05, "backrest_curvature": -0.5, "frame_width": 0.02,
     "frame_depth": 0.02, "armrest_style": 2},
    {"backrest_solid": 0, "cross_rail_count": 1, "top_rail": 0, "armrest_style": 1,
     "armrest_support": 0, "cushion": 1, "seat_thickness": 0.1, "frame_roundness": 1.0,
     "frame_width": 0.04},
])
def test_a_back_post_lifts_the_backrest_off_the_seat(program, label, back):
    values = {**back, "seat_height": 0.45}
    low = program.evaluate({**values, "back_post": 1, "back_post_gap": 0.05})
    high = program.evaluate({**values, "back_post": 1, "back_post_gap": 0.2})
    plain = program.evaluate({**values, "back_post": 0})
    frame = lambda m: _vertices(m, label.BACK_FRAME)  # noqa: E731
    # the frames start `back_post_gap` above the seat's top instead of inside the slab
    for mesh, gap in ((low, 0.05), (high, 0.2)):
        assert frame(mesh)[:, 2].min() == pytest.approx(0.45 + gap, abs=0.01)
        assert loose_parts(mesh) == 0
        # held by the post alone: the back, the post and the seat are one piece
        assert loose_parts(part_mesh(mesh, label.SEAT, label.BACK_FRAME, label.BACK_POST)) == 0
        post = _vertices(mesh, label.BACK_POST)
        assert post[:, 2].min() < 0.45
        # one post in the middle: below the yoke (two frame widths tall, centred on the
        # frames' feet), nothing of it is off the centre
        width = back["frame_width"]
        under = post[post[:, 2] < frame(mesh)[:, 2].min() - width - 1e-3]
        assert len(under) and np.abs(under[:, 0]).max() <= width + 1e-6
    assert frame(plain)[:, 2].min() < 0.45
    assert frame(high)[:, 2].max() - frame(low)[:, 2].max() == pytest.approx(0.15, abs=1e-3)


@pytest.mark.parametrize("arm", [
    {"armrest_style": 1, "armrest_support": 1, "armrest_cushion": 1},
    {"armrest_style": 1, "armrest_support": 0, "armrest_cushion": 1,
     "armrest_front_height": 1.3},
    {"armrest_style": 2, "armrest_mid": -0.6},
    {"armrest_style": 2, "armrest_mid": 0.6},
])
@pytest.mark.parametrize("shape", [
    {"seat_roundness": 1.0, "backrest_slant": 0.35, "armrest_back_height": 0.8,
     "armrest_edge": 1.0, "back_frame_offset": 0.0},
    {"seat_roundness": 0.0, "backrest_slant": -0.05, "armrest_back_height": 0.35,
     "armrest_edge": 0.6, "back_frame_offset": 0.5, "backrest_curvature": 0.5},
])
def test_armrests_stay_attached_to_the_frame_and_the_seat(program, label, arm, shape):
    mesh = program.evaluate({**FULL, **shape, **arm})
    arms = (label.ARMRESTS, label.ARM_SUPPORTS, label.ARM_PADS)
    assert len(_vertices(mesh, *arms))
    assert loose_parts(part_mesh(mesh, label.SEAT, label.BACK_FRAME, *arms)) == 0
    # without the frame, the arms of a straight style without support hang free: they
    # are held by the frame, not by chance contacts
    if arm["armrest_style"] == 1 and not arm["armrest_support"]:
        assert loose_parts(part_mesh(mesh, label.SEAT, *arms)) > 0


@pytest.mark.parametrize("count", [3, 6])
def test_monoleg_with_tent_legs_stands_on_a_wide_base(program, label, count):
    mesh = program.evaluate({"monoleg": 1, "tent_legs": 1, "tent_leg_count": count,
                           "tent_leg_spread": 0.22, "armrest_style": 1})
    assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    feet = _vertices(mesh, label.TENT_LEGS)
    feet = feet[feet[:, 2] < 0.01]
    span = feet.max(0) - feet.min(0)
    assert span[0] > 0.3 and span[1] > 0.3
    # the column ends above the floor: the legs carry the chair
    assert _vertices(mesh, label.MONOLEG)[:, 2].min() > 0.03
    assert loose_parts(mesh) == 0


def test_monoleg_foot_rests_on_the_floor(program, label):
    mesh = program.evaluate({"monoleg": 1, "tent_legs": 0, "monoleg_bottom_radius": 0.2})
    foot = _vertices(mesh, label.MONOLEG)
    foot = foot[foot[:, 2] < 1e-6]
    assert np.linalg.norm(foot[:, :2], axis=1).max() == pytest.approx(0.2, abs=1e-3)


def test_sled_runners_join_each_sides_feet_on_the_floor(program, label):
    legs = {"leg_thickness": 0.02, "leg_taper": 1.0, "leg_splay": 0.04, "back_leg_offset": 0.1}
    four = _vertices(program.evaluate({**legs, "sled_base": 0}), label.LEGS)
    mesh = program.evaluate({**legs, "sled_base": 1})
    sled = _vertices(mesh, label.LEGS)
    # on the floor, the runners reach as far as the feet's rims (a foot radius around each
    # foot; the legs end in the runners); between the feet, legs alone leave the floor empty
    low = lambda v: v[v[:, 2] < 0.02]  # noqa: E731
    between = lambda v: v[np.abs(v[:, 1]) < 0.1]  # noqa: E731
    assert len(between(low(four))) == 0 and len(between(low(sled)))
    assert np.ptp(low(sled)[:, 1]) == pytest.approx(np.ptp(low(four)[:, 1]), abs=0.005)
    # ... lying on the floor: no runner vertex there sits higher than its tube's diameter
    assert sled[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    assert between(sled)[:, 2].max() < 0.04 + 1e-3
    assert loose_parts(mesh) == 0
    # joined: a tube across the back
    joined = _vertices(program.evaluate({**legs, "sled_base": 1, "sled_joined": 1}), label.LEGS)
    centre = joined[np.abs(joined[:, 0]) < 0.05]
    assert len(centre) and centre[:, 1].min() > 0.2 and centre[:, 2].max() < 0.05


LEG_EXTREMES = [
    {"leg_splay": 0.08, "back_leg_offset": 0.1, "leg_curvature": 1.0, "leg_taper": 0.5,
     "leg_thickness": 0.015, "stretcher_height": 0.15},
    {"leg_splay": 0.08, "back_leg_offset": 0.0, "leg_curvature": 0.0, "leg_taper": 1.2,
     "leg_thickness": 0.04, "stretcher_height": 0.5, "leg_bevel": 1.0},
    {"leg_splay": 0.0, "back_leg_offset": 0.1, "leg_curvature": 0.5, "leg_taper": 0.5,
     "leg_thickness": 0.04, "stretcher_height": 0.5, "seat_roundness": 1.0},
]


@pytest.mark.parametrize("legs", LEG_EXTREMES)
def test_stretchers_end_inside_the_legs_at_any_splay_and_curvature(program, label, legs):
    for style in (1, 2):
        mesh = program.evaluate({**legs, "stretchers": style})
        bars = _vertices(mesh, label.STRETCHERS)
        assert loose_parts(part_mesh(mesh, label.LEGS, label.STRETCHERS)) == 0
        # the side bars' end sections (the vertices nearest the front and the back) lie
        # inside the legs, not merely against them
        size = legs["leg_thickness"]
        ends = bars[(bars[:, 1] < bars[:, 1].min() + size) |
                    (bars[:, 1] > bars[:, 1].max() - size)]
        if style == 1:   # the bars across share the ends' y: keep the side bars' rings
            ends = ends[np.abs(ends[:, 0]) > np.abs(bars[:, 0]).max() - size]
        assert len(ends) >= 8
        legs_mesh = part_mesh(mesh, label.LEGS)
        inside = np.abs(winding_number(ends, legs_mesh.triangles))
        assert (inside > 0.5).all(), style
    # a box joins all four legs at the front and the back; an H crosses between the sides
    box = _vertices(program.evaluate({**legs, "stretchers": 1}), label.STRETCHERS)
    h = _vertices(program.evaluate({**legs, "stretchers": 2}), label.STRETCHERS)
    centre = lambda v: v[np.abs(v[:, 0]) < 0.05]  # noqa: E731
    assert np.ptp(centre(box)[:, 1]) > 0.3
    assert np.ptp(centre(h)[:, 1]) < 0.05


def test_stretcher_height_moves_the_bars_up_the_legs(program, label):
    low = _vertices(program.evaluate({"stretchers": 2, "stretcher_height": 0.15}),
                    label.STRETCHERS)
    high = _vertices(program.evaluate({"stretchers": 2, "stretcher_height": 0.5}),
                     label.STRETCHERS)
    # the default legs (0.43 long, nearly vertical): 0.35 x 0.43 higher
    assert high[:, 2].mean() - low[:, 2].mean() == pytest.approx(0.35 * 0.43, abs=0.01)
    assert low[:, 2].min() > 0.03


def test_an_apron_joins_the_legs_under_the_seat_as_deep_as_asked(program, label):
    seat = {"seat_height": 0.45, "seat_thickness": 0.05}
    for depth in (0.03, 0.12):
        mesh = program.evaluate({**seat, "apron": 1, "apron_height": depth})
        rails = _vertices(mesh, label.APRON)
        # grounding lifts the chair by the slanted feet's rim dip (a few mm)
        lift = _vertices(mesh, label.SEAT)[:, 2].max() - 0.45
        assert rails[:, 2].min() - lift == pytest.approx(0.45 - 0.05 - depth, abs=1e-3)
        assert rails[:, 2].max() - lift < 0.45
        # rails on all four sides: one ring of the legs' tops, a single piece with them
        assert np.ptp(rails[:, 0]) > 0.3 and np.ptp(rails[:, 1]) > 0.3
        assert loose_parts(part_mesh(mesh, label.LEGS, label.APRON)) == 0
    assert label.APRON not in program.evaluate({"apron": 0}).metadata["part"]


@pytest.mark.parametrize("back", [{"backrest_solid": 1}, {"backrest_solid": 0, "top_rail": 1},
                                  {"backrest_solid": 0, "vertical_rails": 1, "back_post": 1}])
def test_a_wrapped_back_curves_in_plan_its_sides_forward_its_middle_back(program, label, back):
    filling = (label.BACK_PANEL, label.CROSS_RAILS, label.VERTICAL_RAILS, label.TOP_RAIL)
    flat, wrapped = (program.evaluate({**back, "back_wrap": w, "back_wrap_depth": 0.12})
                     for w in (0, 1))
    # the frames (and all that hangs on them) half the depth forward
    moved = _vertices(wrapped, label.BACK_FRAME) - _vertices(flat, label.BACK_FRAME)
    assert moved[:, 1] == pytest.approx(-0.06, abs=1e-5)
    assert np.abs(moved[:, [0, 2]]).max() < 1e-5
    # the filling's middle half the depth back, above the lowest quarter of the back's rise
    before, after = _vertices(flat, *filling), _vertices(wrapped, *filling)
    middle = (np.abs(before[:, 0]) < 0.02) & (before[:, 2] > before[:, 2].min() + 0.15)
    assert (after - before)[middle, 1] == pytest.approx(0.06, abs=0.01)
    still = (label.SEAT, label.LEGS)
    assert np.array_equal(_vertices(flat, *still), _vertices(wrapped, *still))
    assert loose_parts(wrapped) == 0


@pytest.mark.parametrize("shape", [{}, {"cushion": 1, "seat_roundness": 1.0},
                                   {"monoleg": 1, "back_post": 1, "apron": 1}])
def test_a_bulging_seat_grows_out_behind_its_middle_and_moves_nothing_else(program, label, shape):
    straight, bulged = (program.evaluate({**shape, "seat_bulge": b}) for b in (0.0, 0.15))
    seat = (label.SEAT, label.CUSHION)
    before, after = _vertices(straight, *seat), _vertices(bulged, *seat)
    # the back edge's middle 0.15 further back; the front half and the sides where they were
    assert after[:, 1].max() - before[:, 1].max() == pytest.approx(0.15, abs=0.01)
    moved = np.abs(after - before).max(axis=1) > 1e-6
    assert not moved[before[:, 1] <= 0].any()
    assert not moved[np.abs(before[:, 0]) >= 0.25 - 1e-6].any()
    rest = [part for part in np.unique(straight.metadata["part"]) if part not in seat]
    assert np.array_equal(_vertices(straight, *rest), _vertices(bulged, *rest))
    assert loose_parts(bulged) == 0


@pytest.mark.parametrize("back", [{"backrest_solid": 1}, {"backrest_solid": 0, "top_rail": 1},
                                  {"backrest_solid": 0, "vertical_rails": 1, "armrest_style": 1}])
def test_an_arched_back_brings_its_top_corners_down_and_keeps_its_middle(program, label, back):
    base = {**back, "backrest_height": 0.45, "seat_thickness": 0.05, "back_arch_drop": 0.4}
    flat, arched = (program.evaluate({**base, "back_arch": a}) for a in (0, 1))
    outer = [f[f[:, 0] > f[:, 0].max() - 1e-4] for f in (_vertices(m, label.BACK_FRAME)
                                                        for m in (flat, arched))]
    # the frames' outer top corners come down by the drop x the rise (0.45 + 0.05 / 2)
    assert outer[0][:, 2].max() - outer[1][:, 2].max() == pytest.approx(0.4 * 0.475, abs=1e-3)
    flat_top, arched_top = (m.vertices[np.abs(m.vertices[:, 0]) < 0.02, 2].max()
                            for m in (flat, arched))
    assert arched_top == pytest.approx(flat_top, abs=2e-3)
    # nothing under the top half of the back moves: the seat and the legs are as they were
    still = (label.SEAT, label.LEGS)
    assert np.array_equal(_vertices(flat, *still), _vertices(arched, *still))
    assert loose_parts(arched) == 0


def test_casters_lift_the_tent_legs_off_the_floor(program, label):
    base = {"monoleg": 1, "tent_legs": 1, "tent_leg_count": 5, "caster_size": 0.03}
    mesh = program.evaluate({**base, "casters": 1})
    wheels = _vertices(mesh, label.CASTERS)
    assert wheels[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    assert wheels[:, 2].max() == pytest.approx(0.06, abs=2e-3)
    # the legs rest on the wheels, above the floor; one wheel per leg, at the legs' ends
    assert _vertices(mesh, label.TENT_LEGS)[:, 2].min() > 0.03
    radius = np.linalg.norm(wheels[:, :2], axis=1)
    assert radius.min() > 0.3 - 0.04 and radius.max() < 0.3 + 0.04
    assert loose_parts(mesh) == 0
    assert len(part_mesh(mesh, label.CASTERS).split(only_watertight=False)) == 5
    bare = program.evaluate({**base, "casters": 0})
    assert _vertices(bare, label.TENT_LEGS)[:, 2].min() == pytest.approx(0.0, abs=1e-6)


def test_a_column_on_tent_legs_is_a_slim_copy_of_the_pedestal(program, label):
    straight = {"monoleg": 1, "monoleg_top_radius": 0.12, "monoleg_top_handle": 0.12,
                "monoleg_bottom_handle": 0.12, "monoleg_bottom_radius": 0.12}
    column = _vertices(program.evaluate({**straight, "tent_legs": 1}), label.MONOLEG)
    radius = np.linalg.norm(column[:, :2], axis=1)
    side = radius[radius > 1e-6]   # the caps' centres aside
    # a straight column of 0.35 x 0.12 (a gas lift)
    assert side.max() == pytest.approx(0.042, abs=1e-3)
    assert side.min() > 0.042 * 0.9
    pedestal = _vertices(program.evaluate({**straight, "tent_legs": 0}), label.MONOLEG)
    foot = pedestal[pedestal[:, 2] < 1e-6]
    assert np.linalg.norm(foot[:, :2], axis=1).max() == pytest.approx(0.12, abs=2e-3)


@pytest.mark.parametrize("roundness", [0.0, 1.0])
def test_side_panels_reach_from_the_seat_down_to_the_floor(program, label, roundness):
    arms = {"side_panels": 1, "seat_roundness": roundness, "armrest_edge": 1.0,
            "seat_height": 0.45, "seat_thickness": 0.06}
    floor = program.evaluate({**arms, "side_panel_drop": 1.0})
    panels = _vertices(floor, label.SIDE_PANELS)
    # on the floor (the slanted feet's rims dip a few mm lower)
    assert panels[:, 2].min() == pytest.approx(0.0, abs=0.01)
    assert panels[:, 2].max() > 0.45 + 0.1
    # one slab per side, along the seat's sides
    assert panels[:, 0].min() < -0.15 and panels[:, 0].max() > 0.15
    assert np.ptp(panels[:, 1]) > 0.25
    seated = _vertices(program.evaluate({**arms, "side_panel_drop": 0.0}), label.SIDE_PANELS)
    assert 0.45 - 0.06 < seated[:, 2].min() < 0.45
    for mesh in (floor, program.evaluate({**arms, "side_panel_drop": 0.0})):
        assert loose_parts(part_mesh(mesh, label.SEAT, label.SIDE_PANELS)) == 0


@pytest.mark.parametrize("arms", [
    {"armrest_style": 0},
    {"armrest_style": 1, "armrest_support": 0, "armrest_width": 0.07},
    {"armrest_style": 2, "armrest_mid": 0.6},
])
@pytest.mark.parametrize("shape", [
    {"seat_roundness": 1.0, "back_frame_offset": 0.0, "backrest_solid": 1,
     "side_panel_drop": 0.0, "armrest_back_height": 0.35},
    {"seat_roundness": 0.0, "back_frame_offset": 0.5, "backrest_slant": 0.35,
     "side_panel_drop": 1.0, "armrest_back_height": 0.8, "armrest_edge": 0.6},
])
def test_thick_side_panels_are_blocky_armchair_sides(program, label, arms, shape):
    values = {**shape, **arms, "side_panels": 1, "seat_height": 0.45}
    thin = program.evaluate({**values, "side_panel_thickness": 0.02})
    thick = program.evaluate({**values, "side_panel_thickness": 0.125})
    for mesh, thickness in ((thin, 0.02), (thick, 0.125)):
        panels = _vertices(mesh, label.SIDE_PANELS)
        right = panels[panels[:, 0] > 0]
        # a slab that thick, centred on the seat's corner (inside the seat's half-width)
        assert np.ptp(right[:, 0]) == pytest.approx(thickness, abs=1e-3)
        assert right[:, 0].min() < 0.25 - thickness * 0.5 + 1e-3
        assert loose_parts(mesh) == 0
        assert loose_parts(part_mesh(mesh, label.SEAT, label.SIDE_PANELS)) == 0
    # the sides reach further out and further in, leaving less of the seat between them
    outer = lambda m: np.ptp(_vertices(m, label.SIDE_PANELS)[:, 0])  # noqa: E731
    assert outer(thick) == pytest.approx(outer(thin) + 0.105, abs=1e-3)


def test_overall_scale_scales_each_axis(program):
    base = program.evaluate({})
    scaled = program.evaluate({"scale_x": 1.25, "scale_y": 0.8, "scale_z": 1.2})
    extent = lambda m: m.bounds[1] - m.bounds[0]  # noqa: E731
    assert extent(scaled) / extent(base) == pytest.approx([1.25, 0.8, 1.2], rel=1e-4)
    assert scaled.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6)


def test_random_chairs_are_whole_finite_and_grounded(program):
    rng = np.random.default_rng(7)
    for _ in range(100):
        values = program.random_values(rng)
        mesh = program.evaluate(values)
        assert np.isfinite(mesh.vertices).all(), values
        assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6), values
        assert loose_parts(mesh) == 0, values


def test_random_chairs_mostly_survive_the_drop_test(program):
    rng = np.random.default_rng(11)
    stable = [drop_test(program.evaluate(program.random_values(rng)))["stable"] for _ in range(12)]
    assert sum(stable) >= 10
