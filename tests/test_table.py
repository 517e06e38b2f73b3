"""The table program: parameters, inferred visibility, and its structural rules (each
rule: change one parameter, check the geometric consequence). Its recipe: test_program_recipes."""

import numpy as np
import pytest

from geocode.program import part_mesh
from geocode.stability import drop_test, loose_parts

pytestmark = pytest.mark.blender

DOMAIN = "table"  # the `program` and `label` fixtures (conftest.py) load it
# four legs with every part between them
FULL = {"pedestal": 0, "aprons": 1, "stretchers": 1, "shelf": 1, "stretcher_height": 0.4,
        "shelf_height": 0.15}
FEET = {"pedestal": 1, "base_plate": 0}
X_FRAMES = {"pedestal": 0, "leg_style": 1}
TRESTLES = {"pedestal": 0, "leg_style": 2}
PLATE = {"pedestal": 1, "base_plate": 1}


def _vertices(mesh, *labels) -> np.ndarray:
    return part_mesh(mesh, *labels).vertices


# -- parameters, visibility, recipe ---------------------------------------------------------------

def test_parameters_match_the_paper_counts(program):
    kinds = [p.kind for p in program.parameters]
    assert len(kinds) == 38
    assert kinds.count("float") == 31 and len(kinds) - kinds.count("float") == 7
    for p in program.parameters:
        assert p.description and p.min <= p.default <= p.max, p.name


def test_visibility_rules_are_inferred_from_the_switches(program):
    rules = {name: None if rule is None else str(rule)
             for name, rule in program.visibility().items()}
    assert rules["top_height"] is None and rules["pedestal"] is None
    # in every leg style (the rule lists them), only in the four legs
    assert rules["leg_splay"] == " or ".join(f"leg_style == {k} and not pedestal"
                                             for k in range(3))
    assert rules["leg_curvature"] == "leg_style == 0 and not pedestal"
    assert rules["apron_inset"] == "aprons and not pedestal"
    assert rules["stretcher_height"] == ("leg_style == 0 and not pedestal and stretchers == 1 or "
                                         "leg_style == 0 and not pedestal and stretchers == 2")
    assert rules["shelf_thickness"] == "leg_style == 0 and not pedestal and shelf"
    assert rules["column_roundness"] == "pedestal"
    # through the feet (not base_plate) and through the plate (base_plate)
    assert rules["foot_spread"] == "pedestal"
    assert rules["foot_count"] == "not base_plate and pedestal"
    assert rules["base_thickness"] == "base_plate and pedestal"


@pytest.mark.parametrize("hidden, change", [
    ({"pedestal": 1}, {"leg_splay": 0.1, "aprons": 0, "stretchers": 2, "shelf": 1}),
    ({"pedestal": 0}, {"base_plate": 1, "column_top_radius": 0.1, "foot_count": 6}),
    ({"pedestal": 1}, {"leg_style": 2}),
    (X_FRAMES, {"leg_curvature": 1.0, "stretchers": 2, "shelf": 1, "shelf_height": 0.3}),
    (TRESTLES, {"leg_curvature": 1.0, "stretchers": 1, "stretcher_thickness": 0.02}),
    ({"aprons": 0}, {"apron_height": 0.15}),
    ({"stretchers": 0}, {"stretcher_height": 0.45, "stretcher_thickness": 0.02}),
    ({"shelf": 0}, {"shelf_height": 0.35}),
    (PLATE, {"foot_count": 3, "foot_rise": 0.2}),
    (FEET, {"base_thickness": 0.06}),
])
def test_invisible_parameters_leave_the_mesh_unchanged(program, hidden, change):
    before = program.evaluate(hidden)
    after = program.evaluate({**hidden, **change})
    assert np.array_equal(before.vertices, after.vertices)


def test_every_part_carries_its_own_label(program, label):
    assert set(program.evaluate(FULL).metadata["part"]) == {
        label.TOP, label.LEGS, label.APRONS, label.STRETCHERS, label.SHELF}
    assert set(program.evaluate(FEET).metadata["part"]) == {label.TOP, label.COLUMN, label.FEET}
    assert set(program.evaluate(PLATE).metadata["part"]) == {label.TOP, label.COLUMN,
                                                           label.BASE_PLATE}
    assert set(program.evaluate(X_FRAMES).metadata["part"]) == {
        label.TOP, label.LEGS, label.APRONS, label.STRETCHERS}
    assert set(program.evaluate({**TRESTLES, "aprons": 0}).metadata["part"]) == {
        label.TOP, label.LEGS, label.FEET, label.STRETCHERS}


def _moves(program, layout, parameter) -> bool:
    """Whether some vertex moves when `parameter` goes from its min to its max."""
    low = program.evaluate({**layout, parameter.name: parameter.min})
    high = program.evaluate({**layout, parameter.name: parameter.max})
    return (low.vertices.shape != high.vertices.shape
            or not np.allclose(low.vertices, high.vertices, atol=1e-6))


def test_every_parameter_changes_the_mesh_somewhere(program):
    """Each parameter, from its min to its max, moves some vertex in one of the layouts
    (four legs with every part, with X stretchers, a pedestal on feet, on a plate)."""
    layouts = [FULL, {**FULL, "stretchers": 2}, FEET, PLATE]
    for p in program.parameters:
        assert any(_moves(program, layout, p) for layout in layouts), p.name


# -- structural rules ------------------------------------------------------------------------------

def test_raising_the_top_moves_legs_aprons_stretchers_and_shelf(program, label):
    # straight, upright legs: their top faces stay level
    low = program.evaluate({**FULL, "leg_splay": 0.0, "top_height": 0.6})
    high = program.evaluate({**FULL, "leg_splay": 0.0, "top_height": 0.85})

    def top_of(mesh, part):
        return _vertices(mesh, part)[:, 2].max()

    rise = top_of(high, label.TOP) - top_of(low, label.TOP)
    assert rise == pytest.approx(0.25, abs=1e-5)
    for part in (label.LEGS, label.APRONS):
        assert top_of(high, part) - top_of(low, part) == pytest.approx(rise, abs=1e-5), part
    # stretchers and shelf sit at a share of the legs' length: they rise by that share
    for part, share in ((label.STRETCHERS, 0.4), (label.SHELF, 0.15)):
        assert top_of(high, part) - top_of(low, part) == pytest.approx(rise * share,
                                                                        abs=5e-3), part
    for mesh in (low, high):
        assert _vertices(mesh, label.LEGS)[:, 2].min() == pytest.approx(0.0, abs=1e-6)
        assert loose_parts(mesh) == 0


def test_rounder_top_pulls_the_legs_inwards_under_it(program, label):
    values = {"top_width": 1.0, "top_depth": 1.0, "leg_splay": 0.0, "leg_inset": 0.0}
    square = program.evaluate({**values, "top_roundness": 0.0})
    round_ = program.evaluate({**values, "top_roundness": 1.0})
    s, r = _vertices(square, label.LEGS), _vertices(round_, label.LEGS)
    assert r[:, 0].max() < s[:, 0].max() - 0.05
    assert r[:, 1].max() < s[:, 1].max() - 0.05
    # the leg tops stay under the round top's outline (a disc of radius 0.5)
    tops = r[r[:, 2] > r[:, 2].max() - 1e-3]
    assert np.linalg.norm(tops[:, :2], axis=1).max() < 0.5
    assert loose_parts(round_) == 0


@pytest.mark.parametrize("inset, face", [(0.0, "outer"), (1.0, "inner")])
def test_apron_inset_moves_the_aprons_from_the_outer_to_the_inner_faces(program, label, inset,
                                                                       face):
    mesh = program.evaluate({"apron_inset": inset, "leg_splay": 0.0, "leg_taper": 1.0})
    legs, aprons = _vertices(mesh, label.LEGS), _vertices(mesh, label.APRONS)
    right_leg = legs[legs[:, 0] > 0]
    right_apron = aprons[(aprons[:, 0] > 0) & (np.abs(aprons[:, 1]) < 0.2)]
    if face == "outer":
        assert right_apron[:, 0].max() == pytest.approx(right_leg[:, 0].max(), abs=1e-5)
    else:
        assert right_apron[:, 0].min() == pytest.approx(right_leg[:, 0].min(), abs=1e-5)


@pytest.mark.parametrize("legs", [
    {"leg_curvature": 0.0, "leg_splay": 0.1},
    {"leg_curvature": 1.0, "leg_splay": 0.1, "leg_taper": 0.5},
    {"leg_curvature": 0.5, "leg_splay": 0.0, "top_roundness": 1.0, "leg_inset": 0.3},
])
@pytest.mark.parametrize("stretchers", [1, 2])
def test_stretchers_and_shelf_hold_on_to_the_legs(program, label, legs, stretchers):
    mesh = program.evaluate({**FULL, **legs, "stretchers": stretchers, "stretcher_height": 0.1,
                           "shelf_height": 0.35})
    for part in (label.STRETCHERS, label.SHELF):
        assert loose_parts(part_mesh(mesh, label.LEGS, part)) == 0, part
    # without the legs the four shelf corners and stretcher ends hang free
    assert loose_parts(part_mesh(mesh, label.TOP, label.STRETCHERS)) > 0
    stretchers_z = _vertices(mesh, label.STRETCHERS)[:, 2]
    legs_z = _vertices(mesh, label.LEGS)[:, 2]
    assert stretchers_z.mean() < legs_z.min() + 0.2 * (legs_z.max() - legs_z.min())


def test_x_stretchers_run_along_the_diagonals_and_h_stretchers_along_sides_and_middle(
        program, label):
    values = {**FULL, "stretcher_thickness": 0.01, "leg_splay": 0.0, "leg_curvature": 0.0}
    x = _vertices(program.evaluate({**values, "stretchers": 2}), label.STRETCHERS)
    h = _vertices(program.evaluate({**values, "stretchers": 1}), label.STRETCHERS)
    px, py = np.abs(x[:, :2]).max(0)
    # X: every vertex within a stretcher's half-diagonal of one of the lines y = +-py/px x
    off_diagonal = np.abs(np.abs(x[:, 1]) * px - np.abs(x[:, 0]) * py) / np.hypot(px, py)
    assert off_diagonal.max() < 0.015
    # H: every vertex on a side bar (|x| near the legs) or on the middle bar (y near 0)
    on_side = np.abs(h[:, 0]) > np.abs(h[:, 0]).max() - 0.021
    assert (on_side | (np.abs(h[:, 1]) < 0.011)).all()
    assert on_side.any() and (~on_side).any()


@pytest.mark.parametrize("count, spread, width, depth", [(3, 0.9, 1.0, 1.0),
                                                       (6, 0.5, 0.8, 0.6)])
def test_pedestal_feet_carry_the_column_above_the_floor(program, label, count, spread, width,
                                                        depth):
    mesh = program.evaluate({**FEET, "foot_count": count, "foot_spread": spread,
                           "foot_rise": 0.2, "top_width": width, "top_depth": depth,
                           "column_bottom_radius": 0.12, "column_bottom_handle": 0.12})
    feet = _vertices(mesh, label.FEET)
    toes = feet[feet[:, 2] < 0.01]
    reach = np.linalg.norm(toes[:, :2], axis=1).max()
    assert reach == pytest.approx(min(width, depth) / 2 * spread, abs=0.04)
    column = _vertices(mesh, label.COLUMN)
    assert column[:, 2].min() > 0.15
    # the toes reach out beyond the widest column's foot
    assert reach > np.linalg.norm(column[:, :2], axis=1).max()
    assert loose_parts(mesh) == 0


def test_base_plate_is_a_disc_on_the_floor(program, label):
    mesh = program.evaluate({**PLATE, "foot_spread": 0.5, "top_width": 1.6, "top_depth": 1.2,
                           "base_thickness": 0.05})
    plate = _vertices(mesh, label.BASE_PLATE)
    assert plate[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    assert plate[:, 2].max() == pytest.approx(0.05, abs=1e-6)
    assert np.linalg.norm(plate[:, :2], axis=1).max() == pytest.approx(0.3, abs=1e-3)
    assert loose_parts(mesh) == 0


def test_random_tables_are_finite_grounded_whole_and_stand(program):
    """Unlike chairs, every table stands: four symmetric legs or a centred pedestal."""
    rng = np.random.default_rng(7)
    for _ in range(24):
        values = program.random_values(rng)
        mesh = program.evaluate(values)
        assert np.isfinite(mesh.vertices).all(), values
        assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6), values
        result = drop_test(mesh)
        assert result["loose_parts"] == 0 and result["stable"], values


# -- top, proportions, end frames ------------------------------------------------------------------

@pytest.mark.parametrize("roundness", [0.0, 1.0])
def test_the_top_is_a_flat_slab_whose_edges_round_within_its_thickness(program, label,
                                                                        roundness):
    """Even on a wide, thick top at full bevel, the upper face is flat and reaches to
    within half the thickness of the outline; bevel 0 leaves square edges."""
    values = {"top_width": 2.0, "top_depth": 1.2, "top_thickness": 0.1,
              "top_roundness": roundness}
    for bevel, reach in ((1.0, 0.05), (0.0, 0.0)):
        top = _vertices(program.evaluate({**values, "top_bevel": bevel}), label.TOP)
        upper = top[top[:, 2] > top[:, 2].max() - 1e-4]
        assert upper[:, 0].max() == pytest.approx(1.0 - reach, abs=1e-3), bevel
        # nothing of the top rises above that flat face
        assert top[:, 2].max() - upper[:, 2].min() < 1e-4


def test_bevel_rounds_more_on_a_thicker_top(program, label):
    def upper_reach(thickness):
        top = _vertices(program.evaluate({"top_thickness": thickness, "top_bevel": 1.0}),
                        label.TOP)
        return top[top[:, 2] > top[:, 2].max() - 1e-4][:, 0].max()

    assert upper_reach(0.02) - upper_reach(0.1) == pytest.approx(0.04, abs=1e-3)


@pytest.mark.parametrize("values", [
    # a long low coffee table on splayed legs, a tall narrow side table, a long dining table
    {"top_height": 0.4, "top_width": 1.25, "top_depth": 0.5, "top_roundness": 1.0,
     "leg_splay": 0.06, "leg_thickness": 0.012, "aprons": 0},
    {"top_height": 0.9, "top_width": 0.4, "top_depth": 0.4, "leg_thickness": 0.05,
     "leg_inset": 0.3, "top_roundness": 1.0, "shelf": 1},
    {"top_height": 0.75, "top_width": 2.0, "top_depth": 0.9, "stretchers": 1},
])
def test_real_proportions_stand_whole(program, label, values):
    mesh = program.evaluate(values)
    size = mesh.vertices.max(0) - mesh.vertices.min(0)
    top = _vertices(mesh, label.TOP)
    assert size[2] == pytest.approx(values["top_height"], abs=0.01)
    assert np.ptp(top[:, 0]) == pytest.approx(values["top_width"], abs=1e-3)
    result = drop_test(mesh)
    assert result["loose_parts"] == 0 and result["stable"]
    # the legs stay apart and under the top
    legs = _vertices(mesh, label.LEGS)
    assert np.abs(legs[:, 0]).min() > 0.0 and np.abs(legs[:, 1]).min() > 0.0


@pytest.mark.parametrize("splay", [0.0, 0.1])
def test_x_frames_cross_under_each_end_and_a_tie_joins_them(program, label, splay):
    mesh = program.evaluate({**X_FRAMES, "aprons": 0, "leg_splay": splay, "leg_inset": 0.0,
                             "leg_thickness": 0.03, "top_width": 1.6, "top_depth": 0.8})
    legs, tie = _vertices(mesh, label.LEGS), _vertices(mesh, label.STRETCHERS)
    # the bars lie in the two end planes x = +-(0.8 - 1.2 * 0.03), a leg's width thick
    ends = 0.8 - 1.2 * 0.03
    assert np.abs(np.abs(legs[:, 0]) - ends).max() < 0.031
    # the feet stand on the floor at the corners, splayed outwards
    feet = legs[legs[:, 2] < 1e-3]
    assert feet[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    assert np.abs(feet[:, 1]).max() == pytest.approx(0.4 - 0.036 + splay, abs=0.03)
    # every end is an X: at mid-height its bars pass the middle, at the top and floor the
    # sides
    middle = legs[np.abs(legs[:, 2] - np.median(legs[:, 2])) < 0.05]
    assert np.abs(middle[:, 1]).min() < 0.05
    # the tie runs along x through both crossings, well off the floor
    assert np.ptp(tie[:, 0]) == pytest.approx(2 * ends, abs=0.03)
    assert np.abs(tie[:, 1]).max() < 0.03 and tie[:, 2].min() > 0.2
    # no bar corner pokes through the top's upper face
    assert legs[:, 2].max() < mesh.vertices[:, 2].max() - 1e-4
    assert loose_parts(mesh) == 0
    # without the tie, the two ends hang from the top only
    assert loose_parts(part_mesh(mesh, label.LEGS, label.STRETCHERS)) == 0
    assert loose_parts(part_mesh(mesh, label.LEGS)) > 0


def test_trestles_stand_posts_on_foot_bars(program, label):
    mesh = program.evaluate({**TRESTLES, "aprons": 0, "leg_splay": 0.1, "leg_inset": 0.0,
                             "leg_thickness": 0.04, "top_width": 1.6, "top_depth": 0.8})
    legs, feet = _vertices(mesh, label.LEGS), _vertices(mesh, label.FEET)
    # posts upright on the middle plane y = 0
    assert np.abs(legs[:, 1]).max() <= 0.04 + 1e-6
    # foot bars on the floor along y, wider than the top's leg positions by the splay
    assert feet[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    assert feet[:, 2].max() == pytest.approx(0.08, abs=1e-6)
    assert np.abs(feet[:, 1]).max() == pytest.approx(0.4 - 0.048 + 0.1, abs=1e-3)
    assert loose_parts(mesh) == 0
    assert drop_test(mesh)["stable"]


def test_top_cut_halves_a_round_top_into_a_demilune_with_its_legs_under_it(program, label):
    values = {"top_width": 1.0, "top_depth": 0.5, "top_roundness": 1.0, "leg_splay": 0.0,
              "leg_thickness": 0.02, "aprons": 0}
    whole = _vertices(program.evaluate(values), label.TOP)
    mesh = program.evaluate({**values, "top_cut": 1.0})
    top, legs = _vertices(mesh, label.TOP), _vertices(mesh, label.LEGS)
    # the same extent, centred
    for v in (whole, top):
        assert v[:, 1].min() == pytest.approx(-0.25, abs=1e-3)
        assert v[:, 1].max() == pytest.approx(0.25, abs=1e-3)
        assert np.ptp(v[:, 0]) == pytest.approx(1.0, abs=1e-3)
    # a straight back as wide as the top, a front that narrows as a half-ellipse would
    back = top[top[:, 1] < -0.25 + 1e-4]
    assert np.ptp(back[:, 0]) == pytest.approx(1.0, abs=1e-3)
    front = top[top[:, 1] > 0.2]
    assert np.abs(front[:, 0]).max() < 0.3
    assert np.abs(whole[whole[:, 1] > 0.2][:, 0]).max() > 0.35
    # the legs' tops lie under the half-ellipse x^2 / 0.5^2 + (y + 0.25)^2 / 0.5^2 < 1
    tops = legs[legs[:, 2] > legs[:, 2].max() - 1e-3]
    assert (np.hypot(tops[:, 0] / 0.5, (tops[:, 1] + 0.25) / 0.5) < 1.0).all()
    assert (tops[:, 1] > -0.25).all()
    result = drop_test(mesh)
    assert result["loose_parts"] == 0 and result["stable"]
