"""Symmetry: radial copies about the Z axis and mirror copies across a coordinate plane."""

from __future__ import annotations

import math

from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group


@node_group("SymmetryRadial")
def radial(g: Graph) -> None:
    """`Count` copies of `Geometry` about the Z axis, copy k turned by
    `Start Angle` + 2 pi k / Count and moved `Radius` out along its turned +X axis.
    Count 0 gives nothing."""
    geometry = g.input("Geometry", "geometry")
    count = g.input("Count", "int", default=4, min=0, max=64)
    radius = g.input("Radius", "float", default=0.0, min=0.0)
    start_angle = g.input("Start Angle", "float", default=0.0)
    angle = start_angle + g.index() * (2 * math.pi / g.max(count, 1))
    position = g.vec(radius * g.cos(angle), radius * g.sin(angle), 0.0)
    points = g.node("GeometryNodePoints", {"Count": count, "Position": position})
    copies = g.instance_on_points(points, geometry,
                                  rotation=g.euler_to_rotation(g.vec(0.0, 0.0, angle)))
    g.output("Geometry", "geometry", copies)


@node_group("SymmetryMirror")
def mirror(g: Graph) -> None:
    """`Geometry` joined with its mirror image across the plane through the origin normal
    to `Axis` (0 = X, 1 = Y, 2 = Z). Faces of the copy are flipped so that normals still
    point outwards."""
    geometry = g.input("Geometry", "geometry")
    axis = g.input("Axis", "int", default=0, min=0, max=2)
    scale = g.index_switch(axis, [(-1.0, 1.0, 1.0), (1.0, -1.0, 1.0), (1.0, 1.0, -1.0)],
                           data_type="VECTOR")
    mirrored = g.node("GeometryNodeFlipFaces", {"Mesh": g.transform(geometry, scale=scale)})
    g.output("Geometry", "geometry", g.join([geometry, mirrored]))
