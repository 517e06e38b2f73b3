"""Profile curves: closed planar curves that a sweep carries along a path."""

from __future__ import annotations

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group

# Roundness is clamped to this range: a fillet of exactly half the side would make coincident
# points (zero-area faces in every sweep of the profile), and a zero radius drops the fillet
# points and changes the topology.
ROUNDNESS_LIMITS = (1e-3, 0.995)


def corner_radius(g: Graph, roundness, width, height):
    """The fillet radius of a `width` x `height` rectangle's corners at `roundness` (clamped to
    ROUNDNESS_LIMITS): `roundness` times half the shorter side."""
    low, high = ROUNDNESS_LIMITS
    return g.clamp(roundness, low, high) * (g.min(width, height) * 0.5)


@node_group("ProfileRectangleFillet")
def rectangle_fillet(g: Graph) -> None:
    """Closed rectangle in the XY plane, centred at the origin, whose corners are rounded
    by `Roundness` (0 = sharp rectangle, 1 = fully round: a circle when Width == Height).

    The point count is the same for every roundness (4 corners x (Resolution + 1) points,
    and `Cuts` more evenly along each side), so sweeps keep their topology while the profile
    morphs; the cuts let a sweep of a wide profile (a panel) bend across.
    """
    width = g.input("Width", "float", default=2.0, min=0.0)
    height = g.input("Height", "float", default=2.0, min=0.0)
    roundness = g.input("Roundness", "float", default=0.0, min=0.0, max=1.0)
    resolution = g.input("Resolution", "int", default=6, min=1, max=64)
    cuts = g.input("Cuts", "int", default=0, min=0, max=64)
    rectangle = g.node("GeometryNodeCurvePrimitiveQuadrilateral",
                       {"Width": width, "Height": height}, mode="RECTANGLE")
    radius = corner_radius(g, roundness, width, height)
    fillet = g.node("GeometryNodeFilletCurve", {
        "Curve": rectangle, "Radius": radius, "Limit Radius": True, "Mode": "Poly",
        "Count": resolution,
    })
    # the last point of each corner starts a side
    side = g.compare("EQUAL", g.int_math("MODULO", g.index(), resolution + 1), resolution)
    sides = g.node("GeometryNodeSubdivideCurve", {"Curve": fillet, "Cuts": side * cuts})
    g.output("Curve", "geometry", sides)
