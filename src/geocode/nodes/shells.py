"""Shells: thin-walled vessels (a lamp shade, a cup) swept from a profile.

A shell is a triplet whose sweep keeps one cap and loses the other: closed where the path
ends, open where it starts, then given a wall by Solidify.
"""

from __future__ import annotations

from geocode.nodes.attachment import sample_curve
from geocode.nodes.graph import Graph
from geocode.nodes.group import node_group
from geocode.nodes.styles import solidify, sweep

# Curve to Mesh makes the side of a sweep from quads and each cap from one n-gon of the
# profile's points (a RectangleFillet has at least 12)
_SIDE_CORNERS = 4


@node_group("StyleShell")
def shell(g: Graph) -> None:
    """Sweep `Profile Curve` along `Curve` scaled by the field `Scale`, open at the path's
    start and closed at its end, with a wall of `Thickness` (StyleSolidify). The profile
    needs more than four points (a RectangleFillet has)."""
    curve = g.input("Curve", "geometry")
    profile = g.input("Profile Curve", "geometry")
    scale = g.input("Scale", "float", default=1.0)
    thickness = g.input("Thickness", "float", default=0.01, min=0.0)
    label = g.input("Label", "int", default=0, min=0)
    closed = sweep(g, curve=curve, profile_curve=profile, scale=scale, fill_caps=True,
                   label=label)["Mesh"]
    start, end = (sample_curve(g, curve=curve, factor=f)["Position"] for f in (0.0, 1.0))
    # a face's position is its centre: the start cap is the n-gon nearer the path's start
    corners = g.node("GeometryNodeInputMeshFaceNeighbors")["Vertex Count"]
    is_start_cap = (corners > _SIDE_CORNERS) & (
        g.distance(g.position(), start) < g.distance(g.position(), end))
    opened = g.delete_faces(closed, is_start_cap)
    g.output("Mesh", "geometry", solidify(g, mesh=opened, thickness=thickness)["Mesh"])
