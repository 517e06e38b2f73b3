"""The cabinet program: parameters, inferred visibility, recipe, and its structural rules (each
rule: change one parameter, check the geometric consequence)."""

import numpy as np
import pytest
import trimesh

from geocode.paths import programs_dir
from geocode.recipe import Recipe
from geocode.stability import loose_parts

pytestmark = pytest.mark.blender

# thin fronts, no base: the body's bottom rests on z = 0 and nothing is shifted by grounding
PLAIN = {"base_style": 0, "top_board": 0, "drawer_rows": 3, "drawer_columns": 2,
         "door_rows": 1, "door_columns": 2, "handle_style": 1}


DOMAIN = "cabinet"   # the conftest's `program` and `label` fixtures build it


@pytest.fixture(scope="module")
def cabinet(program):
    return program


def _only(mesh, *labels):
    """The sub-mesh of the faces labelled with any of `labels`."""
    keep = np.flatnonzero(np.isin(mesh.metadata["part"], labels))
    return mesh.submesh([keep], append=True)


def _pieces(mesh, *labels):
    """The separate pieces (face-connected after welding) of the labelled faces."""
    part = _only(mesh, *labels)
    part.merge_vertices()
    return part.split(only_watertight=False)


def _body_half_width(mesh, label, z):
    """Half-width of the body's front outline at heights `z`, from its side's vertices."""
    body = _only(mesh, label.BODY).vertices
    front = body[body[:, 1] < body[:, 1].min() + 1e-6]
    side = front[front[:, 0] > 0]
    order = np.argsort(side[:, 2])
    return np.interp(z, side[order, 2], side[order, 0])


# -- parameters, visibility, recipe -------------------------------------------------------------

def test_parameter_space(cabinet):
    kinds = [p.kind for p in cabinet.parameters]
    assert len(cabinet.parameters) == 38
    assert kinds.count("float") == 27 and len(kinds) - kinds.count("float") == 11
    for p in cabinet.parameters:
        assert p.description and p.min <= p.default <= p.max, p.name


def test_visibility_rules_are_inferred_from_the_switches(cabinet):
    rules = {name: None if rule is None else str(rule)
             for name, rule in cabinet.visibility().items()}
    assert rules["width"] is None and rules["drawer_rows"] is None
    assert rules["handle_length"] == "handle_style == 1"
    assert rules["knob_size"] == "handle_style == 2"
    assert rules["handle_reach"] == "handle_style == 1 or handle_style == 2"
    assert rules["handle_height"] == "handle_style == 1 or handle_style == 2"
    assert rules["top_overhang"] == "top_board"
    assert rules["plinth_inset"] == "base_style == 1"
    assert rules["leg_splay"] == "base_style == 2"
    assert rules["base_height"] == "base_style == 1 or base_style == 2"
    assert rules["door_height"] == "door_rows > 0 or open_rows > 0"
    assert rules["shelf_count"] == "open_rows > 0"
    assert rules["open_depth"] == "open_rows > 0"
    assert rules["panel_border"] == "front_style > 0"
    assert rules["front_thickness"] is None and rules["front_style"] is None
    assert rules["drawer_columns"] == "drawer_rows > 0"
    assert rules["drawer_open"] == "drawer_rows > 0 and open_drawer > 0"


@pytest.mark.parametrize("hidden, change", [
    ({"handle_style": 0}, {"handle_length": 0.7, "handle_reach": 0.06, "knob_size": 0.03,
                           "handle_height": 0.75}),
    ({"handle_style": 1}, {"knob_size": 0.03}),
    ({"top_board": 0}, {"top_overhang": 0.06, "top_thickness": 0.05}),
    ({"base_style": 1}, {"leg_splay": 0.05, "leg_thickness": 0.04}),
    ({"door_rows": 0}, {"door_height": 2.5, "door_columns": 1}),
    ({"open_drawer": 0}, {"drawer_open": 0.55}),
    ({"open_rows": 0}, {"shelf_count": 3, "open_depth": 0.4}),
    ({"front_style": 0}, {"panel_border": 0.08}),
])
def test_invisible_parameters_leave_the_mesh_unchanged(cabinet, hidden, change):
    before = cabinet.evaluate(hidden)
    after = cabinet.evaluate({**hidden, **change})
    assert np.array_equal(before.vertices, after.vertices)


def test_recipe_loads_against_the_program(cabinet):
    recipe = Recipe.load(programs_dir() / "cabinet.yaml", cabinet.parameters,
                         cabinet.visibility())
    assert {p.name for p in recipe.parameters} == {p.name for p in cabinet.parameters}
    assert any("drawer_rows" in str(c) for c in recipe.constraints)


def test_every_part_carries_its_own_label(cabinet, label):
    with_legs = cabinet.evaluate({**PLAIN, "top_board": 1, "base_style": 2})
    assert set(with_legs.metadata["part"]) == {label.BODY, label.TOP, label.DRAWERS,
                                               label.DOORS, label.HANDLES, label.LEGS}
    plinth = cabinet.evaluate({"base_style": 1, "door_rows": 0, "handle_style": 2})
    assert set(plinth.metadata["part"]) == {label.BODY, label.TOP, label.DRAWERS,
                                            label.HANDLES, label.PLINTH}


# -- structural rules ---------------------------------------------------------------------------

def test_rows_and_columns_make_a_grid_of_fronts(cabinet, label):
    mesh = cabinet.evaluate({**PLAIN, "drawer_rows": 3, "drawer_columns": 3, "door_rows": 2,
                             "door_columns": 2, "handle_style": 2})
    assert len(_pieces(mesh, label.DRAWERS)) == 9
    assert len(_pieces(mesh, label.DOORS)) == 4
    assert len(_pieces(mesh, label.HANDLES)) == 13  # a knob on every front
    # the doors are below the drawers
    doors, drawers = _only(mesh, label.DOORS).vertices, _only(mesh, label.DRAWERS).vertices
    assert doors[:, 2].max() < drawers[:, 2].min()


@pytest.mark.parametrize("shape", [
    {"side_curvature": 0.08, "top_width": 0.75},
    {"side_curvature": -0.08, "top_width": 1.2},
    {"side_curvature": 0.04, "top_width": 1.0, "width": 0.45, "frame_width": 0.06},
])
def test_fronts_follow_the_body_profile_at_every_height(cabinet, label, shape):
    values = {**PLAIN, **shape, "drawer_columns": 1, "door_columns": 1, "gap": 0.01}
    mesh = cabinet.evaluate(values)
    fronts = _only(mesh, label.DRAWERS, label.DOORS).vertices
    # each front's outer edge: the body's side moved in by the frame and half the gap
    expected = (_body_half_width(mesh, label, fronts[:, 2]) - values.get("frame_width", 0.03)
                - values["gap"] / 2)
    assert np.all(np.abs(fronts[:, 0]) <= expected + 1e-5)
    outer = np.abs(np.abs(fronts[:, 0]) - expected) < 1e-5
    assert outer.sum() >= 0.4 * len(fronts)  # the side edges of every front, top to bottom
    assert np.ptp(fronts[outer, 2]) > 0.8 * values.get("height", 0.9)


def test_bowing_the_sides_bows_the_fronts_with_them(cabinet, label):
    def outer_x(curvature):
        mesh = cabinet.evaluate({**PLAIN, "side_curvature": curvature, "door_rows": 0,
                                 "drawer_rows": 4, "drawer_columns": 1})
        fronts = _only(mesh, label.DRAWERS).vertices
        middle = np.abs(fronts[:, 2] - 0.45) < 0.1
        return np.abs(fronts[middle, 0]).max(), _body_half_width(mesh, label, 0.45)

    flat, bowed = outer_x(0.0), outer_x(0.08)
    assert bowed[1] - flat[1] > 0.035  # the body bows out in the middle ...
    assert bowed[0] - flat[0] == pytest.approx(bowed[1] - flat[1], abs=0.01)  # ... and the fronts


@pytest.mark.parametrize("style", [1, 2])
def test_handles_stay_attached_when_a_drawer_is_pulled_out(cabinet, label, style):
    values = {**PLAIN, "open_drawer": 1, "handle_style": style, "drawer_columns": 1,
              "depth": 0.5}
    closed = cabinet.evaluate({**values, "drawer_open": 0.1})
    opened = cabinet.evaluate({**values, "drawer_open": 0.55})
    top = closed.vertices[:, 2].max()

    def top_row(mesh, *labels):
        vertices = _only(mesh, *labels).vertices
        return vertices[vertices[:, 2] > top - 0.2]

    for part in (label.DRAWERS, label.HANDLES):  # front and handle move out together
        moved = top_row(opened, part)[:, 1].min() - top_row(closed, part)[:, 1].min()
        assert moved == pytest.approx(-0.45 * 0.5, abs=1e-4), part
    # the other rows stay shut
    lower = _only(opened, label.DRAWERS).vertices
    assert lower[lower[:, 2] < top - 0.3][:, 1].min() > -0.25 - 0.021
    for mesh in (closed, opened):
        assert loose_parts(mesh) == 0
        # every handle holds on to a front of its own
        fronts = _pieces(mesh, label.DRAWERS, label.DOORS)
        for piece in _pieces(mesh, label.HANDLES):
            assert any(loose_parts(trimesh.util.concatenate([front, piece])) == 0
                       for front in fronts)


def test_doors_are_taller_than_drawers_by_their_height_ratio(cabinet, label):
    mesh = cabinet.evaluate({**PLAIN, "door_height": 2.5, "drawer_rows": 2, "door_rows": 1,
                             "gap": 0.002, "side_curvature": 0.0, "top_width": 1.0})
    door = np.ptp(_only(mesh, label.DOORS).vertices[:, 2])
    drawers = _pieces(mesh, label.DRAWERS)
    drawer = np.ptp(drawers[0].vertices[:, 2])
    assert (door + 0.002) / (drawer + 0.002) == pytest.approx(2.5, rel=1e-3)


@pytest.mark.parametrize("base_style", [1, 2])
def test_the_base_lifts_the_body(cabinet, label, base_style):
    low = cabinet.evaluate({"base_style": base_style, "base_height": 0.05, "leg_splay": 0.0})
    high = cabinet.evaluate({"base_style": base_style, "base_height": 0.2, "leg_splay": 0.0})
    for mesh, lift in ((low, 0.05), (high, 0.2)):
        assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6)
        base = _only(mesh, label.PLINTH if base_style == 1 else label.LEGS).vertices
        body = _only(mesh, label.BODY).vertices
        assert body[:, 2].min() == pytest.approx(base[:, 2].min() + lift, abs=2e-3)
        assert loose_parts(mesh) == 0


def test_the_top_board_overhangs_the_body(cabinet, label):
    for overhang in (0.0, 0.06):
        mesh = cabinet.evaluate({"top_board": 1, "top_overhang": overhang, "top_width": 1.0,
                                 "side_curvature": 0.0, "width": 0.8, "depth": 0.45})
        board = _only(mesh, label.TOP).vertices
        assert board[:, 0].max() == pytest.approx(0.4 + overhang, abs=1e-4)
        assert board[:, 1].min() == pytest.approx(-0.225 - overhang, abs=1e-4)
        assert board[:, 1].max() == pytest.approx(0.225, abs=1e-4)  # flush at the back
        assert board[:, 2].min() < _only(mesh, label.BODY).vertices[:, 2].max()


def test_random_cabinets_are_whole_finite_and_grounded(cabinet):
    rng = np.random.default_rng(7)
    for _ in range(100):
        values = cabinet.random_values(rng)
        mesh = cabinet.evaluate(values)
        assert len(mesh.faces) and np.isfinite(mesh.vertices).all(), values
        assert mesh.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6), values
        assert loose_parts(mesh) == 0, values


def test_random_cabinets_satisfy_the_recipe_and_have_fronts(cabinet):
    recipe, rng = cabinet.recipe(), np.random.default_rng(0)
    for _ in range(50):
        values = cabinet.random_values(rng)
        rows = values["drawer_rows"] + values["door_rows"] + values["open_rows"]
        assert recipe.satisfies(values) and rows >= 1, values
        assert all(p.min <= values[p.name] <= p.max for p in recipe.parameters), values


def test_random_values_name_a_recipe_whose_constraints_never_hold(cabinet, monkeypatch):
    from geocode.errors import UserError

    impossible = Recipe.from_dict({"parameters": {"width": {"samples": 4}}, "constraints": ["width > 100"]},
                                  cabinet.parameters, cabinet.visibility(), source="impossible.yaml")
    monkeypatch.setattr(cabinet, "_recipe_for_drawing", impossible)
    with pytest.raises(UserError, match=r"^impossible.yaml: no random shape in 1000 draws .*; relax"):
        cabinet.random_values(np.random.default_rng(0))


def test_every_parameter_changes_the_mesh_somewhere_in_its_range(cabinet):
    base = {**PLAIN, "open_drawer": 1}
    settings = {"knob_size": {"handle_style": 2}, "leg_splay": {"base_style": 2},
                "leg_taper": {"base_style": 2}, "leg_thickness": {"base_style": 2},
                "leg_roundness": {"base_style": 2}, "plinth_inset": {"base_style": 1},
                "base_height": {"base_style": 1}, "top_overhang": {"top_board": 1},
                "top_thickness": {"top_board": 1}, "top_bevel": {"top_board": 1},
                "shelf_count": {"open_rows": 1}, "open_depth": {"open_rows": 1},
                "panel_border": {"front_style": 1}}
    for p in cabinet.parameters:
        values = {**base, **settings.get(p.name, {})}
        middle = (p.min + p.max) / 2 if p.kind == "float" else float(round((p.min + p.max) / 2))
        meshes = [cabinet.evaluate({**values, p.name: value})
                  for value in (p.min, middle, p.max)]
        assert any(a.vertices.shape != b.vertices.shape or not np.allclose(a.vertices, b.vertices)
                   for a, b in zip(meshes, meshes[1:], strict=False)), p.name


# -- open rows, framed fronts, proportions ------------------------------------------------------

OPEN = {**PLAIN, "drawer_rows": 1, "door_rows": 1, "drawer_columns": 1, "door_columns": 1,
        "door_height": 2.0, "side_curvature": 0.0, "top_width": 1.0, "depth": 0.45,
        "frame_width": 0.03, "handle_style": 0}


def _first_hit_y(mesh, x, z):
    """The y of the first surface a ray along +y from the front meets at (x, z): the
    smallest y where the line meets a triangle (barycentric test in the xz-plane)."""
    a, b, c = (mesh.vertices[mesh.faces[:, i]] for i in range(3))
    ab, ac, ap = b - a, c - a, np.array([x, 0.0, z]) - a
    det = ab[:, 0] * ac[:, 2] - ab[:, 2] * ac[:, 0]
    ok = np.abs(det) > 1e-12
    det = np.where(ok, det, 1.0)
    u = (ap[:, 0] * ac[:, 2] - ap[:, 2] * ac[:, 0]) / det
    v = (ab[:, 0] * ap[:, 2] - ab[:, 2] * ap[:, 0]) / det
    inside = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
    return (a[:, 1] + u * ab[:, 1] + v * ac[:, 1])[inside].min()


def test_an_open_row_shows_the_back_wall_behind_its_shelves(cabinet, label):
    closed = cabinet.evaluate({**OPEN, "open_rows": 0})
    opened = cabinet.evaluate({**OPEN, "open_rows": 1, "shelf_count": 0})
    height = closed.vertices[:, 2].max()
    # the open row is on top, as tall as the door: the rows share the height 2 : 1 : 2
    z = height - 0.03 - (height - 0.06) * 0.2
    assert _first_hit_y(closed, 0.1, z) == pytest.approx(-0.245, abs=1e-4)  # a drawer
    assert _first_hit_y(opened, 0.1, z) == pytest.approx(0.225 - 0.03, abs=1e-4)  # the back
    assert _first_hit_y(opened, 0.1, 0.2) < -0.225  # the door below stays
    assert set(opened.metadata["part"]) == {label.BODY, label.DRAWERS, label.DOORS}
    assert loose_parts(opened) == 0


def test_shelves_are_boards_across_the_open_rows(cabinet, label):
    def boards(rows, shelves):
        mesh = cabinet.evaluate({**OPEN, "drawer_rows": 0, "door_rows": 0, "open_rows": rows,
                                 "shelf_count": shelves})
        assert loose_parts(mesh) == 0
        return len(_pieces(mesh, label.BODY))

    assert boards(1, 3) - boards(1, 0) == 3
    assert boards(2, 3) - boards(2, 0) == 6
    assert boards(2, 0) - boards(1, 0) == 1  # the board between two open rows
    # a shelf reaches from the front to the back wall, between the sides
    mesh = cabinet.evaluate({**OPEN, "drawer_rows": 0, "door_rows": 0, "open_rows": 1,
                             "shelf_count": 1, "top_board": 0})
    middle = mesh.vertices[:, 2].max() / 2
    assert _first_hit_y(mesh, 0.1, middle) == pytest.approx(-0.225, abs=1e-4)


def test_a_hutch_sets_its_open_rows_and_top_back_on_the_closed_body(cabinet, label):
    values = {**OPEN, "drawer_rows": 0, "open_rows": 1, "shelf_count": 1, "top_board": 1,
              "top_overhang": 0.0}
    full = cabinet.evaluate(values)
    hutch = cabinet.evaluate({**values, "open_depth": 0.6})
    height = hutch.vertices[:, 2].max()
    # the open row over the door, its shelf the first thing seen at the front (0.45 deep)
    shelf = next(z for z in np.linspace(0.5, 0.9, 41) * height
                 if _first_hit_y(full, 0.1, z) == pytest.approx(-0.225, abs=1e-4))
    door, setback = 0.2, 0.4 * 0.45
    assert _first_hit_y(hutch, 0.1, shelf) == pytest.approx(-0.225 + setback, abs=1e-4)
    assert _first_hit_y(hutch, 0.1, door) == pytest.approx(_first_hit_y(full, 0.1, door))
    # the sides of the open row and the top board stand back by as much
    for mesh, back in ((full, 0.0), (hutch, setback)):
        sides = _only(mesh, label.BODY).vertices
        upper = sides[sides[:, 2] > 0.5 * height + 0.02]
        assert upper[:, 1].min() == pytest.approx(-0.225 + back, abs=1e-4)
        assert _only(mesh, label.TOP).vertices[:, 1].min() == pytest.approx(-0.225 + back,
                                                                            abs=1e-4)
    assert loose_parts(hutch) == 0


@pytest.mark.parametrize("style, recess", [(1, 0.5 * 0.03), (2, 0.03 - 0.004)])
def test_framed_fronts_set_their_panel_back_and_keep_their_handles(cabinet, label, style,
                                                                   recess):
    values = {**PLAIN, "front_thickness": 0.03, "front_style": style, "panel_border": 0.05,
              "handle_style": 2, "drawer_columns": 1, "door_columns": 1}
    slab = cabinet.evaluate({**values, "front_style": 0})
    framed = cabinet.evaluate(values)
    face = -0.225 - 0.03
    for mesh, depths in ((slab, {face}), (framed, {face, face + recess})):
        fronts = _only(mesh, label.DRAWERS, label.DOORS).vertices
        seen = set(np.round(fronts[fronts[:, 1] < -0.225 - 1e-4, 1], 5))
        assert seen == {round(d, 5) for d in depths}
        assert loose_parts(mesh) == 0
    # the panel's face lies inside the frame: the border shows at the door's edge
    door = _only(framed, label.DOORS).vertices
    inner = door[np.isclose(door[:, 1], face + recess)]
    outer = door[np.isclose(door[:, 1], face)]
    assert np.abs(inner[:, 0]).max() == pytest.approx(np.abs(outer[:, 0]).max() - 0.05, abs=1e-4)


def test_wide_low_and_tall_narrow_proportions_are_reachable(cabinet):
    bare = {**PLAIN, "top_board": 0, "base_style": 0, "side_curvature": 0.0, "top_width": 1.0}
    wide = cabinet.evaluate({**bare, "width": 2.0, "height": 0.5}).extents
    tall = cabinet.evaluate({**bare, "width": 0.45, "height": 1.6}).extents
    assert wide[0] / wide[2] > 3.5 and tall[0] / tall[2] < 0.35
