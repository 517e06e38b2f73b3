"""Profile curves: closed planar curves that a sweep carries along a path."""

from __future__ import annotations

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group

# The fillet never reaches exactly half the side: coincident points would make
# zero-area faces in every sweep that uses the profile.
_MAX_ROUNDNESS = 0.995
# ... nor exactly zero: a zero radius drops the fillet points and changes the topology.
_MIN_ROUNDNESS = 1e-3


@node_group("ProfileRectangleFillet")
def rectangle_fillet(g: Graph) -> None:
    """Closed rectangle in the XY plane, centred at the origin, whose corners are rounded
    by `Roundness` (0 = sharp rectangle, 1 = fully round: a circle when Width == Height).

    The point count is the same for every roundness (4 corners x (Resolution + 2) points),
    so sweeps keep their topology while the profile morphs.
    """
    width = g.input("Width", "float", default=2.0, min=0.0)
    height = g.input("Height", "float", default=2.0, min=0.0)
    roundness = g.input("Roundness", "float", default=0.0, min=0.0, max=1.0)
    resolution = g.input("Resolution", "int", default=6, min=1, max=64)
    rectangle = g.node("GeometryNodeCurvePrimitiveQuadrilateral",
                       {"Width": width, "Height": height}, mode="RECTANGLE")
    clamped = g.clamp(roundness, _MIN_ROUNDNESS, _MAX_ROUNDNESS)
    radius = clamped * (g.min(width, height) * 0.5)
    fillet = g.node("GeometryNodeFilletCurve", {
        "Curve": rectangle, "Radius": radius, "Limit Radius": True, "Mode": "Poly",
        "Count": resolution,
    })
    g.output("Curve", "geometry", fillet)
