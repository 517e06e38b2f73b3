"""Frame curves and the styles of furniture parts (SPEC §1 catalogue).

Curves (open paths, a fixed number of points so sweeps keep their topology):
- FixedTop / FixedBottom: a quadratic path between two points that leaves one end
  vertically when `Curvature` is 1 (a straight chord at 0). A leg hangs from a FixedTop
  (fixed under the seat), a support stands on a FixedBottom (fixed on the seat).
- FixedMiddle: a cubic S-path whose ends turn vertical with `Curvature` while its middle
  stays on the chord's midpoint.

Styles (scale of the profile along the path, t = fraction of the path's length); each labels
its faces with `Part`:
- SeatFrame: full size in the middle of the path, rounded in by `Bevel` towards both ends.
- Cushion: a pillow, flat at the bottom and puffed towards the top; `Fill` from a dome (0)
  to a full, box-like pillow (1).
- AlignedBevelXY: the profile's X pinned to a world `Axis` (no twist as the path bends),
  constant size, the end of the path bevelled in by `Bevel`.
- BezierSegment: the scale follows a cubic Bezier of four values over t (a lathe-like
  silhouette: a column that flares at its base).
"""

from __future__ import annotations

from geocode.nodes.curves import bezier_segment, quadratic_cartesian
from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group
from geocode.nodes.utils import align_curve_tilt_to_axis

# the share of the path, at its end, that AlignedBevelXY rounds in
_BEVEL_SPAN = 0.2
# Cushion never shrinks below this share of its profile, so its top cap keeps an area
_CUSHION_TOP = 0.35


def _flat(g: Graph, vector):
    """(x, y, 0) of a vector."""
    xyz = g.separate(vector)
    return g.combine(xyz["X"], xyz["Y"], 0.0)


def _vertical_end_offset(g: Graph, fixed, other, curvature):
    """QuadraticCartesian offset that puts the middle control point above/below `fixed`
    (curvature 1) or on the chord (curvature 0): the path then leaves `fixed` vertically."""
    return g.vmath("SCALE", _flat(g, g.vmath("SUBTRACT", fixed, other)), g.mul(curvature, 0.5))


def _fixed_inputs(g: Graph, first: str, second: str, defaults):
    a = g.input(first, "vector", default=defaults[0])
    b = g.input(second, "vector", default=defaults[1])
    curvature = g.input("Curvature", "float", default=1.0, min=0.0, max=1.0)
    resolution = g.input("Resolution", "int", default=12, min=1, max=256)
    return a, b, curvature, resolution


@node_group("CurveFixedTop")
def fixed_top(g: Graph) -> None:
    """Path from `Top` down to `Bottom`; with `Curvature` 1 it leaves `Top` vertically and
    bends out towards `Bottom` (a splayed leg), with 0 it is the straight chord."""
    top, bottom, curvature, resolution = _fixed_inputs(g, "Top", "Bottom",
                                                       ((0, 0, 1), (0.2, 0, 0)))
    curve = quadratic_cartesian(g, start=top, end=bottom, resolution=resolution,
                                offset=_vertical_end_offset(g, top, bottom, curvature))
    g.output("Curve", "geometry", curve["Curve"])


@node_group("CurveFixedBottom")
def fixed_bottom(g: Graph) -> None:
    """Path from `Bottom` up to `Top`; with `Curvature` 1 it rises vertically from `Bottom`
    and bends over towards `Top`, with 0 it is the straight chord."""
    bottom, top, curvature, resolution = _fixed_inputs(g, "Bottom", "Top",
                                                       ((0, 0, 0), (0, 0.2, 1)))
    curve = quadratic_cartesian(g, start=bottom, end=top, resolution=resolution,
                                offset=_vertical_end_offset(g, bottom, top, curvature))
    g.output("Curve", "geometry", curve["Curve"])


@node_group("CurveFixedMiddle")
def fixed_middle(g: Graph) -> None:
    """Cubic path from `Start` to `End` through the chord's midpoint; `Curvature` turns both
    ends vertical (an S-bend between two offset points), 0 gives the straight chord."""
    start, end, curvature, resolution = _fixed_inputs(g, "Start", "End",
                                                      ((0, 0, 0), (0.2, 0, 1)))
    third = g.vmath("SCALE", g.vmath("SUBTRACT", end, start), 1.0 / 3.0)
    rise = g.combine(0.0, 0.0, g.separate(third)["Z"])
    start_handle = g.vmath("ADD", start, g.vmath("ADD", rise, g.vmath(
        "SCALE", _flat(g, third), g.sub(1.0, curvature))))
    end_handle = g.vmath("SUBTRACT", end, g.vmath("ADD", rise, g.vmath(
        "SCALE", _flat(g, third), g.sub(1.0, curvature))))
    curve = bezier_segment(g, start=start, start_handle=start_handle, end_handle=end_handle,
                           end=end, resolution=resolution)
    g.output("Curve", "geometry", curve["Curve"])


# -- styles -------------------------------------------------------------------------------------

def _style_inputs(g: Graph):
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


@node_group("StyleSeatFrame")
def seat_frame(g: Graph) -> None:
    """Scale 1 - Bevel (1 - sqrt(1 - u^2)), u = |2t - 1|: full size in the middle of the
    path, a quarter-round edge of depth `Bevel` (share of the profile) at both ends."""
    curve, profile, fill_caps, part = _style_inputs(g)
    bevel = g.input("Bevel", "float", default=0.05, min=0.0, max=0.5)
    u = g.math("ABSOLUTE", g.sub(g.mul(g.spline_factor(), 2.0), 1.0))
    rounded = g.sub(1.0, g.math("SQRT", g.maximum(g.sub(1.0, g.mul(u, u)), 0.0)))
    scale = g.sub(1.0, g.mul(bevel, rounded))
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, part))


@node_group("StyleCushion")
def cushion(g: Graph) -> None:
    """Scale max(sqrt(1 - t^k), 0.35), k = 2 + 8 Fill, along a path that rises from the
    cushion's bottom: a flat base whose sides puff in towards the top; `Fill` 0 gives a
    dome, 1 a full pillow with rounded top edges."""
    curve, profile, fill_caps, part = _style_inputs(g)
    fill = g.input("Fill", "float", default=0.5, min=0.0, max=1.0)
    power = g.math("POWER", g.spline_factor(), g.add(2.0, g.mul(fill, 8.0)))
    puff = g.math("SQRT", g.maximum(g.sub(1.0, power), 0.0))
    scale = g.maximum(puff, _CUSHION_TOP)
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, part))


@node_group("StyleAlignedBevelXY")
def aligned_bevel_xy(g: Graph) -> None:
    """The profile's X pinned to the world `Axis` (perpendicular to the path), so a bent
    frame does not twist; constant scale `Radius`, rounded in by `Bevel` (share of the
    profile) over the last fifth of the path (a chamfered top)."""
    curve, profile, fill_caps, part = _style_inputs(g)
    axis = g.input("Axis", "vector", default=(1, 0, 0))
    radius = g.input("Radius", "float", default=1.0, min=0.0)
    bevel = g.input("Bevel", "float", default=0.0, min=0.0, max=0.9)
    aligned = align_curve_tilt_to_axis(g, curve=curve, axis=axis)["Curve"]
    ramp = g.map_range(g.spline_factor(), 1.0 - _BEVEL_SPAN, 1.0, 0.0, 1.0,
                       interpolation="SMOOTHSTEP")
    scale = g.mul(radius, g.sub(1.0, g.mul(bevel, ramp)))
    g.output("Mesh", "geometry", _sweep(g, aligned, profile, scale, fill_caps, part))


@node_group("StyleBezierSegment")
def bezier_segment_style(g: Graph) -> None:
    """Scale B(t) = (1-t)^3 Start + 3(1-t)^2 t Start Handle + 3(1-t) t^2 End Handle
    + t^3 End: a smooth silhouette from `Start` to `End` shaped by the two handles."""
    curve, profile, fill_caps, part = _style_inputs(g)
    values = [g.input(name, "float", default=default, min=0.0)
              for name, default in (("Start", 0.05), ("Start Handle", 0.05),
                                    ("End Handle", 0.1), ("End", 0.2))]
    t = g.spline_factor()
    s = g.sub(1.0, t)
    weights = (g.mul(g.mul(s, s), s), g.mul(3.0, g.mul(g.mul(s, s), t)),
               g.mul(3.0, g.mul(g.mul(s, t), t)), g.mul(g.mul(t, t), t))
    scale = 0.0
    for weight, value in zip(weights, values, strict=True):
        scale = g.add(scale, g.mul(weight, value))
    g.output("Mesh", "geometry", _sweep(g, curve, profile, scale, fill_caps, part))
