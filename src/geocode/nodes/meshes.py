"""Meshes: ready-made triplets (path curve + RectangleFillet profile + style -> mesh), the
pieces that furniture programs are assembled from (docs/paper-numbers.md#building-blocks, "meshes").

Profiles are given in absolute sizes (`Width` along the profile's X, `Depth` along its Y),
so styles scale by 1 at rest. Every block labels its faces with `Label` and, where other
meshes attach to it, also returns its path `Curve` (sample it for attachment points).
"""

from __future__ import annotations

import math

from geocode.nodes.curves import fixed_bottom, fixed_top, quadratic_cartesian, quadratic_polar
from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group
from geocode.nodes.profiles import corner_radius, rectangle_fillet
from geocode.nodes.styles import (
    aligned_bevel_xy,
    cushion_style,
    leg_style,
    middle_expand_contract,
    rail,
    seat_frame,
)
from geocode.nodes.utils import align_curve_tilt_to_axis

# fillet points per profile corner: small meshes need few, the seat is seen up close
THIN_RESOLUTION = 2
SEAT_RESOLUTION = 6
# the rectangle's corner moves in by r (1 - 1/sqrt 2) when rounded with radius r
_CORNER_INSET = 1.0 - 1.0 / math.sqrt(2.0)


def _vertical_path(g: Graph, bottom, top, points: int):
    """Vertical path on the Z axis from z=bottom to z=top, the profile's X on world X."""
    path = g.line(g.vec(0.0, 0.0, bottom), g.vec(0.0, 0.0, top), count=points)
    return align_curve_tilt_to_axis(g, curve=path, axis=(1.0, 0.0, 0.0))["Curve"]


def _profile(g: Graph, width, depth, roundness, resolution=THIN_RESOLUTION, cuts=0):
    return rectangle_fillet(g, width=width, height=depth, roundness=roundness,
                            resolution=resolution, cuts=cuts)["Curve"]


def _frame_along(g: Graph, path) -> None:
    """The body of a frame group, after its path's inputs: the profile and style inputs
    (after the path's, so the sockets keep their order), then the outputs `Mesh`, the
    profile swept along the curve that `path()` builds, and that `Curve`."""
    width = g.input("Width", "float", default=0.04, min=0.0)
    depth = g.input("Depth", "float", default=0.04, min=0.0)
    roundness = g.input("Roundness", "float", default=0.0, min=0.0, max=1.0)
    bevel = g.input("Bevel", "float", default=0.0, min=0.0, max=0.9)
    axis = g.input("Axis", "vector", default=(1, 0, 0))
    label = g.input("Label", "int", default=0, min=0)
    curve = path()
    mesh = aligned_bevel_xy(g, curve=curve, profile_curve=_profile(g, width, depth, roundness),
                            axis=axis, radius=1.0, bevel=bevel, fill_caps=True,
                            label=label)["Mesh"]
    g.output("Mesh", "geometry", mesh)
    g.output("Curve", "geometry", curve)


def _outline_inputs(g: Graph):
    """`Width`, `Depth`, `Roundness` and `Cuts` of a seat's outline (MeshSeat, MeshCushion):
    the cuts, points along each side, let the slab bend in plan (UtilBowInPlan)."""
    return (g.input("Width", "float", default=0.5, min=0.0),
            g.input("Depth", "float", default=0.5, min=0.0),
            g.input("Roundness", "float", default=0.0, min=0.0, max=1.0),
            g.input("Cuts", "int", default=0, min=0, max=64))


def _sweep_outline(g: Graph, style, outline, bottom, top, points: int, **style_inputs) -> None:
    """The last input, `Label`, and the output `Mesh`: the outline swept from z = `bottom`
    up to `top` along `points` points with the `style` group."""
    width, depth, roundness, cuts = outline
    label = g.input("Label", "int", default=0, min=0)
    profile = _profile(g, width, depth, roundness, SEAT_RESOLUTION, cuts)
    mesh = style(g, curve=_vertical_path(g, bottom, top, points), profile_curve=profile,
                 fill_caps=True, label=label, **style_inputs)["Mesh"]
    g.output("Mesh", "geometry", mesh)


@node_group("MeshSeat")
def seat(g: Graph) -> None:
    """A seat slab: a `Width` x `Depth` RectangleFillet (corners rounded by `Roundness`,
    a disc/ellipse at 1) swept from z = Top - Thickness up to `Top` with StyleSeatFrame.

    `Corner` is the attachment point of the +X+Y corner on the outline (z = 0): the
    middle of the rounded corner, which moves inwards as the seat gets rounder, so legs
    and frames placed from it follow the outline."""
    outline = width, depth, roundness, _ = _outline_inputs(g)
    top = g.input("Top", "float", default=0.45)
    thickness = g.input("Thickness", "float", default=0.05, min=0.0)
    bevel = g.input("Bevel", "float", default=0.05, min=0.0, max=0.5)
    _sweep_outline(g, seat_frame, outline, top - thickness, top, 7, bevel=bevel)
    inset = corner_radius(g, roundness, width, depth) * _CORNER_INSET
    g.output("Corner", "vector", g.vec(width * 0.5 - inset, depth * 0.5 - inset, 0.0))


@node_group("MeshCushion")
def cushion_mesh(g: Graph) -> None:
    """A pillow on a seat: the seat's outline (`Width`, `Depth`, `Roundness`, `Cuts`) swept
    up from `Bottom` by `Thickness` with StyleCushion (`Fill`: dome to full pillow)."""
    outline = _outline_inputs(g)
    bottom = g.input("Bottom", "float", default=0.45)
    thickness = g.input("Thickness", "float", default=0.05, min=0.0)
    fill = g.input("Fill", "float", default=0.5, min=0.0, max=1.0)
    _sweep_outline(g, cushion_style, outline, bottom, bottom + thickness, 8, fill=fill)


@node_group("MeshLeg")
def leg_mesh(g: Graph) -> None:
    """A leg hanging from `Top` to `Bottom` on a CurveFixedTop (`Curvature` 1: vertical
    under the seat, bending out towards the foot), StyleLeg from `Top Radius` to
    `Bottom Radius`, a square-to-round profile (`Roundness`) with its X on world X.
    `Curve` is its axis, top to bottom, for meshes attached to the leg (stretchers)."""
    top = g.input("Top", "vector", default=(0, 0, 0.45))
    bottom = g.input("Bottom", "vector", default=(0, 0, 0))
    curvature = g.input("Curvature", "float", default=1.0, min=0.0, max=1.0)
    top_radius = g.input("Top Radius", "float", default=0.025, min=0.0)
    bottom_radius = g.input("Bottom Radius", "float", default=0.02, min=0.0)
    roundness = g.input("Roundness", "float", default=0.0, min=0.0, max=1.0)
    label = g.input("Label", "int", default=0, min=0)
    curve = fixed_top(g, top=top, bottom=bottom, curvature=curvature, resolution=8)["Curve"]
    aligned = align_curve_tilt_to_axis(g, curve=curve, axis=(1.0, 0.0, 0.0))["Curve"]
    mesh = leg_style(g, curve=aligned, profile_curve=_profile(g, 2.0, 2.0, roundness),
                     top_radius=top_radius, bottom_radius=bottom_radius, fill_caps=True,
                     label=label)["Mesh"]
    g.output("Mesh", "geometry", mesh)
    g.output("Curve", "geometry", aligned)


@node_group("MeshStraightFrame")
def straight_frame(g: Graph) -> None:
    """A straight bar from `Start` to `End`: `Width` x `Depth` profile (X on world `Axis`),
    StyleAlignedBevelXY (the end at `End` bevelled by `Bevel`)."""
    start = g.input("Start", "vector", default=(0, 0, 0))
    end = g.input("End", "vector", default=(0, 0, 1))
    _frame_along(g, lambda: g.line(start, end, count=4))


@node_group("MeshQuadraticCartesianAlignedXYFrame")
def quadratic_cartesian_aligned_xy_frame(g: Graph) -> None:
    """A bent frame on a CurveQuadraticCartesian (`Start`, `End`, middle control point
    moved by `Offset`), profile X kept on world `Axis` (StyleAlignedBevelXY)."""
    start = g.input("Start", "vector", default=(0, 0, 0))
    end = g.input("End", "vector", default=(0, 0, 1))
    offset = g.input("Offset", "vector", default=(0, 0.1, 0))
    _frame_along(g, lambda: quadratic_cartesian(g, start=start, end=end, offset=offset,
                                                resolution=12)["Curve"])


@node_group("MeshQuadraticPolarFrame")
def quadratic_polar_frame(g: Graph) -> None:
    """A frame on a CurveQuadraticPolar (`Start`, `End`, bulge `Distance` at `Angle` in
    the XZ plane), profile X kept on world `Axis` (StyleAlignedBevelXY)."""
    start = g.input("Start", "vector", default=(0, 0, 0))
    end = g.input("End", "vector", default=(0, 0, 1))
    angle = g.input("Angle", "float", default=0.0, min=-math.pi, max=math.pi)
    distance = g.input("Distance", "float", default=0.1, min=0.0)
    _frame_along(g, lambda: quadratic_polar(g, start=start, end=end, angle=angle,
                                            distance=distance, resolution=12)["Curve"])


@node_group("MeshFrameFixedBottom")
def frame_fixed_bottom(g: Graph) -> None:
    """A frame standing on `Bottom` (CurveFixedBottom: vertical there at `Curvature` 1)
    and leaning over to `Top`; profile X kept on world `Axis` (StyleAlignedBevelXY)."""
    bottom = g.input("Bottom", "vector", default=(0, 0, 0))
    top = g.input("Top", "vector", default=(0, 0.1, 1))
    curvature = g.input("Curvature", "float", default=1.0, min=0.0, max=1.0)
    _frame_along(g, lambda: fixed_bottom(g, bottom=bottom, top=top, curvature=curvature,
                                         resolution=8)["Curve"])


@node_group("MeshQuadraticCartesian")
def quadratic_cartesian_mesh(g: Graph) -> None:
    """A tube on a CurveQuadraticCartesian (`Start`, `End`, `Offset`) with StyleRail:
    a square-to-round (`Roundness`) profile of half-size `Radius`, X kept on `Axis`."""
    start = g.input("Start", "vector", default=(0, 0, 1))
    end = g.input("End", "vector", default=(1, 0, 0))
    offset = g.input("Offset", "vector", default=(0.3, 0, 0))
    radius = g.input("Radius", "float", default=0.02, min=0.0)
    roundness = g.input("Roundness", "float", default=1.0, min=0.0, max=1.0)
    axis = g.input("Axis", "vector", default=(0, 1, 0))
    label = g.input("Label", "int", default=0, min=0)
    curve = quadratic_cartesian(g, start=start, end=end, offset=offset, resolution=8)["Curve"]
    aligned = align_curve_tilt_to_axis(g, curve=curve, axis=axis)["Curve"]
    mesh = rail(g, curve=aligned, profile_curve=_profile(g, 2.0, 2.0, roundness),
                radius=radius, fill_caps=True, label=label)["Mesh"]
    g.output("Mesh", "geometry", mesh)


def _bar_along_x(g: Graph, half_length, points: int):
    return g.line(g.vec(-half_length, 0.0, 0.0), g.vec(half_length, 0.0, 0.0), count=points)


@node_group("MeshTopRail")
def top_rail(g: Graph) -> None:
    """A rail along X centred on `Center` (x ignored), reaching `Half Length` to both sides
    (over a mirrored pair of frames): profile `Size` along `Tangent` (the frames' direction
    at the attachment) by `Depth`, StyleMiddleExpandContract swelling its middle by
    `Fill`."""
    center = g.input("Center", "vector", default=(0, 0, 1))
    tangent = g.input("Tangent", "vector", default=(0, 0, 1))
    half_length = g.input("Half Length", "float", default=0.25, min=0.0)
    size = g.input("Size", "float", default=0.08, min=0.0)
    depth = g.input("Depth", "float", default=0.03, min=0.0)
    roundness = g.input("Roundness", "float", default=0.0, min=0.0, max=1.0)
    fill = g.input("Fill", "float", default=0.0, min=0.0, max=1.0)
    label = g.input("Label", "int", default=0, min=0)
    bar = g.transform(_bar_along_x(g, half_length, 9),
                      translation=g.vec(0.0, center.y, center.z))
    aligned = align_curve_tilt_to_axis(g, curve=bar, axis=tangent)["Curve"]
    mesh = middle_expand_contract(g, curve=aligned,
                                  profile_curve=_profile(g, size, depth, roundness),
                                  radius=1.0, amount=fill, fill_caps=True, label=label)["Mesh"]
    g.output("Mesh", "geometry", mesh)


@node_group("MeshCrossRail")
def cross_rail(g: Graph) -> None:
    """One rail along X through each of `Points` (x ignored; e.g. SampleCurveArray on the
    right frame of a mirrored pair), reaching `Half Length` to both sides; the profile
    (`Thickness Z` along the frame, `Thickness Y` across it) is turned so that its Z
    follows each point's stored `tangent` (the frame's direction there)."""
    points = g.input("Points", "geometry")
    half_length = g.input("Half Length", "float", default=0.25, min=0.0)
    thickness_y = g.input("Thickness Y", "float", default=0.02, min=0.0)
    thickness_z = g.input("Thickness Z", "float", default=0.04, min=0.0)
    roundness = g.input("Roundness", "float", default=0.0, min=0.0, max=1.0)
    label = g.input("Label", "int", default=0, min=0)
    bar = align_curve_tilt_to_axis(g, curve=_bar_along_x(g, half_length, 9),
                                   axis=(0.0, 0.0, 1.0))["Curve"]
    one = rail(g, curve=bar, profile_curve=_profile(g, thickness_z, thickness_y, roundness),
               radius=1.0, fill_caps=True, label=label)["Mesh"]
    centred = g.set_position(points, position=g.position() * (0.0, 1.0, 1.0))
    tangent = g.node("GeometryNodeInputNamedAttribute", {"Name": "tangent"},
                     data_type="FLOAT_VECTOR")["Attribute"]
    turn = g.node("FunctionNodeAlignRotationToVector", {"Vector": tangent},
                  axis="Z", pivot_axis="X").out
    g.output("Mesh", "geometry", g.instance_on_points(centred, one, rotation=turn))
