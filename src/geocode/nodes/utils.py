"""Utilities: blocks that keep curve directions stable while parameters change, and a bend.

Blender picks a curve's direction and normals from its shape, so a small edit can flip
them; a part swept along such a curve would suddenly turn over. The align blocks pin them.
"""

from __future__ import annotations

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group


@node_group("UtilAlignCurveToStartPoint")
def align_curve_to_start_point(g: Graph) -> None:
    """Reverse `Curve` when its end lies closer to `Point` than its start does, so that
    the curve always runs away from `Point`."""
    curve = g.input("Curve", "geometry")
    point = g.input("Point", "vector", default=(0, 0, 0))
    first = g.node("GeometryNodeSampleCurve", {"Curves": curve, "Factor": 0.0},
                   mode="FACTOR", use_all_curves=False)["Position"]
    last = g.node("GeometryNodeSampleCurve", {"Curves": curve, "Factor": 1.0},
                  mode="FACTOR", use_all_curves=False)["Position"]
    backwards = g.distance(last, point) < g.distance(first, point)
    reversed_curve = g.node("GeometryNodeReverseCurve", {"Curve": curve,
                                                          "Selection": backwards})
    g.output("Curve", "geometry", reversed_curve)


@node_group("UtilAlignCurveTiltToAxis")
def align_curve_tilt_to_axis(g: Graph) -> None:
    """Set the normals of `Curve` to `Axis` made perpendicular to the tangent, so that a
    profile swept along it keeps its orientation (profile +X along the normal) instead of
    following Blender's minimum-twist frame."""
    curve = g.input("Curve", "geometry")
    axis = g.input("Axis", "vector", default=(1, 0, 0))
    tangent = g.tangent()
    along = tangent * g.dot(axis, tangent)
    normal = g.normalize(axis - along)
    oriented = g.node("GeometryNodeSetCurveNormal", {
        "Curve": curve, "Mode": "Free", "Normal": normal,
    })
    g.output("Curve", "geometry", oriented)


@node_group("UtilBowInPlan")
def bow_in_plan(g: Graph) -> None:
    """Every point of `Geometry` moved along +Y by `Depth` x (1 - (x / `Half Width`)^2), and
    not at all beyond |x| = `Half Width`: a part spanning x = -Half Width..Half Width bent into
    a parabola in plan, its ends in place (they stay joined to whatever holds them). `Depth`
    may be a field (the chair's bow grows with height). The bend shows only where the part
    has points across x."""
    geometry = g.input("Geometry", "geometry")
    depth = g.input("Depth", "float", default=0.0)
    half_width = g.input("Half Width", "float", default=0.25, min=1e-6)
    across = g.min(abs(g.position().x) / half_width, 1.0)
    offset = g.vec(0.0, depth * (1.0 - across * across), 0.0)
    g.output("Geometry", "geometry", g.set_position(geometry, offset=offset))
