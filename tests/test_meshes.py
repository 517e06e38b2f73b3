"""The frame curves, furniture styles and ready-made mesh triplets, evaluated in Blender."""

import math

import numpy as np
import pytest

from geocode.nodes import (
    Evaluator,
    Graph,
    curves,
    meshes,
    rectangle_fillet,
    sample_curve_array,
    styles,
)

pytestmark = pytest.mark.blender

LABEL = 7
BLOCKS = [curves.fixed_top, curves.fixed_bottom, curves.fixed_middle, styles.seat_frame,
          styles.cushion_style, styles.aligned_bevel_xy, styles.bezier_segment_style,
          meshes.seat, meshes.cushion_mesh, meshes.top_rail, meshes.cross_rail, meshes.straight_frame,
          meshes.frame_fixed_bottom, meshes.leg_mesh, meshes.quadratic_polar_frame,
          meshes.quadratic_cartesian_aligned_xy_frame, meshes.quadratic_cartesian_mesh]


def _mesh(build, output="Mesh"):
    """Evaluate a probe graph whose output is `build(g)[output]` (or `build(g)` itself)."""
    g = Graph.new("probe")
    result = build(g)
    g.output("Geometry", "geometry", result[output] if output else result)
    return Evaluator(g.tree).mesh()


def _curve(build):
    """The points of the curve `build(g)["Curve"]`, in order."""
    return _mesh(lambda g: g.node("GeometryNodeCurveToMesh", {"Curve": build(g)["Curve"]}),
                 output=None).vertices


def _vertical_path(g, bottom=0.0, top=1.0, points=9):
    line = g.node("GeometryNodeCurvePrimitiveLine", {"Start": (0, 0, bottom),
                                                     "End": (0, 0, top)})
    return g.node("GeometryNodeResampleCurve", {"Curve": line, "Mode": "Count",
                                                "Count": points}).out


def _direction(a, b):
    d = np.asarray(b) - np.asarray(a)
    return d / np.linalg.norm(d)


def test_every_part_block_is_documented_and_builds(blender):
    for block in BLOCKS:
        assert block.__doc__ and len(block.__doc__.strip()) > 30, block.name
        assert block.tree().name == block.name


# -- curves -------------------------------------------------------------------------------------

@pytest.mark.parametrize("curvature", [0.0, 1.0])
def test_fixed_top_and_bottom_leave_their_fixed_end_vertically(blender, curvature):
    top, bottom = (0.1, 0.1, 1.0), (0.4, -0.2, 0.0)
    hanging = _curve(lambda g: curves.fixed_top(g, top=top, bottom=bottom,
                                                curvature=curvature, resolution=32))
    standing = _curve(lambda g: curves.fixed_bottom(g, bottom=bottom, top=top,
                                                    curvature=curvature, resolution=32))
    assert hanging[0] == pytest.approx(top, abs=1e-5)
    assert hanging[-1] == pytest.approx(bottom, abs=1e-5)
    assert standing[0] == pytest.approx(bottom, abs=1e-5)
    assert standing[-1] == pytest.approx(top, abs=1e-5)
    chord = _direction(top, bottom)
    if curvature == 1.0:
        assert _direction(hanging[0], hanging[1]) == pytest.approx([0, 0, -1], abs=0.05)
        assert _direction(standing[0], standing[1]) == pytest.approx([0, 0, 1], abs=0.05)
    else:
        assert _direction(hanging[0], hanging[1]) == pytest.approx(chord, abs=1e-3)
        assert _direction(standing[0], standing[1]) == pytest.approx(-chord, abs=1e-3)


def test_fixed_middle_keeps_its_middle_and_turns_its_ends_vertical(blender):
    start, end = (0.0, 0.0, 0.0), (0.4, 0.2, 1.0)
    points = _curve(lambda g: curves.fixed_middle(g, start=start, end=end, curvature=1.0,
                                                  resolution=32))
    assert points[0] == pytest.approx(start, abs=1e-5)
    assert points[-1] == pytest.approx(end, abs=1e-5)
    middle = points[len(points) // 2]
    assert middle == pytest.approx([0.2, 0.1, 0.5], abs=0.02)
    assert _direction(points[0], points[1]) == pytest.approx([0, 0, 1], abs=0.08)
    assert _direction(points[-2], points[-1]) == pytest.approx([0, 0, 1], abs=0.08)


# -- styles -------------------------------------------------------------------------------------

def _square(g, size=1.0, roundness=0.0):
    return rectangle_fillet(g, width=size, height=size, roundness=roundness,
                            resolution=2)["Curve"]


def _half_width_at(mesh, z, tol=1e-3):
    near = np.abs(mesh.vertices[:, 2] - z) < tol
    return np.abs(mesh.vertices[near, 0]).max()


def test_bezier_segment_style_scales_from_start_to_end(blender):
    mesh = _mesh(lambda g: styles.bezier_segment_style(
        g, curve=_vertical_path(g), profile_curve=_square(g, 2.0), start=0.1,
        start_handle=0.1, end_handle=0.3, end=0.3, label=LABEL))
    assert _half_width_at(mesh, 0.0) == pytest.approx(0.1, abs=1e-4)
    assert _half_width_at(mesh, 1.0) == pytest.approx(0.3, abs=1e-4)
    assert set(mesh.metadata["part"]) == {LABEL}


def test_seat_frame_rounds_both_ends_by_the_bevel(blender):
    mesh = _mesh(lambda g: styles.seat_frame(g, curve=_vertical_path(g),
                                             profile_curve=_square(g), bevel=0.2, label=LABEL))
    assert _half_width_at(mesh, 0.5) == pytest.approx(0.5, abs=1e-4)
    assert _half_width_at(mesh, 0.0) == pytest.approx(0.4, abs=1e-4)
    assert _half_width_at(mesh, 1.0) == pytest.approx(0.4, abs=1e-4)


def test_cushion_style_puffs_more_when_fuller(blender):
    def widths(fill):
        mesh = _mesh(lambda g: styles.cushion_style(g, curve=_vertical_path(g),
                                              profile_curve=_square(g), fill=fill, label=LABEL))
        return [_half_width_at(mesh, z) for z in (0.0, 0.75, 1.0)]

    dome, full = widths(0.0), widths(1.0)
    assert dome[0] == pytest.approx(0.5) and full[0] == pytest.approx(0.5)
    assert full[1] > dome[1]
    assert dome[2] > 0.1 and full[2] > 0.1  # the top cap keeps an area


def test_aligned_bevel_xy_pins_the_profile_to_the_axis_and_bevels_the_end(blender):
    def mesh(axis, bevel=0.0):
        def build(g):
            profile = rectangle_fillet(g, width=0.2, height=0.04, resolution=2)["Curve"]
            return styles.aligned_bevel_xy(g, curve=_vertical_path(g), profile_curve=profile,
                                           axis=axis, bevel=bevel, label=LABEL)
        return _mesh(build)

    extent = lambda m: m.vertices.max(0) - m.vertices.min(0)  # noqa: E731
    assert extent(mesh((1, 0, 0)))[:2] == pytest.approx([0.2, 0.04], abs=1e-4)
    assert extent(mesh((0, 1, 0)))[:2] == pytest.approx([0.04, 0.2], abs=1e-4)
    bevelled = mesh((1, 0, 0), bevel=0.5)
    assert _half_width_at(bevelled, 1.0) == pytest.approx(0.05, abs=1e-4)
    assert _half_width_at(bevelled, 0.0) == pytest.approx(0.1, abs=1e-4)


# -- meshes -------------------------------------------------------------------------------------

def test_seat_corner_moves_inwards_with_roundness(blender):
    def seat(roundness):
        g = Graph.new("probe")
        block = meshes.seat(g, width=0.6, depth=0.4, roundness=roundness, top=0.5,
                           thickness=0.05, bevel=0.0, label=LABEL)
        corner = g.node("GeometryNodeMeshLine", {"Count": 1,
                                                 "Start Location": block["Corner"]})
        g.output("Geometry", "geometry", g.join([block["Mesh"], corner]))
        return Evaluator(g.tree).mesh()

    square, round_ = seat(0.0), seat(1.0)
    assert square.vertices[-1] == pytest.approx([0.3, 0.2, 0.0], abs=1e-3)
    # a full fillet of radius 0.2: the corner's middle is 0.2 (1 - 1/sqrt 2) further in
    inset = 0.2 * (1 - 1 / math.sqrt(2))
    assert round_.vertices[-1] == pytest.approx([0.3 - inset, 0.2 - inset, 0.0], abs=2e-3)
    body = square.vertices[:-1]
    assert body[:, 2].min() == pytest.approx(0.45) and body[:, 2].max() == pytest.approx(0.5)
    # the corner lies on the outline of the rounded seat
    outline = round_.vertices[:-1]
    assert np.min(np.linalg.norm(outline[:, :2] - round_.vertices[-1, :2], axis=1)) < 0.01


def test_cushion_mesh_sits_on_its_bottom(blender):
    mesh = _mesh(lambda g: meshes.cushion_mesh(g, width=0.5, depth=0.4, roundness=0.3, bottom=0.4,
                                         thickness=0.06, fill=0.5, label=LABEL))
    assert mesh.bounds[:, 2] == pytest.approx([0.4, 0.46], abs=1e-5)
    assert mesh.bounds[1, :2] == pytest.approx([0.25, 0.2], abs=1e-4)
    assert set(mesh.metadata["part"]) == {LABEL}


def test_leg_reaches_from_top_to_bottom_and_tapers(blender):
    mesh = _mesh(lambda g: meshes.leg_mesh(g, top=(0.2, 0.2, 0.5), bottom=(0.25, 0.25, 0.0),
                                     curvature=1.0, top_radius=0.03, bottom_radius=0.015,
                                     label=LABEL))
    z = mesh.vertices[:, 2]
    # the foot's cap is square to the slanted path: its rim dips by up to radius x slope
    assert z.max() == pytest.approx(0.5, abs=2e-3) and z.min() == pytest.approx(0.0, abs=0.01)
    top = mesh.vertices[z > 0.499]
    assert top[:, 0].max() - top[:, 0].min() == pytest.approx(0.06, abs=1e-3)
    foot = mesh.vertices[z < 0.01]
    assert foot[:, 0].mean() == pytest.approx(0.25, abs=5e-3)


def test_cross_rails_span_both_sides_and_follow_the_frame(blender):
    def build(g):
        frame = g.node("GeometryNodeCurvePrimitiveLine", {"Start": (0.2, 0.1, 0.0),
                                                          "End": (0.2, 0.4, 1.0)}).out
        points = sample_curve_array(g, curve=frame, count=3, start_margin=0.2,
                                    end_margin=0.2)["Points"]
        return meshes.cross_rail(g, points=points, half_length=0.2, thickness_y=0.02,
                                thickness_z=0.06, label=LABEL)

    mesh = _mesh(build)
    assert mesh.bounds[:, 0] == pytest.approx([-0.2, 0.2], abs=1e-5)
    assert set(mesh.metadata["part"]) == {LABEL}
    # three rails, centred on the frame at 20%, 50% and 80% of its length
    for fraction in (0.2, 0.5, 0.8):
        y, z = 0.1 + 0.3 * fraction, fraction
        near = np.abs(mesh.vertices[:, 2] - z) < 0.05
        assert near.any()
        assert mesh.vertices[near, 1].mean() == pytest.approx(y, abs=1e-3)
    # each rail's profile is turned to the frame's slope: its height follows the frame
    rail = mesh.vertices[np.abs(mesh.vertices[:, 2] - 0.5) < 0.05]
    extent = rail.max(0) - rail.min(0)
    slope = np.array([0.3, 1.0]) / np.hypot(0.3, 1.0)
    assert extent[2] == pytest.approx(0.06 * slope[1] + 0.02 * slope[0], abs=1e-3)


def test_top_rail_spans_the_frames_at_its_centre(blender):
    mesh = _mesh(lambda g: meshes.top_rail(g, center=(0.2, 0.3, 0.9), tangent=(0, 0, 1),
                                          half_length=0.25, size=0.1, depth=0.03, fill=0.0,
                                          label=LABEL))
    assert mesh.bounds.ravel() == pytest.approx([-0.25, 0.285, 0.85, 0.25, 0.315, 0.95],
                                                abs=1e-4)


@pytest.mark.parametrize("block", ["straight", "cartesian", "polar", "fixed_bottom"])
def test_frames_run_between_their_ends(blender, block):
    start, end = (0.1, 0.0, 0.2), (0.1, -0.3, 0.8)
    common = dict(width=0.04, depth=0.02, label=LABEL)
    makers = {
        "straight": lambda g: meshes.straight_frame(g, start=start, end=end, **common),
        "cartesian": lambda g: meshes.quadratic_cartesian_aligned_xy_frame(
            g, start=start, end=end, offset=(0, 0.1, 0), **common),
        "polar": lambda g: meshes.quadratic_polar_frame(g, start=start, end=end, angle=0.3,
                                                       distance=0.1, **common),
        "fixed_bottom": lambda g: meshes.frame_fixed_bottom(g, bottom=start, top=end,
                                                           curvature=1.0, **common),
    }
    path = _curve(makers[block])
    assert path[0] == pytest.approx(start, abs=1e-5)
    assert path[-1] == pytest.approx(end, abs=1e-5)
    mesh = _mesh(makers[block])
    assert set(mesh.metadata["part"]) == {LABEL}
    lo, hi = mesh.bounds
    assert np.all(lo <= np.minimum(start, end) + 1e-6) and np.all(hi >= np.maximum(start, end)
                                                                   - 1e-6)


def test_quadratic_cartesian_mesh_is_a_tube_between_its_ends(blender):
    mesh = _mesh(lambda g: meshes.quadratic_cartesian_mesh(g, start=(0, 0, 0.1), end=(0.3, 0, 0),
                                                          offset=(0.15, 0, 0), radius=0.02,
                                                          label=LABEL))
    assert mesh.bounds[0, 1] == pytest.approx(-0.02, abs=1e-3)
    assert mesh.bounds[1, 0] == pytest.approx(0.32, abs=0.01)
    assert set(mesh.metadata["part"]) == {LABEL}
