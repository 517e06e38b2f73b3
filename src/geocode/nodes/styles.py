"""Styles: how a profile is scaled along a path when it is swept into a mesh (a triplet is
path curve + profile curve + style -> mesh). Every style labels the faces it makes with its
`Label` input (the segmentation label, `Graph.label`).

Besides the generic Sweep, Rail, Leg, MiddleExpandContract and Solidify, furniture styles:
SeatFrame (full size in the middle, rounded in by `Bevel` towards both ends), Cushion (flat at
the bottom, puffed towards the top by `Fill`), AlignedBevelXY (the profile's X pinned to a
world axis so a bent frame does not twist, its end bevelled) and BezierSegment (the scale
follows a cubic Bezier of four values: a lathe-like silhouette)."""

from __future__ import annotations

import math

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group
from geocode.nodes.utils import align_curve_tilt_to_axis

# the share of the path, at its end, that AlignedBevelXY rounds in
_BEVEL_SPAN = 0.2
# Cushion never shrinks below this share of its profile, so its top cap keeps an area
_CUSHION_TOP = 0.35


def _triplet_inputs(g: Graph):
    curve = g.input("Curve", "geometry")
    profile = g.input("Profile Curve", "geometry")
    fill_caps = g.input("Fill Caps", "bool", default=True)
    label = g.input("Label", "int", default=0, min=0)
    return curve, profile, fill_caps, label


def _sweep(g: Graph, curve, profile, scale, fill_caps, label):
    mesh = g.node("GeometryNodeCurveToMesh", {
        "Curve": curve, "Profile Curve": profile, "Scale": scale, "Fill Caps": fill_caps,
    }).out
    return g.label(mesh, label)


@node_group("StyleSweep")
def sweep(g: Graph) -> None:
    """Sweep `Profile Curve` along `Curve`, scaled by the field `Scale` (evaluated on the
    path's points: use the spline factor for a shape along the path)."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    scale = g.input("Scale", "float", default=1.0)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, label))


@node_group("StyleRail")
def rail(g: Graph) -> None:
    """A rail: the profile swept at the constant scale `Radius`."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    radius = g.input("Radius", "float", default=0.05, min=0.0)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, radius, fill_caps, label))


@node_group("StyleLeg")
def leg_style(g: Graph) -> None:
    """A leg: the scale eases from `Top Radius` at the path's start to `Bottom Radius` at
    its end along a fixed float curve (slow at the top, a flare near the foot)."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    top = g.input("Top Radius", "float", default=0.05, min=0.0)
    bottom = g.input("Bottom Radius", "float", default=0.03, min=0.0)
    ease = g.node("ShaderNodeFloatCurve", {"Value": g.spline_factor()})
    _set_curve(ease.bl.mapping, [(0.0, 0.0), (0.6, 0.35), (1.0, 1.0)])
    scale = g.lerp(top, bottom, ease.out)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, label))


@node_group("StyleMiddleExpandContract")
def middle_expand_contract(g: Graph) -> None:
    """Scale `Radius` x (1 + `Amount` sin(pi t)) along the path (t = fraction of length):
    the middle swells for a positive `Amount` and pinches for a negative one, the two ends
    keep `Radius`."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    radius = g.input("Radius", "float", default=0.05, min=0.0)
    amount = g.input("Amount", "float", default=0.5, min=-0.95, max=4.0)
    bump = g.sin(g.spline_factor() * math.pi)
    scale = radius * (1.0 + amount * bump)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, label))


@node_group("StyleSolidify")
def solidify(g: Graph) -> None:
    """Give an open surface `Thickness`: the surface moves `Thickness` against its normals
    and the boundary is bridged, giving a closed shell whose outside is the input surface.
    Attributes (the label) carry over to the new faces."""
    mesh = g.input("Mesh", "geometry")
    thickness = g.input("Thickness", "float", default=0.02, min=0.0)
    # extruding the flipped surface keeps the inner wall facing into the cavity
    flipped = g.node("GeometryNodeFlipFaces", {"Mesh": mesh})
    inner = g.node("GeometryNodeExtrudeMesh", {
        "Mesh": flipped, "Offset Scale": thickness, "Individual": False,
    }, mode="FACES")["Mesh"]
    shell = g.join([mesh, inner])
    # the extrusion's side walls start on the original boundary: weld them to it
    welded = g.node("GeometryNodeMergeByDistance", {"Geometry": shell, "Distance": 1e-6})
    g.output("Mesh", "geometry", welded)


def _set_curve(mapping, points) -> None:
    """Replace the (two default) points of a Float Curve mapping by `points`."""
    curve = mapping.curves[0]
    for (x, y), point in zip(points, curve.points, strict=False):
        point.location = (x, y)
    for x, y in points[len(curve.points):]:
        curve.points.new(x, y)
    mapping.update()


@node_group("StyleSeatFrame")
def seat_frame(g: Graph) -> None:
    """Scale 1 - Bevel (1 - sqrt(1 - u^2)), u = |2t - 1|: full size in the middle of the
    path, a quarter-round edge of depth `Bevel` (share of the profile) at both ends."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    bevel = g.input("Bevel", "float", default=0.05, min=0.0, max=0.5)
    u = abs(g.spline_factor() * 2.0 - 1.0)
    rounded = 1.0 - g.sqrt(g.max(1.0 - u * u, 0.0))
    scale = 1.0 - bevel * rounded
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, label))


@node_group("StyleCushion")
def cushion_style(g: Graph) -> None:
    """Scale max(sqrt(1 - t^k), 0.35), k = 2 + 8 Fill, along a path that rises from the
    cushion's bottom: a flat base whose sides puff in towards the top; `Fill` 0 gives a
    dome, 1 a full pillow with rounded top edges."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    fill = g.input("Fill", "float", default=0.5, min=0.0, max=1.0)
    power = g.math("POWER", g.spline_factor(), 2.0 + fill * 8.0)
    puff = g.sqrt(g.max(1.0 - power, 0.0))
    scale = g.max(puff, _CUSHION_TOP)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, label))


@node_group("StyleAlignedBevelXY")
def aligned_bevel_xy(g: Graph) -> None:
    """The profile's X pinned to the world `Axis` (perpendicular to the path), so a bent
    frame does not twist; constant scale `Radius`, rounded in by `Bevel` (share of the
    profile) over the last fifth of the path (a chamfered top)."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    axis = g.input("Axis", "vector", default=(1, 0, 0))
    radius = g.input("Radius", "float", default=1.0, min=0.0)
    bevel = g.input("Bevel", "float", default=0.0, min=0.0, max=0.9)
    aligned = align_curve_tilt_to_axis(g, curve=curve, axis=axis)["Curve"]
    ramp = g.map_range(g.spline_factor(), 1.0 - _BEVEL_SPAN, 1.0, 0.0, 1.0,
                       interpolation="SMOOTHSTEP")
    scale = radius * (1.0 - bevel * ramp)
    g.output("Mesh", "geometry", _sweep(g, aligned, profile, scale, fill_caps, label))


@node_group("StyleBezierSegment")
def bezier_segment_style(g: Graph) -> None:
    """Scale B(t) = (1-t)^3 Start + 3(1-t)^2 t Start Handle + 3(1-t) t^2 End Handle
    + t^3 End: a smooth silhouette from `Start` to `End` shaped by the two handles."""
    curve, profile, fill_caps, label = _triplet_inputs(g)
    values = [g.input(name, "float", default=default, min=0.0)
              for name, default in (("Start", 0.05), ("Start Handle", 0.05),
                                    ("End Handle", 0.1), ("End", 0.2))]
    t = g.spline_factor()
    s = 1.0 - t
    weights = (s * s * s, 3.0 * (s * s * t), 3.0 * (s * t * t), t * t * t)
    scale = 0.0
    for weight, value in zip(weights, values, strict=True):
        scale = scale + weight * value
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, label))
