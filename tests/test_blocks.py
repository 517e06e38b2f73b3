"""Every building block evaluated in Blender, its geometry checked."""

import math

import numpy as np
import pytest

from geocode import nodes
from geocode.nodes import Evaluator, Graph
from geocode.nodes.visibility import infer_visibility

pytestmark = pytest.mark.blender


def _evaluate(build, values=None):
    """Evaluate a probe graph: `build(g)` returns the geometry to output."""
    g = Graph.new("probe")
    g.output("Geometry", "geometry", build(g))
    return Evaluator(g.tree).mesh(values)


def _curve_points(build, values=None) -> np.ndarray:
    """The points of the curve `build(g)` returns, in curve order."""
    return _evaluate(lambda g: g.node("GeometryNodeCurveToMesh", {"Curve": build(g)}).out,
                     values).vertices


def _vertical_line(g, top=2.0, points=9):
    line = g.node("GeometryNodeCurvePrimitiveLine", {"Start": (0, 0, 0), "End": (0, 0, top)})
    return g.node("GeometryNodeResampleCurve", {"Curve": line, "Mode": "Count",
                                                "Count": points}).out


def _cube(g, size=0.2, at=(0, 0, 0)):
    cube = g.node("GeometryNodeMeshCube", {"Size": (size, size, size)})
    return g.transform(cube, translation=at)


def test_every_block_is_documented_and_builds(blender):
    for name, block in nodes.BLOCKS.items():
        assert block.__doc__ and len(block.__doc__.strip()) > 20, name
        tree = block.tree()
        assert tree.name == name and tree.description


# -- profile -----------------------------------------------------------------------------------

def test_rectangle_fillet_morphs_square_to_circle(blender):
    def profile(roundness):
        return _curve_points(lambda g: nodes.rectangle_fillet(
            g, width=2.0, height=2.0, roundness=roundness, resolution=6)["Curve"])

    square, half, circle = profile(0.0), profile(0.5), profile(1.0)
    assert len(square) == len(half) == len(circle)  # topology kept while morphing
    # square: every point on the boundary max(|x|, |y|) = 1, the corners reached
    assert np.abs(square[:, :2]).max(axis=1) == pytest.approx(1.0, abs=1e-3)
    assert np.linalg.norm(square[:, :2], axis=1).max() == pytest.approx(math.sqrt(2), abs=1e-2)
    # circle: every point at distance 1
    assert np.linalg.norm(circle[:, :2], axis=1) == pytest.approx(1.0, abs=2e-2)
    # in between: corners cut, still inside the square and outside the circle
    radii = np.linalg.norm(half[:, :2], axis=1)
    assert 1.0 - 1e-3 <= radii.min() and radii.max() < math.sqrt(2) - 0.05
    assert np.abs(half[:, 2]).max() == 0.0


def test_rectangle_fillet_follows_width_and_height(blender):
    points = _curve_points(lambda g: nodes.rectangle_fillet(
        g, width=4.0, height=1.0, roundness=1.0)["Curve"])
    assert points[:, 0].max() == pytest.approx(2.0, abs=1e-3)
    assert points[:, 1].max() == pytest.approx(0.5, abs=1e-3)


def test_rectangle_fillet_cuts_add_points_evenly_along_each_side_only(blender):
    def profile(cuts):
        return _curve_points(lambda g: nodes.rectangle_fillet(
            g, width=4.0, height=1.0, roundness=0.0, resolution=2, cuts=cuts)["Curve"])

    plain, cut = profile(0), profile(3)
    assert len(plain) == 12 and len(cut) == 12 + 4 * 3
    # the same rectangle: every new point lies on a side, the corners as before
    assert np.abs(cut[:, :2] / (2.0, 0.5)).max(axis=1) == pytest.approx(1.0, abs=1e-3)
    top = np.sort(cut[np.abs(cut[:, 1] - 0.5) < 1e-3, 0])
    assert np.unique(top.round(3)) == pytest.approx([-2.0, -1.0, 0.0, 1.0, 2.0], abs=2e-3)


# -- curves ------------------------------------------------------------------------------------

def test_quadratic_cartesian_passes_its_ends_and_bends_by_offset(blender):
    points = _curve_points(lambda g: nodes.quadratic_cartesian(
        g, start=(0, 0, 0), end=(0, 0, 2), offset=(1, 0, 0), resolution=16)["Curve"])
    assert len(points) == 17
    assert points[0] == pytest.approx([0, 0, 0], abs=1e-5)
    assert points[-1] == pytest.approx([0, 0, 2], abs=1e-5)
    # the Bezier's midpoint is (start + 2 middle + end) / 4 = (0.5, 0, 1)
    assert points[:, 0].max() == pytest.approx(0.5, abs=1e-2)


def test_quadratic_polar_bends_towards_its_angle(blender):
    def bend(angle):
        return _curve_points(lambda g: nodes.quadratic_polar(
            g, start=(0, 0, 0), end=(0, 0, 2), angle=angle, distance=1.0)["Curve"])

    straight_out = bend(0.0)
    assert straight_out[:, 0].max() == pytest.approx(0.5, abs=1e-2)
    assert bend(math.pi)[:, 0].min() == pytest.approx(-0.5, abs=1e-2)
    assert straight_out[-1] == pytest.approx([0, 0, 2], abs=1e-5)


def test_bezier_segment_hits_its_endpoints(blender):
    points = _curve_points(lambda g: nodes.bezier_segment(
        g, start=(0, 0, 0), start_handle=(1, 0, 0), end_handle=(1, 0, 1), end=(0, 0, 1),
        resolution=8)["Curve"])
    assert len(points) == 9
    assert points[0] == pytest.approx([0, 0, 0], abs=1e-5)
    assert points[-1] == pytest.approx([0, 0, 1], abs=1e-5)
    assert points[:, 0].max() == pytest.approx(0.75, abs=1e-2)  # cubic midpoint


def test_arc_lies_on_its_circle(blender):
    points = _curve_points(lambda g: nodes.arc(
        g, center=(1, 2, 0), radius=0.5, start_angle=0.0, sweep_angle=math.pi / 2,
        resolution=12)["Curve"])
    assert np.linalg.norm(points[:, :2] - [1, 2], axis=1) == pytest.approx(0.5, abs=1e-5)
    assert points[0] == pytest.approx([1.5, 2, 0], abs=1e-5)
    assert points[-1] == pytest.approx([1, 2.5, 0], abs=1e-5)


def _body_outline(g):
    """A bulging outline in the XZ plane: x = 0.5 + 0.3 sin(pi z / 2), z in [0, 2]."""
    path = _vertical_line(g, 2.0, 33)
    x = 0.5 + 0.3 * g.sin(g.position().z * math.pi / 2)
    return g.node("GeometryNodeSetPosition", {"Geometry": path,
                                              "Offset": g.vec(x, 0, 0)}).out


def test_handle_attaches_on_the_curve_and_clears_it(blender):
    points = _curve_points(lambda g: nodes.handle(
        g, curve=_body_outline(g), start=0.2, end=0.8, reach=0.25, peak=0.5)["Curve"])
    outline = _curve_points(_body_outline)

    def on_outline(p):
        return np.linalg.norm(outline - p, axis=1).min() < 0.07  # within a segment

    assert on_outline(points[0]) and on_outline(points[-1])
    assert points[0][2] < points[-1][2]  # runs from the start attachment upwards
    # it clears the outline: its bulge passes the widest point (0.8) by over half the reach
    assert points[:, 0].max() > 0.8 + 0.25 / 2
    inner = points[2:-2]
    width_at = 0.5 + 0.3 * np.sin(np.pi * inner[:, 2] / 2)
    assert (inner[:, 0] > width_at).all()


def test_handle_attachment_points_are_sampled_on_the_curve(blender):
    def build(g):
        outline = _body_outline(g)
        h = nodes.handle(g, curve=outline, start=0.0, end=1.0)
        s = nodes.sample_curve(g, curve=outline, factor=0.0)["Position"]
        e = nodes.sample_curve(g, curve=outline, factor=1.0)["Position"]
        points = g.join([g.node("GeometryNodeMeshLine", {"Count": 1, "Start Location": v}).out
                         for v in (h["Start Position"], s, h["End Position"], e)])
        return points

    v = _evaluate(build).vertices
    assert v[0] == pytest.approx(v[1], abs=1e-5) and v[0] == pytest.approx([0.5, 0, 0], abs=1e-4)
    assert v[2] == pytest.approx(v[3], abs=1e-5) and v[2] == pytest.approx([0.5, 0, 2], abs=1e-4)


# -- styles ------------------------------------------------------------------------------------

def _round_profile(g):
    return nodes.rectangle_fillet(g, roundness=1.0, resolution=8)["Curve"]


def _radii_by_height(mesh):
    """Max distance from the Z axis at the bottom, middle and top of a swept mesh."""
    v = mesh.vertices
    r = np.linalg.norm(v[:, :2], axis=1)
    z = np.round(v[:, 2], 4)
    levels = np.unique(z)
    return [r[z == levels[i]].max() for i in (0, len(levels) // 2, -1)]


def test_rail_has_constant_radius_and_labels_its_part(blender):
    mesh = _evaluate(lambda g: nodes.rail(g, curve=_vertical_line(g), profile_curve=_round_profile(g),
                                          radius=0.1, label=3)["Mesh"])
    assert _radii_by_height(mesh) == pytest.approx([0.1, 0.1, 0.1], rel=3e-3)
    assert mesh.is_watertight  # caps filled
    assert (mesh.metadata["part"] == 3).all()


def test_leg_eases_from_top_to_bottom_radius(blender):
    mesh = _evaluate(lambda g: nodes.leg_style(g, curve=_vertical_line(g), profile_curve=_round_profile(g),
                                         top_radius=0.2, bottom_radius=0.1)["Mesh"])
    bottom, middle, top = _radii_by_height(mesh)  # path runs up: its start is at z = 0
    assert bottom == pytest.approx(0.2, rel=3e-3) and top == pytest.approx(0.1, rel=3e-3)
    assert 0.1 < middle < 0.2


def test_middle_expand_contract(blender):
    def radii(amount):
        return _radii_by_height(_evaluate(lambda g: nodes.middle_expand_contract(
            g, curve=_vertical_line(g), profile_curve=_round_profile(g), radius=0.1,
            amount=amount)["Mesh"]))

    assert radii(0.5) == pytest.approx([0.1, 0.15, 0.1], rel=3e-3)
    assert radii(-0.5) == pytest.approx([0.1, 0.05, 0.1], rel=3e-3)


def test_solidify_closes_an_open_surface_into_a_shell(blender):
    def build(g):
        tube = nodes.sweep(g, curve=_vertical_line(g), profile_curve=_round_profile(g),
                           scale=1.0, fill_caps=False, label=5)["Mesh"]
        return nodes.solidify(g, mesh=tube, thickness=0.1)["Mesh"]

    mesh = _evaluate(build)
    assert mesh.is_watertight and mesh.is_winding_consistent
    r = np.linalg.norm(mesh.vertices[:, :2], axis=1)
    assert r.max() == pytest.approx(1.0, rel=3e-3) and r.min() == pytest.approx(0.9, rel=3e-3)
    # a pipe of radii 0.9..1 and height 2 (polygonal: slightly less)
    assert mesh.volume == pytest.approx(math.pi * (1 - 0.81) * 2, rel=0.03)
    assert (mesh.metadata["part"] == 5).all()


# -- sampling ----------------------------------------------------------------------------------

def test_sample_curve_gives_point_and_tangent(blender):
    def build(g):
        sample = nodes.sample_curve(g, curve=_vertical_line(g), factor=0.25)
        return g.join([g.node("GeometryNodeMeshLine", {"Count": 1, "Start Location": v}).out
                       for v in (sample["Position"], sample["Tangent"])])

    position, tangent = _evaluate(build).vertices
    assert position == pytest.approx([0, 0, 0.5], abs=1e-5)
    assert tangent == pytest.approx([0, 0, 1], abs=1e-5)


def _array_points(count, start=0.1, end=0.1):
    def build(g):
        points = nodes.sample_curve_array(g, curve=_vertical_line(g), count=count,
                                          start_margin=start, end_margin=end)["Points"]
        return g.node("GeometryNodePointsToVertices", {"Points": points}).out

    return _evaluate(build).vertices


def test_sample_curve_array_spreads_points_between_margins(blender):
    assert _array_points(5)[:, 2] == pytest.approx(np.linspace(0.2, 1.8, 5), abs=1e-5)
    assert _array_points(1)[:, 2] == pytest.approx([1.0], abs=1e-5)  # a single point: middle
    assert len(_array_points(0)) == 0


def test_sample_points_picks_by_index(blender):
    def build(g):
        points = nodes.sample_curve_array(g, curve=_vertical_line(g), count=5)["Points"]
        picked = nodes.sample_points(g, points=points, index=3)["Position"]
        return g.node("GeometryNodeMeshLine", {"Count": 1, "Start Location": picked}).out

    assert _evaluate(build).vertices[0] == pytest.approx([0, 0, 1.5], abs=1e-5)


# -- symmetry ----------------------------------------------------------------------------------

def _centres(mesh):
    return np.array(sorted((c.vertices.mean(0) for c in mesh.split(only_watertight=False)),
                           key=lambda c: math.atan2(c[1], c[0]) % (2 * math.pi)))


def test_radial_places_copies_around_the_axis(blender):
    mesh = _evaluate(lambda g: nodes.radial(g, geometry=_cube(g), count=3, radius=1.0)["Geometry"])
    angles = np.radians([0, 120, 240])
    expected = np.stack([np.cos(angles), np.sin(angles), np.zeros(3)], axis=1)
    assert _centres(mesh) == pytest.approx(expected, abs=1e-5)
    empty = _evaluate(lambda g: nodes.radial(g, geometry=_cube(g), count=0, radius=1.0)["Geometry"])
    assert len(empty.vertices) == 0


def test_mirror_copies_across_the_chosen_axis(blender):
    for axis, expected in ((0, [-1, 2, 3]), (1, [1, -2, 3]), (2, [1, 2, -3])):
        mesh = _evaluate(lambda g, a=axis: nodes.mirror(
            g, geometry=_cube(g, at=(1, 2, 3)), axis=a)["Geometry"])
        centres = [c.vertices.mean(0) for c in mesh.split(only_watertight=False)]
        assert any(np.allclose(c, expected, atol=1e-5) for c in centres)
        assert any(np.allclose(c, [1, 2, 3], atol=1e-5) for c in centres)
        assert all(c.volume > 0 for c in mesh.split(only_watertight=False))  # faces outward


# -- utilities ---------------------------------------------------------------------------------

def test_align_curve_to_start_point_reverses_when_needed(blender):
    def run(point):
        return _curve_points(lambda g: nodes.align_curve_to_start_point(
            g, curve=_vertical_line(g), point=point)["Curve"])

    assert run((0, 0, -1))[0] == pytest.approx([0, 0, 0])
    assert run((0, 0, 3))[0] == pytest.approx([0, 0, 2])


def test_align_curve_tilt_to_axis_turns_the_swept_profile(blender):
    def corners(axis):
        def build(g):
            path = nodes.align_curve_tilt_to_axis(g, curve=_vertical_line(g), axis=axis)["Curve"]
            square = nodes.rectangle_fillet(g, width=2.0, height=2.0, roundness=0.0)["Curve"]
            return nodes.rail(g, curve=path, profile_curve=square, radius=1.0)["Mesh"]

        v = _evaluate(build).vertices
        ring = v[np.isclose(v[:, 2], 0.0)]
        return ring[np.linalg.norm(ring[:, :2], axis=1) > 1.41][:, :2]

    # profile +X along the axis: corners on the diagonals for X, on the axes for X+Y
    straight = np.abs(corners((1, 0, 0)))
    assert len(straight) >= 4 and straight == pytest.approx(np.ones_like(straight), abs=3e-3)
    turned = np.abs(corners((1, 1, 0)))
    assert turned.max(axis=1) == pytest.approx(math.sqrt(2), abs=3e-3)
    assert turned.min(axis=1) == pytest.approx(0.0, abs=3e-3)


# -- surfaces and repeat zones ---------------------------------------------------------------

def _sides(g):
    """A bowed right side from (0.4, 0, 0) to (0.3, 0, 1) and its mirror image."""
    right = nodes.quadratic_cartesian(g, start=(0.4, 0, 0), end=(0.3, 0, 1), offset=(0.1, 0, 0),
                                resolution=8)["Curve"]
    return g.transform(right, scale=(-1.0, 1.0, 1.0)), right


def test_loft_spans_the_two_curves_and_faces_forward(blender):
    def build(g):
        left, right = _sides(g)
        return nodes.loft(g, curve_a=left, curve_b=right, rows=8)["Mesh"]

    mesh = _evaluate(build)
    assert len(mesh.vertices) == 18 and len(mesh.faces) == 16
    # the edges are the curves: mirror images, bowed out past both ends' widths
    left = mesh.vertices[mesh.vertices[:, 0] < 0]
    right = mesh.vertices[mesh.vertices[:, 0] > 0]
    assert np.allclose(np.sort(left[:, 2]), np.sort(right[:, 2]))
    assert right[:, 0].max() > 0.4 and right[np.argmax(right[:, 2]), 0] == pytest.approx(0.3)
    assert np.allclose(mesh.face_normals, (0, -1, 0), atol=1e-6)  # left -> right, rising


def test_loft_cell_covers_its_share_with_gaps(blender):
    def build(g):
        left, right = _sides(g)
        return nodes.loft(g, curve_a=left, curve_b=right, start=0.25, end=0.75, span_start=0.5,
                    span_end=1.0, inset=0.01, rows=4)["Mesh"]

    v = _evaluate(build).vertices
    assert v[:, 2].min() > 0.2 and v[:, 2].max() < 0.8  # a middle share of the height
    assert v[:, 0].min() == pytest.approx(0.01)  # from the middle, moved in by the inset ...
    full = _evaluate(lambda g: nodes.loft(g, curve_a=_sides(g)[0], curve_b=_sides(g)[1], start=0.25,
                                    end=0.75, rows=4)["Mesh"]).vertices
    assert v[:, 0].max() == pytest.approx(full[:, 0].max() - 0.01)  # ... to the side


def test_repeat_zone_carries_its_state_through_the_passes(blender):
    def build(g):
        count = g.input("Count", "int", default=3, min=0, max=10)
        zone = nodes.Repeat(g, count, geometry=None, x=0.5)
        cube = g.node("GeometryNodeMeshCube", {"Size": (0.1, 0.1, 0.1)}).out
        placed = g.transform(cube, translation=g.vec(zone["x"], 0, zone.iteration))
        return zone.close(geometry=g.join([zone["geometry"], placed]),
                          x=zone["x"] * 2.0)["geometry"]

    mesh = _evaluate(build)
    centres = np.array(sorted({tuple(np.round(c, 4)) for c in
                               mesh.vertices.reshape(-1, 8, 3).mean(axis=1)}))
    assert np.allclose(centres, [(0.5, 0, 0), (1.0, 0, 1), (2.0, 0, 2)])
    assert len(_evaluate(build, {"Count": 0}).vertices) == 0


def test_repeat_zone_names_its_items(blender):
    g = Graph.new("probe")
    zone = nodes.Repeat(g, 2, geometry=None, x=0.0)
    with pytest.raises(TypeError, match="items are"):
        zone.close(geometry=None)


def test_visibility_passes_through_a_repeat_zone(blender):
    g = Graph.new("probe")
    extra = g.input("extra", "bool", default=False)
    size = g.input("size", "float", default=0.1, min=0.0, max=1.0)
    zone = nodes.Repeat(g, 2, geometry=None)
    cube = g.node("GeometryNodeMeshCube", {"Size": g.vec(size, size, size)}).out
    built = g.join([zone["geometry"], g.switch(extra, None, cube)])
    g.output("Geometry", "geometry", zone.close(geometry=built)["geometry"])
    assert str(infer_visibility(g.tree)["size"]) == "extra"


def test_bow_in_plan_bends_a_bar_back_in_the_middle_and_keeps_its_ends(blender):
    def bar(g):
        line = g.line(g.vec(-0.5, 0.0, 0.0), g.vec(0.5, 0.0, 0.0), count=11)
        return nodes.bow_in_plan(g, geometry=g.node("GeometryNodeCurveToMesh",
                                                    {"Curve": line}).out,
                                 depth=0.1, half_width=0.4)["Geometry"]

    points = _evaluate(bar).vertices
    x, y = points[:, 0], points[:, 1]
    assert y == pytest.approx(0.1 * (1.0 - np.minimum(np.abs(x) / 0.4, 1.0) ** 2), abs=1e-6)
    assert y[np.abs(x) < 1e-6] == pytest.approx(0.1) and y[np.abs(x) >= 0.4].max() == 0.0


def test_seat_cuts_add_points_to_its_outline_and_keep_its_slab(blender):
    def slab(cuts):
        return _evaluate(lambda g: nodes.seat(g, width=0.5, depth=0.4, roundness=0.3, cuts=cuts,
                                              top=0.45, thickness=0.05)["Mesh"])

    plain, cut = slab(0), slab(5)
    assert len(cut.vertices) > len(plain.vertices)
    assert cut.bounds == pytest.approx(plain.bounds, abs=1e-4)
    # the middle of the back edge is a point of the outline now (a bow can move it)
    back = cut.vertices[np.abs(cut.vertices[:, 1] - 0.2) < 1e-4]
    assert np.abs(back[:, 0]).min() < 1e-4
