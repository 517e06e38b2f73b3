"""The table program (38 parameters: 7 discrete, 31 continuous).

Layout: x = width, y = depth, z = up. Structure (every part touches the rest for every
parameter combination):
- top: MeshSeat, a slab whose outline morphs from a rectangle to a round top; its edges
  round off over at most half its thickness (`top_bevel`), so it stays a flat slab at any
  size; its `Corner` (the middle of the rounded corner of the outline) is the anchor of the
  legs, so a rounder top pulls them inwards and they stay under it. `top_cut` folds a share
  of the back half onto a straight edge: a round top becomes a half-round (demilune) one,
  re-centred, its mirrored legs still under it. Proportions span low
  coffee tables, tall narrow side tables and long dining tables;
- `leg_style` 0, four legs (MeshLeg: straight or curved, tapered, square to round, splayed)
  hang from under the corners, starting inside the slab, so raising the top moves them with
  it; they are built for the +x +y corner and mirrored in x and y (never crossing on a
  small top);
- `leg_style` 1, X-frame ends: under each end two straight bars cross in an X from the
  floor (splayed out in y) up into the slab, and a tie bar along x joins the crossings;
- `leg_style` 2, trestle ends: under each end a post stands on a foot bar that lies on the
  floor along y, and a tie bar along x joins the posts low down;
- aprons: bars (MeshStraightFrame) under the top from leg to leg, reaching up into the slab,
  set from flush with the legs' outer faces to flush with their inner faces (under end
  frames they are the cleats along y and the rails along x);
- with four legs, stretchers (none, H or X bars) and a lower shelf (MeshSeat) attach to the
  legs by curve sampling (SampleCurve): at a share of each leg's length, measured from the
  foot, on the leg's own axis, so they follow the legs' curvature and splay;
- or a pedestal: a column whose silhouette is a Bezier profile (StyleBezierSegment) on
  radial feet (MeshQuadraticCartesian, arched by their curvature) or on a round base plate;
- the table is grounded so that its lowest point lies on z = 0.
Each piece is a named node group in the .blend (`g.group`). Selectors reach the geometry only
through Switch / Index Switch nodes, so visibility rules are inferred from the graph.
"""

from __future__ import annotations

import math

from geocode.nodes import (
    Graph,
    bezier_segment_style,
    leg_mesh,
    mirror,
    quadratic_cartesian_mesh,
    radial,
    rectangle_fillet,
    sample_curve,
    seat,
    straight_frame,
)

# labels (segmentation)
TOP, LEGS, APRONS, STRETCHERS, SHELF, COLUMN, FEET, BASE_PLATE = range(1, 9)

LEG_INSET = 1.2          # legs sit at least this many radii inside the top's corner
LEG_GAP = 1.5            # ... and at least this many radii from the middle planes
TIE = 0.75               # half-width of an end frame's tie bar (share of a leg's)
TRESTLE_TIE = 0.3        # height of the trestles' tie bar (share of the posts' height)
SINK = 0.5               # parts attached under a slab start this share of it inside it
UP = (0.0, 0.0, 1.0)     # bars keep their profile's X vertical


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    # top
    add("top_height", "float", 0.75, 0.4, 0.9, "height of the top's upper face")
    add("top_width", "float", 1.2, 0.4, 2.0, "width of the top (x)")
    add("top_depth", "float", 0.8, 0.25, 1.2, "depth of the top (y)")
    add("top_thickness", "float", 0.04, 0.015, 0.1, "thickness of the top")
    add("top_roundness", "float", 0.0, 0.0, 1.0, "top outline: 0 rectangle, 1 round")
    add("top_bevel", "float", 0.5, 0.0, 1.0, "edge rounding (share of half the thickness)")
    add("top_cut", "float", 0.0, 0.0, 1.0, "back cut straight: 1 halves a round top (a D)")
    # legs
    add("pedestal", "bool", False, 0, 1, "a central pedestal instead of legs")
    add("leg_style", "int", 0, 0, 2, "legs: 0 four legs, 1 X-frame ends, 2 trestle ends")
    add("leg_thickness", "float", 0.03, 0.01, 0.05, "half-width of a leg at its top")
    add("leg_taper", "float", 0.8, 0.5, 1.2, "foot width / top width of a leg")
    add("leg_curvature", "float", 0.0, 0.0, 1.0, "legs: 0 straight, 1 vertical at the top")
    add("leg_splay", "float", 0.02, 0.0, 0.1, "how far the feet spread outwards")
    add("leg_bevel", "float", 0.0, 0.0, 1.0, "leg profile: 0 square, 1 round")
    add("leg_inset", "float", 0.05, 0.0, 0.3, "legs moved in from the corners (share)")
    # aprons, stretchers and shelf between the legs
    add("aprons", "bool", True, 0, 1, "bars under the top from leg to leg")
    add("apron_height", "float", 0.08, 0.04, 0.15, "height of the aprons below the top")
    add("apron_thickness", "float", 0.02, 0.01, 0.03, "thickness of an apron")
    add("apron_inset", "float", 0.5, 0.0, 1.0, "aprons: 0 flush outside, 1 flush inside")
    add("stretchers", "int", 0, 0, 2, "bars between the legs: 0 none, 1 H, 2 X")
    add("stretcher_height", "float", 0.25, 0.1, 0.45, "stretchers on the legs (share from foot)")
    add("stretcher_thickness", "float", 0.012, 0.008, 0.02, "half-width of a stretcher")
    add("stretcher_roundness", "float", 1.0, 0.0, 1.0, "stretcher profile: square to round")
    add("shelf", "bool", False, 0, 1, "a lower shelf between the legs")
    add("shelf_height", "float", 0.2, 0.1, 0.35, "shelf on the legs (share from foot)")
    add("shelf_thickness", "float", 0.02, 0.015, 0.04, "thickness of the shelf")
    # pedestal
    add("base_plate", "bool", False, 0, 1, "pedestal on a round plate instead of feet")
    add("column_top_radius", "float", 0.05, 0.03, 0.1, "column Bezier profile: top")
    add("column_top_handle", "float", 0.05, 0.02, 0.12, "column Bezier profile: upper handle")
    add("column_bottom_handle", "float", 0.06, 0.02, 0.12, "column Bezier profile: lower handle")
    add("column_bottom_radius", "float", 0.08, 0.04, 0.12, "column Bezier profile: foot")
    add("column_roundness", "float", 1.0, 0.0, 1.0, "column profile: 0 square, 1 round")
    add("foot_count", "int", 4, 3, 6, "number of feet")
    add("foot_spread", "float", 0.6, 0.35, 0.9, "reach of feet or plate (share of the top)")
    add("foot_curvature", "float", 0.5, 0.0, 1.0, "feet: 0 straight, 1 arched")
    add("foot_thickness", "float", 0.02, 0.012, 0.035, "half-width of a foot")
    add("foot_rise", "float", 0.1, 0.05, 0.2, "height of the column's end above the floor")
    add("base_thickness", "float", 0.03, 0.015, 0.06, "thickness of the base plate")
    return p


class _Table:
    """Quantities shared between parts, so that every attached part follows edits: the
    top's corner and heights, and the reach of a pedestal's feet or plate."""

    def __init__(self, g: Graph, p: dict):
        self.g, self.p = g, p
        # MeshSeat's Bevel is a share of the outline's half-size: the rounding's reach,
        # at most half the slab's thickness, over the longer half-size, so the top stays a
        # flat slab and only its edges round off
        # the outline is made deep enough that cutting `top_cut` of its back half off
        # leaves `top_depth`; the cut folds the back onto a straight edge (a half-round
        # from a round outline) and the whole top moves forward to stay centred
        cut = p["top_cut"]
        full = g.named("full depth", p["top_depth"] * 2.0 / (2.0 - cut))
        bevel = p["top_bevel"] * p["top_thickness"] / g.max(p["top_width"], full)
        top = seat(g, width=p["top_width"], depth=full, roundness=p["top_roundness"],
                   top=p["top_height"], thickness=p["top_thickness"], bevel=bevel, label=TOP)
        back, shift = full * ((cut - 1.0) * 0.5), full * (cut * 0.25)
        at = g.position()
        self.mesh = g.set_position(top["Mesh"],
                                   position=g.vec(at.x, g.max(at.y, back) - shift, at.z))
        # the front corner, moved with the top; mirrored, it lies inside the straight back
        corner = top["Corner"]
        self.corner = g.named("corner", g.vec(corner.x, corner.y - shift, 0.0))
        # attachments start inside the slab: halfway down from its top
        self.inside = g.named("inside", p["top_height"] - p["top_thickness"] * SINK)
        self.underside = g.named("underside", p["top_height"] - p["top_thickness"])
        self.reach = g.named("reach", g.min(p["top_width"], p["top_depth"]) * 0.5
                             * p["foot_spread"])


# -- four legs ---------------------------------------------------------------------------------

class _Legs:
    """The +x +y leg, from under the top's corner to its foot (the other three are its
    mirror images), and its axis, on which stretchers and shelf are attached."""

    def __init__(self, t: _Table):
        g, p = t.g, t.p
        self.t = t
        inset = p["leg_thickness"] * LEG_INSET
        # on a small top the legs stop at a leg's width apart rather than cross
        least = p["leg_thickness"] * LEG_GAP
        self.x = g.named("leg x", g.max(t.corner.x * (1.0 - p["leg_inset"]) - inset, least))
        self.y = g.named("leg y", g.max(t.corner.y * (1.0 - p["leg_inset"]) - inset, least))
        splay = p["leg_splay"]
        one = leg_mesh(g, top=g.vec(self.x, self.y, t.inside),
                       bottom=g.vec(self.x + splay, self.y + splay, 0.0),
                       curvature=p["leg_curvature"], top_radius=p["leg_thickness"],
                       bottom_radius=p["leg_thickness"] * p["leg_taper"],
                       roundness=p["leg_bevel"], label=LEGS)
        self.axis = g.named("leg axis", one["Curve"])
        self.mesh = mirror(g, geometry=mirror(g, geometry=one["Mesh"], axis=0)["Geometry"],
                           axis=1)["Geometry"]

    def at(self, share):
        """The point of the +x +y leg's axis at `share` of its length from the foot."""
        return sample_curve(self.t.g, curve=self.axis, factor=1.0 - share)["Position"]


def _bar(g: Graph, start, end, width, depth, roundness, label):
    return straight_frame(g, start=start, end=end, width=width, depth=depth,
                          roundness=roundness, axis=UP, label=label)["Mesh"]


def _aprons(legs: _Legs):
    """Bars from leg to leg along each side, from inside the slab down by `apron_height`;
    `apron_inset` moves them from the legs' outer faces to their inner faces."""
    t = legs.t
    g, p = t.g, t.p
    bottom = t.underside - p["apron_height"]
    height = t.inside - bottom
    z = (t.inside + bottom) * 0.5
    # from the leg's axis to the apron's middle: the outer faces flush at inset 0
    shift = (p["leg_thickness"] - p["apron_thickness"] * 0.5) * (1.0 - p["apron_inset"] * 2.0)
    x, y = legs.x + shift, legs.y + shift
    side = _bar(g, g.vec(x, -legs.y, z), g.vec(x, legs.y, z), height, p["apron_thickness"],
                0.0, APRONS)
    end = _bar(g, g.vec(-legs.x, y, z), g.vec(legs.x, y, z), height, p["apron_thickness"],
               0.0, APRONS)
    aprons = g.join([mirror(g, geometry=side, axis=0)["Geometry"],
                     mirror(g, geometry=end, axis=1)["Geometry"]])
    return g.when(p["aprons"], aprons)


def _stretchers(legs: _Legs):
    """None, H (a bar along each side and one across their middles) or X (two diagonals),
    between points sampled on the legs' axes."""
    t = legs.t
    g, p = t.g, t.p
    point = legs.at(p["stretcher_height"])
    x, y, z = point.x, point.y, point.z
    size = p["stretcher_thickness"] * 2.0

    def bar(start, end):
        return _bar(g, start, end, size, size, p["stretcher_roundness"], STRETCHERS)

    side = mirror(g, geometry=bar(g.vec(x, -y, z), point), axis=0)["Geometry"]
    h_shape = g.join([side, bar(g.vec(-x, 0.0, z), g.vec(x, 0.0, z))])
    x_shape = mirror(g, geometry=bar(point, g.vec(-x, -y, z)), axis=0)["Geometry"]
    return g.index_switch(p["stretchers"], [None, h_shape, x_shape])


def _shelf(legs: _Legs):
    """A slab whose corners lie on the legs' axes, at a point sampled on them."""
    t = legs.t
    g, p = t.g, t.p
    point = legs.at(p["shelf_height"])
    slab = seat(g, width=point.x * 2.0, depth=point.y * 2.0, roundness=0.0,
                top=point.z + p["shelf_thickness"] * 0.5, thickness=p["shelf_thickness"],
                bevel=0.0, label=SHELF)["Mesh"]
    return g.when(p["shelf"], slab)


# -- end frames: X-frames or trestles under the two ends ------------------------------------------

def _tie(legs: _Legs, z):
    """The bar along x that joins the two end frames at height `z`, on the middle plane."""
    g, p = legs.t.g, legs.t.p
    size = p["leg_thickness"] * (TIE * 2.0)
    return _bar(g, g.vec(-legs.x, 0.0, z), g.vec(legs.x, 0.0, z), size, size, p["leg_bevel"],
                STRETCHERS)


def _x_frames(legs: _Legs):
    """Under each end (x = +-leg x) two straight bars cross in an X in the y-z plane, each
    from a foot at y = -+(leg y + splay) on the floor up into the slab at y = +-leg y; a tie
    bar along x joins the two crossings. Each bar's ends are lifted by its half-width times
    the sine of its slope, so its corners stay between the floor and the top's upper face."""
    t = legs.t
    g, p = t.g, t.p
    top_y, foot_y = legs.y, legs.y + p["leg_splay"]
    run = top_y + foot_y
    sine = run / g.sqrt(run * run + t.inside * t.inside)
    top_z = t.inside - p["leg_thickness"] * sine
    foot_z = p["leg_thickness"] * p["leg_taper"] * sine
    one = leg_mesh(g, top=g.vec(legs.x, top_y, top_z), bottom=g.vec(legs.x, -foot_y, foot_z),
                   curvature=0.0, top_radius=p["leg_thickness"],
                   bottom_radius=p["leg_thickness"] * p["leg_taper"], roundness=p["leg_bevel"],
                   label=LEGS)["Mesh"]
    cross = mirror(g, geometry=one, axis=1)["Geometry"]
    # where the bar's axis passes y = 0
    crossing = foot_z + (top_z - foot_z) * (foot_y / run)
    return g.join([mirror(g, geometry=cross, axis=0)["Geometry"], _tie(legs, crossing)])


def _trestles(legs: _Legs):
    """Under each end a post (x = +-leg x, y = 0) from inside the slab down into a foot bar
    that lies on the floor along y, from -(leg y + splay) to leg y + splay; a tie bar along
    x joins the posts low down."""
    t = legs.t
    g, p = t.g, t.p
    size = p["leg_thickness"] * 2.0
    foot_y = legs.y + p["leg_splay"]
    post = leg_mesh(g, top=g.vec(legs.x, 0.0, t.inside), bottom=g.vec(legs.x, 0.0, size * 0.5),
                    curvature=0.0, top_radius=p["leg_thickness"],
                    bottom_radius=p["leg_thickness"] * p["leg_taper"], roundness=p["leg_bevel"],
                    label=LEGS)["Mesh"]
    foot = _bar(g, g.vec(legs.x, -foot_y, size * 0.5), g.vec(legs.x, foot_y, size * 0.5), size,
                size, 0.0, FEET)
    ends = mirror(g, geometry=g.join([post, foot]), axis=0)["Geometry"]
    tie_z = size + (t.inside - size) * TRESTLE_TIE
    return g.join([ends, _tie(legs, tie_z)])


# -- pedestal ----------------------------------------------------------------------------------

def _column(t: _Table):
    """A column from inside the top down to its end: above the floor on feet, or inside the
    base plate; its silhouette is a Bezier profile."""
    g, p = t.g, t.p
    end = g.when(p["base_plate"], p["base_thickness"] * SINK, p["foot_rise"])
    profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=p["column_roundness"],
                               resolution=3)["Curve"]
    return bezier_segment_style(
        g, curve=g.line(g.vec(0.0, 0.0, t.inside), g.vec(0.0, 0.0, end), count=12),
        profile_curve=profile, start=p["column_top_radius"],
        start_handle=p["column_top_handle"], end_handle=p["column_bottom_handle"],
        end=p["column_bottom_radius"], fill_caps=True, label=COLUMN)["Mesh"]


def _feet(t: _Table):
    """Radial feet from the column's axis, just above its end, out to the floor; curvature
    1 lifts the middle control point over the toe, so the foot meets the floor vertically."""
    g, p = t.g, t.p
    hub = g.vec(0.0, 0.0, p["foot_rise"] + p["foot_thickness"])
    toe = g.vec(t.reach, 0.0, 0.0)
    one = quadratic_cartesian_mesh(g, start=hub, end=toe,
                                   offset=(toe + hub) * (p["foot_curvature"] * 0.5),
                                   radius=p["foot_thickness"], roundness=1.0,
                                   axis=(0.0, 1.0, 0.0), label=FEET)["Mesh"]
    return radial(g, geometry=one, count=p["foot_count"], radius=0.0,
                  start_angle=math.pi / 2)["Geometry"]


def _base_plate(t: _Table):
    """A round plate on the floor, as wide as the feet would reach, its upper edge rounded
    over half its thickness."""
    g, p = t.g, t.p
    return seat(g, width=t.reach * 2.0, depth=t.reach * 2.0, roundness=1.0,
                top=p["base_thickness"], thickness=p["base_thickness"],
                bevel=p["base_thickness"] * 0.5 / t.reach, label=BASE_PLATE)["Mesh"]


# -- assembly ----------------------------------------------------------------------------------

def build(g: Graph) -> None:
    with g.frame("Parameters"):
        p = _parameters(g)
    with g.group("Top"):
        t = _Table(g, p)
    with g.group("Legs"):
        legs = _Legs(t)
    with g.group("Aprons"):
        aprons = _aprons(legs)
    with g.group("Stretchers"):
        stretchers = _stretchers(legs)
    with g.group("Shelf"):
        shelf = _shelf(legs)
    with g.group("X Frames"):
        x_frames = _x_frames(legs)
    with g.group("Trestles"):
        trestles = _trestles(legs)
    with g.group("Column"):
        column = _column(t)
    with g.group("Feet"):
        feet = _feet(t)
    with g.group("Base Plate"):
        plate = _base_plate(t)
    with g.frame("Assembly"):
        four_legs = g.join([legs.mesh, stretchers, shelf])
        under = g.join([g.index_switch(p["leg_style"], [four_legs, x_frames, trestles]), aprons])
        pedestal = g.join([column, g.when(p["base_plate"], plate, feet)])
        table = g.join([t.mesh, g.when(p["pedestal"], pedestal, under)])
        # whatever the parts, the lowest point rests on z = 0
        g.output("Geometry", "geometry", g.ground(table))
