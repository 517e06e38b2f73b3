"""The cabinet program (33 parameters: 8 discrete, 25 continuous): the paper's example of the
blocks carried to a new domain, a cabinet whose drawers follow the frame's profile and whose
handles stay attached (its "structural integrity discussion").

Layout: x = width, y = depth (the fronts at -y), z = up. Structure (every part touches the
rest for every parameter combination):
- body: the right side is a CurveQuadraticCartesian from the bottom corner to the top corner
  (tapered by `top_width`, bowed by `side_curvature`), the left side its mirror image; a Loft
  between the two sides is the front outline, swept back by the depth (StyleSolidify);
- fronts: rows of drawers above rows of doors, built in a repeat zone (one pass per row, a
  nested one per column). Each front is a Loft between the sides moved in by the frame, over
  its row's share of their length, so its outer edges follow the profile at every height;
  it stands out of the body by `front_thickness` and is sunk a little into it. The open
  drawer slides out along -y and a box joins it back into the body;
- handles: a CurveHandle (a bar attached at both ends) or a knob, placed by SampleCurveArray
  on the row's line across its fronts (cell centres) on the front's face, so they move with
  their drawer; door handles are upright, near the door's inner edge;
- top board (optional, overhanging at the front and sides), a plinth or four legs; the body
  stands on them, and the cabinet is grounded so that its lowest point lies on z = 0.
Labels: body 1, top 2, drawers 3, doors 4, handles 5, plinth 6, legs 7.
"""

from __future__ import annotations

import math

from geocode.nodes import (
    Graph,
    Repeat,
    bezier_segment_style,
    handle,
    leg_mesh,
    loft,
    mirror,
    quadratic_cartesian,
    rail,
    rectangle_fillet,
    sample_curve,
    sample_curve_array,
    seat,
    solidify,
)

BODY, TOP, DRAWERS, DOORS, HANDLES, PLINTH, LEGS = range(1, 8)

SIDE_RESOLUTION = 16   # segments of each side curve (and rows of the body's loft)
FRONT_ROWS = 6         # loft rows of a front: enough to follow a bowed side
SINK = 0.004           # how far fronts, boxes, boards and handles reach into what holds them
BOX_MARGIN = 0.08      # an open drawer's box is this share of its front smaller on each side
DOOR_HANDLE_SHIFT = 0.7  # a door handle sits this share of the half-door off its centre
LEG_INSET = 1.2        # legs stand this many leg radii inside the body's corners


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    # body
    add("width", "float", 0.8, 0.45, 1.2, "width of the body at its bottom")
    add("height", "float", 0.9, 0.5, 1.6, "height of the body")
    add("depth", "float", 0.45, 0.3, 0.6, "depth of the body")
    add("top_width", "float", 1.0, 0.75, 1.2, "width at the top / width at the bottom")
    add("side_curvature", "float", 0.0, -0.08, 0.08, "outward bow of the sides")
    add("frame_width", "float", 0.03, 0.01, 0.06, "the body's border around the fronts")
    # fronts
    add("drawer_rows", "int", 3, 0, 4, "rows of drawers (above the doors)")
    add("drawer_columns", "int", 2, 1, 3, "drawers per row")
    add("door_rows", "int", 0, 0, 2, "rows of doors (at the bottom)")
    add("door_columns", "int", 2, 1, 2, "doors per row")
    add("door_height", "float", 2.0, 1.0, 2.5, "height of a door row / a drawer row")
    add("gap", "float", 0.006, 0.002, 0.015, "gap between neighbouring fronts")
    add("front_thickness", "float", 0.02, 0.01, 0.035, "how far the fronts stand out")
    add("open_drawer", "int", 0, 0, 4, "the drawer row pulled out, from the top; 0 none")
    add("drawer_open", "float", 0.4, 0.1, 0.7, "how far it is pulled out (share of depth)")
    # handles
    add("handle_style", "int", 1, 0, 2, "handles: 0 none, 1 bar, 2 knob")
    add("handle_length", "float", 0.4, 0.15, 0.7, "bar length / front width (doors: height)")
    add("handle_reach", "float", 0.03, 0.015, 0.06, "how far a handle stands out")
    add("handle_thickness", "float", 0.006, 0.003, 0.012, "half-width of a bar")
    add("handle_roundness", "float", 1.0, 0.0, 1.0, "bar profile: 0 square, 1 round")
    add("handle_height", "float", 0.5, 0.25, 0.75, "height of a drawer's handle (share)")
    add("knob_size", "float", 0.015, 0.008, 0.03, "radius of a knob's head")
    # top board
    add("top_board", "bool", True, 0, 1, "a board on top of the body")
    add("top_overhang", "float", 0.02, 0.0, 0.06, "how far the board reaches past the body")
    add("top_thickness", "float", 0.025, 0.015, 0.05, "thickness of the top board")
    add("top_bevel", "float", 0.1, 0.0, 0.5, "rounding of the top board's edges")
    # base
    add("base_style", "int", 1, 0, 2, "base: 0 none, 1 plinth, 2 legs")
    add("base_height", "float", 0.08, 0.03, 0.25, "height of the plinth or the legs")
    add("plinth_inset", "float", 0.02, 0.0, 0.05, "how far the plinth is set back")
    add("leg_thickness", "float", 0.02, 0.012, 0.04, "half-width of a leg at its top")
    add("leg_taper", "float", 0.7, 0.4, 1.0, "foot width / top width of a leg")
    add("leg_splay", "float", 0.01, 0.0, 0.05, "how far the feet spread outwards")
    add("leg_roundness", "float", 1.0, 0.0, 1.0, "leg profile: 0 square, 1 round")
    return p


class _Cabinet:
    """The body's sides and the quantities that every part is placed from."""

    def __init__(self, g: Graph, p: dict):
        self.g, self.p = g, p
        self.bottom = g.named("bottom", g.index_switch(
            p["base_style"], [0.0, p["base_height"], p["base_height"]]))
        self.top = g.named("top", self.bottom + p["height"])
        self.front = g.named("front", -0.5 * p["depth"])
        half = 0.5 * p["width"]
        bottom_corner = g.vec(half, self.front, self.bottom)
        top_corner = g.vec(half * p["top_width"], self.front, self.top)
        self.right = g.named("right side", quadratic_cartesian(
            g, start=bottom_corner, end=top_corner, offset=g.vec(p["side_curvature"], 0, 0),
            resolution=SIDE_RESOLUTION)["Curve"])
        self.left = g.named("left side", self.mirrored(self.right))
        # the fronts' sides: the body's sides moved in by the frame
        self.inner_right = g.named("inner right side", g.transform(
            self.right, translation=g.vec(-p["frame_width"], 0, 0)))
        self.inner_left = g.named("inner left side", self.mirrored(self.inner_right))
        self.side_length = g.named("side length", g.distance(bottom_corner, top_corner))

    def mirrored(self, curve):
        return self.g.transform(curve, scale=(-1.0, 1.0, 1.0))

    def along(self, distance):
        """A distance along the sides as a share of their length."""
        return distance / self.side_length


def _body(c: _Cabinet):
    g, p = c.g, c.p
    outline = loft(g, curve_a=c.left, curve_b=c.right, rows=SIDE_RESOLUTION)["Mesh"]
    return g.label(solidify(g, mesh=outline, thickness=p["depth"])["Mesh"], BODY)


# -- fronts -------------------------------------------------------------------------------------

class _Row:
    """One pass of the rows' repeat zone: the row's place, kind and fronts."""

    def __init__(self, c: _Cabinet, zone: Repeat, rows, total_weight, choices):
        g, p = c.g, c.p
        self.c, self.g, self.p = c, g, p
        self.is_door = zone.iteration < p["door_rows"]
        self.columns = g.when(self.is_door, choices["door_columns"], choices["drawer_columns"])
        weight = g.when(self.is_door, choices["door_height"], 1.0)
        usable = 1.0 - 2.0 * c.along(p["frame_width"])
        self.start = zone["start"]
        self.end = self.start + usable * weight / total_weight
        gap = c.along(0.5 * p["gap"])
        self.low, self.high = self.start + gap, self.end - gap
        # counted from the top, the open drawer slides out by the travel
        from_top = rows - zone.iteration
        is_open = g.compare("EQUAL", from_top, p["open_drawer"]) & ~self.is_door
        self.travel = g.when(is_open, choices["travel"], 0.0)
        self.label = g.when(self.is_door, DOORS, DRAWERS)

    def _loft(self, low, high, span_start, span_end):
        return loft(self.g, curve_a=self.c.inner_left, curve_b=self.c.inner_right, start=low,
                    end=high, span_start=span_start, span_end=span_end,
                    inset=0.5 * self.p["gap"], rows=FRONT_ROWS)["Mesh"]

    def front(self, span_start, span_end):
        """One front: a Loft over the row's share of the inner sides, standing out of the
        body's face, its back sunk into it (or, when open, into the drawer's box)."""
        g, p = self.g, self.p
        surface = self._loft(self.low, self.high, span_start, span_end)
        face = g.transform(surface, translation=g.vec(0, -self.travel - p["front_thickness"], 0))
        return solidify(g, mesh=face, thickness=p["front_thickness"] + SINK)["Mesh"]

    def box(self, span_start, span_end):
        """The open drawer's box, a little smaller than its front, from the front's back
        into the body: it holds the pulled-out drawer."""
        g = self.g
        margin = (span_end - span_start) * BOX_MARGIN
        surface = self._loft(g.lerp(self.low, self.high, BOX_MARGIN),
                             g.lerp(self.low, self.high, 1.0 - BOX_MARGIN),
                             span_start + margin, span_end - margin)
        back = g.transform(surface, translation=g.vec(0, -self.travel, 0))
        box = solidify(g, mesh=back, thickness=self.travel + SINK)["Mesh"]
        return g.when(self.travel > 0.0, box)

    def fronts(self):
        """The row's fronts, one pass of a nested repeat zone per column."""
        g = self.g
        zone = Repeat(g, self.columns, geometry=None)
        span_start = zone.iteration / self.columns
        span_end = (zone.iteration + 1.0) / self.columns
        cell = g.join([self.front(span_start, span_end), self.box(span_start, span_end)])
        return zone.close(geometry=g.join([zone["geometry"], cell]))["geometry"]

    def handles(self):
        """A handle on each front: SampleCurveArray on the row's line across its fronts, at
        the handle's height on the fronts' face, gives the fronts' centres."""
        g, p, c = self.g, self.p, self.c
        height = g.lerp(self.low, self.high, g.when(self.is_door, 0.5, p["handle_height"]))
        edge = sample_curve(g, curve=c.inner_right, factor=height)["Position"]
        face = c.front - self.travel - p["front_thickness"]
        line = g.line(g.vec(-edge.x, face, edge.z), g.vec(edge.x, face, edge.z))
        margin = 0.5 / self.columns
        centres = sample_curve_array(g, curve=line, count=self.columns, start_margin=margin,
                                     end_margin=margin)["Points"]
        front_width = 2.0 * edge.x / self.columns - p["gap"]
        front_height = (self.high - self.low) * c.side_length
        # doors: the handle moves towards the cabinet's middle, beside the door's inner edge
        inward = g.math("SIGN", g.position().x) * front_width * (-0.5 * DOOR_HANDLE_SHIFT)
        placed = g.set_position(centres, offset=g.vec(g.when(self.is_door, inward, 0.0), 0, 0))
        length = p["handle_length"] * g.when(self.is_door, front_height, front_width)

        def on_fronts(handle):
            # handle +x (out of the front) -> world -y; its z (along a bar) -> world x, or z
            # on a door
            lying = g.transform(g.transform(handle, rotation=(0.0, math.pi / 2, 0.0)),
                                rotation=(-math.pi / 2, 0.0, 0.0))
            upright = g.transform(handle, rotation=(0.0, 0.0, -math.pi / 2))
            return g.instance_on_points(placed, g.when(self.is_door, upright, lying))

        return g.index_switch(p["handle_style"], [None, on_fronts(_bar(c, length)),
                                                  on_fronts(_knob(c))])


# handles at the origin, their foot on the plane x = 0, standing out to +x

def _bar(c: _Cabinet, length):
    """A CurveHandle attached at both ends to a line of `length` along z (it works in the XZ
    plane, bulging to +x), swept with a square-to-round tube."""
    g, p = c.g, c.p
    attach = g.line(g.vec(0, 0, -0.5 * length), g.vec(0, 0, 0.5 * length))
    curve = handle(g, curve=attach, start=0.0, end=1.0, reach=p["handle_reach"], peak=0.5,
                   inset=SINK, resolution=12)["Curve"]
    profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=p["handle_roundness"],
                               resolution=2)["Curve"]
    return rail(g, curve=curve, profile_curve=profile, radius=p["handle_thickness"],
                fill_caps=True, label=HANDLES)["Mesh"]


def _knob(c: _Cabinet):
    """A round stem widening into a head (StyleBezierSegment)."""
    g, p = c.g, c.p
    stem = g.line(g.vec(-SINK, 0, 0), g.vec(p["handle_reach"], 0, 0), count=8)
    profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=1.0, resolution=2)["Curve"]
    size = p["knob_size"]
    return bezier_segment_style(g, curve=stem, profile_curve=profile, start=0.4 * size,
                                start_handle=0.4 * size, end_handle=1.3 * size,
                                end=0.6 * size, fill_caps=True, label=HANDLES)["Mesh"]


def _fronts(c: _Cabinet):
    """Rows from the bottom (doors first), one pass of a repeat zone each: a row's share of
    the sides starts where the previous one ended."""
    g, p = c.g, c.p
    has_drawers, has_doors = p["drawer_rows"] > 0, p["door_rows"] > 0
    travel = g.when(p["open_drawer"] > 0, p["drawer_open"] * p["depth"], 0.0)
    # parameters of absent rows reach no geometry: their rules are inferred from these
    choices = {"travel": g.when(has_drawers, travel, 0.0),
               "drawer_columns": g.when(has_drawers, p["drawer_columns"], 1),
               "door_columns": g.when(has_doors, p["door_columns"], 1),
               "door_height": g.when(has_doors, p["door_height"], 1.0)}
    rows = p["drawer_rows"] + p["door_rows"]
    total = g.max(p["drawer_rows"] + p["door_rows"] * choices["door_height"], 1.0)
    zone = Repeat(g, rows, geometry=None, start=c.along(p["frame_width"]))
    row = _Row(c, zone, rows, total, choices)
    built = g.join([zone["geometry"], g.label(row.fronts(), row.label),
                    row.handles()])
    return zone.close(geometry=built, start=row.end)["geometry"]


# -- top and base --------------------------------------------------------------------------------

def _top_board(c: _Cabinet):
    g, p = c.g, c.p
    overhang = p["top_overhang"]
    board = seat(g, width=p["width"] * p["top_width"] + 2.0 * overhang,
                 depth=p["depth"] + overhang, roundness=0.0,
                 top=c.top + p["top_thickness"] - SINK, thickness=p["top_thickness"],
                 bevel=p["top_bevel"], label=TOP)["Mesh"]
    moved = g.transform(board, translation=g.vec(0, -0.5 * overhang, 0))
    return g.when(p["top_board"], moved)


def _plinth(c: _Cabinet):
    g, p = c.g, c.p
    inset = 2.0 * p["plinth_inset"]
    return seat(g, width=p["width"] - inset, depth=p["depth"] - inset, roundness=0.0,
                top=c.bottom + SINK, thickness=c.bottom + SINK, bevel=0.0, label=PLINTH)["Mesh"]


def _legs(c: _Cabinet):
    """Four legs from inside the body's bottom corners to the floor (one, mirrored twice)."""
    g, p = c.g, c.p
    inset = p["leg_thickness"] * LEG_INSET
    x, y, splay = 0.5 * p["width"] - inset, 0.5 * p["depth"] - inset, p["leg_splay"]
    one = leg_mesh(g, top=g.vec(x, y, c.bottom + SINK), bottom=g.vec(x + splay, y + splay, 0.0),
                   curvature=1.0, top_radius=p["leg_thickness"],
                   bottom_radius=p["leg_thickness"] * p["leg_taper"],
                   roundness=p["leg_roundness"], label=LEGS)["Mesh"]
    pair = mirror(g, geometry=one, axis=0)["Geometry"]
    return mirror(g, geometry=pair, axis=1)["Geometry"]


def build(g: Graph) -> None:
    with g.frame("Parameters"):
        p = _parameters(g)
    with g.group("Sides"):
        c = _Cabinet(g, p)
    with g.group("Body"):
        body = _body(c)
    with g.group("Fronts"):
        fronts = _fronts(c)
    with g.group("Top Board"):
        top = _top_board(c)
    with g.group("Plinth"):
        plinth = _plinth(c)
    with g.group("Legs"):
        legs = _legs(c)
    with g.frame("Assembly"):
        base = g.index_switch(p["base_style"], [None, plinth, legs])
        # grounded: a splayed leg's foot dips a little below its axis' end
        g.output("Geometry", "geometry", g.ground(g.join([body, fronts, top, base])))
