"""Surfaces: Loft, a surface between two curves (it fills a shape between its two sides)."""

from __future__ import annotations

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group


@node_group("Loft")
def loft(g: Graph) -> None:
    """A ruled surface between `Curve A` and `Curve B`: `Rows` x `Columns` quads whose vertex
    at (u, v) lies at lerp(A(f), B(f), s), f = lerp(`Start`, `End`, v) a fraction of each
    curve's length and s = lerp(`Span Start`, `Span End`, u) a fraction of the way from A to
    B. `Inset` then moves the two side edges that far towards each other (a gap between
    neighbouring cells). Faces face (B - A) x (the curves' direction): a loft from a left to
    a right side that both rise faces the viewer at -Y."""
    curve_a = g.input("Curve A", "geometry")
    curve_b = g.input("Curve B", "geometry")
    start = g.input("Start", "float", default=0.0, min=0.0, max=1.0)
    end = g.input("End", "float", default=1.0, min=0.0, max=1.0)
    span_start = g.input("Span Start", "float", default=0.0)
    span_end = g.input("Span End", "float", default=1.0)
    inset = g.input("Inset", "float", default=0.0)
    rows = g.input("Rows", "int", default=8, min=1, max=256)
    columns = g.input("Columns", "int", default=1, min=1, max=256)
    grid = g.node("GeometryNodeMeshGrid", {"Size X": 1.0, "Size Y": 1.0,
                                           "Vertices X": columns + 1, "Vertices Y": rows + 1})
    u, v = g.position().x + 0.5, g.position().y + 0.5  # on the unit grid
    factor = g.lerp(start, end, v)
    a, b = (g.node("GeometryNodeSampleCurve", {"Curves": curve, "Factor": factor},
                   mode="FACTOR", use_all_curves=False)["Position"]
            for curve in (curve_a, curve_b))
    across = b - a
    on_span = a + across * g.lerp(span_start, span_end, u)
    inward = g.normalize(across) * (inset * (1.0 - 2.0 * u))
    g.output("Mesh", "geometry", g.set_position(grid, position=on_span + inward))
