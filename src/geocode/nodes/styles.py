"""Styles: how a profile is scaled along a path when it is swept into a mesh (a triplet is
path curve + profile curve + style -> mesh). Every style labels the faces it makes with its
`Part` input (the integer attribute `part`)."""

from __future__ import annotations

import math

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group


def _triplet_inputs(g: Graph):
    curve = g.input("Curve", "geometry")
    profile = g.input("Profile Curve", "geometry")
    fill_caps = g.input("Fill Caps", "bool", default=True)
    part = g.input("Part", "int", default=0, min=0)
    return curve, profile, fill_caps, part


def _sweep(g: Graph, curve, profile, scale, fill_caps, part):
    mesh = g.node("GeometryNodeCurveToMesh", {
        "Curve": curve, "Profile Curve": profile, "Scale": scale, "Fill Caps": fill_caps,
    }).out
    return g.label_part(mesh, part)


@node_group("StyleSweep")
def sweep(g: Graph) -> None:
    """Sweep `Profile Curve` along `Curve`, scaled by the field `Scale` (evaluated on the
    path's points: use the spline factor for a shape along the path)."""
    curve, profile, fill_caps, part = _triplet_inputs(g)
    scale = g.input("Scale", "float", default=1.0)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, part))


@node_group("StyleRail")
def rail(g: Graph) -> None:
    """A rail: the profile swept at the constant scale `Radius`."""
    curve, profile, fill_caps, part = _triplet_inputs(g)
    radius = g.input("Radius", "float", default=0.05, min=0.0)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, radius, fill_caps, part))


@node_group("StyleLeg")
def leg(g: Graph) -> None:
    """A leg: the scale eases from `Top Radius` at the path's start to `Bottom Radius` at
    its end along a fixed float curve (slow at the top, a flare near the foot)."""
    curve, profile, fill_caps, part = _triplet_inputs(g)
    top = g.input("Top Radius", "float", default=0.05, min=0.0)
    bottom = g.input("Bottom Radius", "float", default=0.03, min=0.0)
    ease = g.node("ShaderNodeFloatCurve", {"Value": g.spline_factor()})
    _set_curve(ease.bl.mapping, [(0.0, 0.0), (0.6, 0.35), (1.0, 1.0)])
    scale = g.lerp(top, bottom, ease.out)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, part))


@node_group("StyleMiddleExpandContract")
def middle_expand_contract(g: Graph) -> None:
    """Scale `Radius` x (1 + `Amount` sin(pi t)) along the path (t = fraction of length):
    the middle swells for a positive `Amount` and pinches for a negative one, the two ends
    keep `Radius`."""
    curve, profile, fill_caps, part = _triplet_inputs(g)
    radius = g.input("Radius", "float", default=0.05, min=0.0)
    amount = g.input("Amount", "float", default=0.5, min=-0.95, max=4.0)
    bump = g.math("SINE", g.mul(g.spline_factor(), math.pi))
    scale = g.mul(radius, g.add(1.0, g.mul(amount, bump)))
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, part))


@node_group("StyleSolidify")
def solidify(g: Graph) -> None:
    """Give an open surface `Thickness`: the surface moves `Thickness` against its normals
    and the boundary is bridged, giving a closed shell whose outside is the input surface.
    Attributes (the `part` label) carry over to the new faces."""
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
