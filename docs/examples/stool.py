"""The stool of docs/guide/programs.md (the tutorial): a round or square seat on three to five
splayed legs, with an optional ring footrest (9 parameters: 3 discrete, 6 continuous).

Layout: z up, the seat centred on the z axis. Every part touches the rest for every
parameter combination:
- seat: MeshSeat, `seat_width` across, its top at `seat_height`;
- legs: straight MeshLegs, radial copies, each from inside the seat slab at 0.6 of the
  seat's half-width (inside the seat at any roundness) down to the floor, the foot spread
  outwards by `leg_splay`;
- footrest: a ring at `footrest_height` (share of the seat height) through the legs' axes.
Labels: seat 1, legs 2, footrest 3.
"""

from __future__ import annotations

import math

from geocode.nodes import Graph, leg_mesh, radial, rail, rectangle_fillet, seat

SEAT, LEGS, FOOTREST = 1, 2, 3
LEG_REACH = 0.6   # legs start at this share of the seat's half-width from the axis


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    add("seat_height", "float", 0.6, 0.45, 0.8, "height of the seat's top")
    add("seat_width", "float", 0.35, 0.28, 0.45, "width of the seat")
    add("seat_thickness", "float", 0.04, 0.025, 0.06, "thickness of the seat")
    add("seat_roundness", "float", 1.0, 0.0, 1.0, "seat outline: 0 square, 1 round")
    add("leg_count", "int", 4, 3, 5, "number of legs")
    add("leg_thickness", "float", 0.02, 0.012, 0.03, "half-width of a leg")
    add("leg_splay", "float", 0.05, 0.0, 0.1, "how far the feet spread outwards")
    add("footrest", "bool", True, 0, 1, "a ring joining the legs")
    add("footrest_height", "float", 0.35, 0.25, 0.5, "height of the ring (share of the seat's)")
    return p


def _legs(g: Graph, p: dict, inside):
    """`leg_count` straight legs from (0.6 seat_width / 2, 0, inside) to the floor, the foot
    `leg_splay` further out; the first at 45 degrees."""
    x = p["seat_width"] * (0.5 * LEG_REACH)
    one = leg_mesh(g, top=g.vec(x, 0.0, inside), bottom=g.vec(x + p["leg_splay"], 0.0, 0.0),
                   curvature=0.0, top_radius=p["leg_thickness"],
                   bottom_radius=p["leg_thickness"], roundness=1.0, label=LEGS)["Mesh"]
    return radial(g, geometry=one, count=p["leg_count"], start_angle=math.pi / 4)["Geometry"]


def _footrest(g: Graph, p: dict, inside):
    """When `footrest`: a ring at z = footrest_height x seat_height whose radius is the legs'
    axis there (the axis runs linearly from the top's x to the foot's), so it passes
    through every leg; its tube is as thick as a leg."""
    height = p["footrest_height"] * p["seat_height"]
    top_x = p["seat_width"] * (0.5 * LEG_REACH)
    radius = top_x + p["leg_splay"] * (1.0 - height / inside)
    circle = rectangle_fillet(g, width=radius * 2.0, height=radius * 2.0, roundness=1.0,
                              resolution=8)["Curve"]
    ring = g.transform(circle, translation=g.vec(0.0, 0.0, height))
    tube = rectangle_fillet(g, width=2.0, height=2.0, roundness=1.0, resolution=2)["Curve"]
    mesh = rail(g, curve=ring, profile_curve=tube, radius=p["leg_thickness"], fill_caps=False,
                label=FOOTREST)["Mesh"]
    return g.when(p["footrest"], mesh)


def build(g: Graph) -> None:
    with g.frame("Parameters"):
        p = _parameters(g)
    with g.group("Seat"):
        top = seat(g, width=p["seat_width"], depth=p["seat_width"],
                   roundness=p["seat_roundness"], top=p["seat_height"],
                   thickness=p["seat_thickness"], bevel=0.1, label=SEAT)["Mesh"]
        # the legs start halfway into the slab, so they stay joined to it at any thickness
        inside = g.named("inside", p["seat_height"] - p["seat_thickness"] * 0.5)
    with g.group("Legs"):
        legs = _legs(g, p, inside)
    with g.group("Footrest"):
        footrest = _footrest(g, p, inside)
    with g.frame("Assembly"):
        g.output("Geometry", "geometry", g.ground(g.join([top, legs, footrest])))
