"""Curves: open paths that parts are swept along.

Every curve block returns a poly curve with a fixed number of points (`Resolution` + 1),
so the meshes swept along it keep their topology when parameters change.

Furniture frames add fixed-end paths: FixedTop / FixedBottom (a quadratic path that leaves one
end vertically when `Curvature` is 1, the straight chord at 0: a leg hangs from a FixedTop, a
support stands on a FixedBottom) and FixedMiddle (a cubic S-path whose ends turn vertical while
its middle stays on the chord's midpoint).
"""

from __future__ import annotations

import math

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group
from geocode.nodes.utils import align_curve_to_start_point

_UP = (0.0, 1.0, 0.0)  # the normal of the XZ plane in which planar curves bend


def _poly(g: Graph, curve, resolution):
    """Evenly spaced poly curve with `resolution` segments."""
    return g.resample(curve, g.int_math("ADD", resolution, 1))


@node_group("CurveBezierSegment")
def bezier_segment(g: Graph) -> None:
    """Cubic Bezier from `Start` to `End` with the two inner control points `Start Handle`
    and `End Handle` (absolute positions)."""
    start = g.input("Start", "vector", default=(0, 0, 0))
    start_handle = g.input("Start Handle", "vector", default=(0.5, 0, 0))
    end_handle = g.input("End Handle", "vector", default=(0.5, 0, 1))
    end = g.input("End", "vector", default=(0, 0, 1))
    resolution = g.input("Resolution", "int", default=16, min=1, max=256)
    bezier = g.node("GeometryNodeCurvePrimitiveBezierSegment", {
        "Resolution": resolution, "Start": start, "Start Handle": start_handle,
        "End Handle": end_handle, "End": end,
    }, mode="POSITION")
    g.output("Curve", "geometry", _poly(g, bezier, resolution))


@node_group("CurveQuadraticCartesian")
def quadratic_cartesian(g: Graph) -> None:
    """Quadratic Bezier from `Start` to `End` whose middle control point is the chord's
    midpoint moved by `Offset` (a Cartesian vector)."""
    start = g.input("Start", "vector", default=(0, 0, 0))
    end = g.input("End", "vector", default=(0, 0, 1))
    offset = g.input("Offset", "vector", default=(0.3, 0, 0))
    resolution = g.input("Resolution", "int", default=16, min=1, max=256)
    middle = g.vmath("ADD", g.vmath("SCALE", g.vmath("ADD", start, end), 0.5), offset)
    curve = g.node("GeometryNodeCurveQuadraticBezier", {
        "Resolution": resolution, "Start": start, "Middle": middle, "End": end,
    })
    g.output("Curve", "geometry", _poly(g, curve, resolution))


@node_group("CurveQuadraticPolar")
def quadratic_polar(g: Graph) -> None:
    """Quadratic Bezier from `Start` to `End` whose middle control point sits at polar
    coordinates (`Distance`, `Angle`) about the chord's midpoint, in the plane that holds
    the chord and the Y axis' normal: angle 0 bends towards +X for an upward chord,
    +90 degrees pushes the control point along the chord towards `End`."""
    start = g.input("Start", "vector", default=(0, 0, 0))
    end = g.input("End", "vector", default=(0, 0, 1))
    angle = g.input("Angle", "float", default=0.0, min=-math.pi, max=math.pi)
    distance = g.input("Distance", "float", default=0.3, min=0.0)
    resolution = g.input("Resolution", "int", default=16, min=1, max=256)
    chord = g.vmath("NORMALIZE", g.vmath("SUBTRACT", end, start))
    across = g.vmath("NORMALIZE", g.vmath("CROSS_PRODUCT", _UP, chord))
    direction = g.vmath("ADD", g.vmath("SCALE", across, g.math("COSINE", angle)),
                        g.vmath("SCALE", chord, g.math("SINE", angle)))
    midpoint = g.vmath("SCALE", g.vmath("ADD", start, end), 0.5)
    middle = g.vmath("ADD", midpoint, g.vmath("SCALE", direction, distance))
    curve = g.node("GeometryNodeCurveQuadraticBezier", {
        "Resolution": resolution, "Start": start, "Middle": middle, "End": end,
    })
    g.output("Curve", "geometry", _poly(g, curve, resolution))


@node_group("CurveArc")
def arc(g: Graph) -> None:
    """Circular arc in the XY plane about `Center`: `Radius`, `Start Angle`, `Sweep Angle`
    (radians, counter-clockwise seen from +Z)."""
    center = g.input("Center", "vector", default=(0, 0, 0))
    radius = g.input("Radius", "float", default=1.0, min=0.0)
    start_angle = g.input("Start Angle", "float", default=0.0)
    sweep = g.input("Sweep Angle", "float", default=math.pi, min=-2 * math.pi,
                    max=2 * math.pi)
    resolution = g.input("Resolution", "int", default=16, min=2, max=256)
    curve = g.node("GeometryNodeCurveArc", {
        "Resolution": resolution, "Radius": radius, "Start Angle": start_angle,
        "Sweep Angle": sweep,
    }, mode="RADIUS")
    g.output("Curve", "geometry", g.transform(curve, translation=center))


@node_group("CurveHandle")
def handle(g: Graph) -> None:
    """A handle: a curve from the point at `Start` to the point at `End` (fractions of the
    length) of `Curve`, bulging out to +X so that it clears `Curve`.

    `Curve` is a planar curve in the XZ plane whose outside is +X (a body's silhouette).
    The handle leaves and meets the curve horizontally; its two inner control points sit
    `Reach` beyond the widest point of `Curve` between the two attachments, so the handle
    never cuts back into it. `Peak` (0..1) moves the bulge from the start towards the end.
    `Inset` sinks both ends that far into the body (along -X) so that they overlap it.
    """
    curve = g.input("Curve", "geometry")
    start_factor = g.input("Start", "float", default=0.25, min=0.0, max=1.0)
    end_factor = g.input("End", "float", default=0.75, min=0.0, max=1.0)
    reach = g.input("Reach", "float", default=0.3, min=0.0)
    peak = g.input("Peak", "float", default=0.5, min=0.0, max=1.0)
    inset = g.input("Inset", "float", default=0.0, min=0.0)
    resolution = g.input("Resolution", "int", default=16, min=1, max=256)

    start = _sample_position(g, curve, start_factor)
    end = _sample_position(g, curve, end_factor)
    between = g.node("GeometryNodeTrimCurve", {
        "Curve": curve, "Start": g.min(start_factor, end_factor),
        "End": g.max(start_factor, end_factor),
    }, mode="FACTOR")
    out_x = g.bounding_box(between)["Max"].x + reach
    # the bulge's control heights: 0.3 / 0.7 of the way for a centred peak
    low = g.lerp(start.z, end.z, peak * 0.6)
    high = g.lerp(start.z, end.z, 0.4 + peak * 0.6)
    sunk = g.vec(-inset, 0.0, 0.0)
    bezier = bezier_segment(g, start=start + sunk, start_handle=g.vec(out_x, start.y, low),
                            end_handle=g.vec(out_x, end.y, high), end=end + sunk,
                            resolution=resolution)
    aligned = align_curve_to_start_point(g, curve=bezier["Curve"], point=start)
    g.output("Curve", "geometry", aligned["Curve"])
    g.output("Start Position", "vector", start)
    g.output("End Position", "vector", end)


def _sample_position(g: Graph, curve, factor):
    return g.node("GeometryNodeSampleCurve", {"Curves": curve, "Factor": factor},
                  mode="FACTOR", use_all_curves=False)["Position"]


# -- fixed-end paths of furniture frames ---------------------------------------------------

def _flat(g: Graph, vector):
    """(x, y, 0) of a vector."""
    return g.vec(vector.x, vector.y, 0.0)


def _vertical_end_offset(g: Graph, fixed, other, curvature):
    """QuadraticCartesian offset that puts the middle control point above/below `fixed`
    (curvature 1) or on the chord (curvature 0): the path then leaves `fixed` vertically."""
    return _flat(g, fixed - other) * (curvature * 0.5)


def _fixed_inputs(g: Graph, first: str, second: str, defaults):
    a = g.input(first, "vector", default=defaults[0])
    b = g.input(second, "vector", default=defaults[1])
    curvature = g.input("Curvature", "float", default=1.0, min=0.0, max=1.0)
    resolution = g.input("Resolution", "int", default=12, min=1, max=256)
    return a, b, curvature, resolution


def _vertical_at_start(g: Graph, first: str, second: str, defaults) -> None:
    """The body of CurveFixedTop / CurveFixedBottom: a quadratic path from the input `first`
    to `second` that leaves `first` vertically at `Curvature` 1."""
    start, end, curvature, resolution = _fixed_inputs(g, first, second, defaults)
    curve = quadratic_cartesian(g, start=start, end=end, resolution=resolution,
                                offset=_vertical_end_offset(g, start, end, curvature))
    g.output("Curve", "geometry", curve["Curve"])


@node_group("CurveFixedTop")
def fixed_top(g: Graph) -> None:
    """Path from `Top` down to `Bottom`; with `Curvature` 1 it leaves `Top` vertically and
    bends out towards `Bottom` (a splayed leg), with 0 it is the straight chord."""
    _vertical_at_start(g, "Top", "Bottom", ((0, 0, 1), (0.2, 0, 0)))


@node_group("CurveFixedBottom")
def fixed_bottom(g: Graph) -> None:
    """Path from `Bottom` up to `Top`; with `Curvature` 1 it rises vertically from `Bottom`
    and bends over towards `Top`, with 0 it is the straight chord."""
    _vertical_at_start(g, "Bottom", "Top", ((0, 0, 0), (0, 0.2, 1)))


@node_group("CurveFixedMiddle")
def fixed_middle(g: Graph) -> None:
    """Cubic path from `Start` to `End` through the chord's midpoint; `Curvature` turns both
    ends vertical (an S-bend between two offset points), 0 gives the straight chord."""
    start, end, curvature, resolution = _fixed_inputs(g, "Start", "End",
                                                      ((0, 0, 0), (0.2, 0, 1)))
    third = (end - start) * (1.0 / 3.0)
    rise = g.vec(0.0, 0.0, third.z)
    start_handle = start + (rise + _flat(g, third) * (1.0 - curvature))
    end_handle = end - (rise + _flat(g, third) * (1.0 - curvature))
    curve = bezier_segment(g, start=start, start_handle=start_handle, end_handle=end_handle,
                           end=end, resolution=resolution)
    g.output("Curve", "geometry", curve["Curve"])
