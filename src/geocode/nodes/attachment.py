"""Sampling: attachment points on curves, as fractions of their length."""

from __future__ import annotations

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group


@node_group("SampleCurve")
def sample_curve(g: Graph) -> None:
    """The point at `Factor` (fraction of the length, 0 = start, 1 = end) of the first
    spline of `Curve`, with its unit tangent and normal there."""
    curve = g.input("Curve", "geometry")
    factor = g.input("Factor", "float", default=0.5, min=0.0, max=1.0)
    sample = g.node("GeometryNodeSampleCurve", {"Curves": curve, "Factor": factor},
                    mode="FACTOR", use_all_curves=False)
    g.output("Position", "vector", sample["Position"])
    g.output("Tangent", "vector", sample["Tangent"])
    g.output("Normal", "vector", sample["Normal"])


@node_group("SampleCurveArray")
def sample_curve_array(g: Graph) -> None:
    """`Count` points spread at equal distances along `Curve`, between the fractions
    `Start Margin` and 1 - `End Margin` (both ends included; one point sits in the middle).

    Each point carries the attributes `factor`, `tangent` and `normal` of its place on the
    curve, so that parts instanced on the points can follow the curve.
    """
    curve = g.input("Curve", "geometry")
    count = g.input("Count", "int", default=3, min=0, max=1000)
    start = g.input("Start Margin", "float", default=0.0, min=0.0, max=1.0)
    end = g.input("End Margin", "float", default=0.0, min=0.0, max=1.0)
    # i / (n - 1), and 0.5 when n == 1: the comparison adds 0.5 only for a single point
    single = g.compare("EQUAL", count, 1, data_type="INT")
    fraction = (g.index() + single * 0.5) / g.max(count - 1, 1)
    factor = g.lerp(start, 1.0 - end, fraction)
    sample = g.node("GeometryNodeSampleCurve", {"Curves": curve, "Factor": factor},
                    mode="FACTOR", use_all_curves=False)
    points = g.node("GeometryNodePoints", {"Count": count, "Position": sample["Position"]})
    geometry = points.out
    for name, value, data_type in (("factor", factor, "FLOAT"),
                                   ("tangent", sample["Tangent"], "FLOAT_VECTOR"),
                                   ("normal", sample["Normal"], "FLOAT_VECTOR")):
        geometry = g.node("GeometryNodeStoreNamedAttribute", {
            "Geometry": geometry, "Name": name, "Value": value,
        }, data_type=data_type, domain="POINT").out
    g.output("Points", "geometry", geometry)


@node_group("SamplePoints")
def sample_points(g: Graph) -> None:
    """The position of point `Index` of `Points` (clamped to the valid range)."""
    points = g.input("Points", "geometry")
    index = g.input("Index", "int", default=0, min=0)
    sample = g.node("GeometryNodeSampleIndex", {
        "Geometry": points, "Value": g.position(), "Index": index,
    }, data_type="FLOAT_VECTOR", domain="POINT", clamp=True)
    g.output("Position", "vector", sample.out)
