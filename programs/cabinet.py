"""The cabinet program (38 parameters: 11 discrete, 27 continuous): the paper's example of the
blocks carried to a new domain, a cabinet whose drawers follow the frame's profile and whose
handles stay attached (its "structural integrity discussion"), grown to the common real forms:
chests of drawers, cupboards, bookcases and open shelving, night stands, low wide TV cabinets
and sideboards, wall cabinets.

Layout: x = width, y = depth (the fronts at -y), z = up. Structure (every part touches the
rest for every parameter combination):
- sides: the right side is a CurveQuadraticCartesian from the bottom corner to the top corner
  (tapered by `top_width`, bowed by `side_curvature`), the left side its mirror image; the
  fronts' sides are these moved in by the frame (`frame_width`, also the boards' thickness).
  Rows share the sides' length: door rows at the bottom, drawer rows above, open rows on top;
  doors and open rows weigh `door_height`, drawers 1;
- body: below the open rows (all of it when there are none) a Loft between the two sides,
  swept back by the depth (StyleSolidify); around the open rows the two side boards, a top
  rail and a back wall, Lofts between a side and its inner side, given thickness the same way;
  the open rows' boards, their shelves and the top board may stand back on the closed body
  (`open_depth`: a hutch);
- fronts: built in a repeat zone (one pass per row, a nested one per column). Each front is a
  Loft between the inner sides over its row's share of their length, so its outer edges
  follow the profile at every height; it stands out of the body by `front_thickness` and is
  sunk a little into it. A front is a slab, or (`front_style`) a frame of `panel_border`
  (rails: Lofts over a band of the row; stiles: Lofts of no span, widened by a negative
  inset) around a panel set back by half the thickness, or around a thin glass pane at the
  frame's back. The open drawer slides out along -y and a box joins it back into the body;
- open rows: `shelf_count` boards evenly across each, and one between two open rows, from
  the front to the back wall, sunk into the side boards (a nested repeat zone);
- handles: a CurveHandle (a bar attached at both ends) or a knob, placed by SampleCurveArray
  on the row's line across its fronts (cell centres) on the front's face (a framed front's
  panel face: on the frame they sink into it), so they move with their drawer; door handles
  are upright, near the door's inner edge;
- top board (optional, overhanging at the front and sides), a plinth or four legs; the body
  stands on them, and the cabinet is grounded so that its lowest point lies on z = 0.
Labels: body 1 (with the back wall and shelves), top 2, drawers 3, doors 4, handles 5,
plinth 6, legs 7.
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
OPEN_RESOLUTION = 8    # rows of the side boards and the back wall around the open rows
FRONT_ROWS = 6         # loft rows of a front: enough to follow a bowed side
SINK = 0.004           # how far fronts, boxes, boards and handles reach into what holds them
PANEL_RECESS = 0.5     # a framed panel lies this share of the front's thickness behind its frame
PANE = 0.004           # thickness of a glass pane, at the back of its frame
BORDER_SHARE = 0.3     # a front's frame is at most this share of its smaller side
BOX_MARGIN = 0.08      # an open drawer's box is this share of its front smaller on each side
DOOR_HANDLE_SHIFT = 0.7  # a door handle sits this share of the half-door off its centre
LEG_INSET = 1.2        # legs stand this many leg radii inside the body's corners


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    # body
    add("width", "float", 0.8, 0.45, 2.0, "width of the body at its bottom")
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
    add("open_rows", "int", 0, 0, 2, "rows of open shelves (at the top)")
    add("shelf_count", "int", 1, 0, 3, "shelves across an open row")
    add("open_depth", "float", 1.0, 0.4, 1.0, "depth of the open rows / the body's (a hutch)")
    add("door_height", "float", 2.0, 1.0, 2.5, "height of a door or open row / a drawer row")
    add("gap", "float", 0.006, 0.002, 0.015, "gap between neighbouring fronts")
    add("front_thickness", "float", 0.02, 0.01, 0.035, "how far the fronts stand out")
    add("front_style", "int", 0, 0, 2, "fronts: 0 flat slab, 1 panel in a frame, 2 glass pane")
    add("panel_border", "float", 0.04, 0.015, 0.08, "width of the frame around a panel")
    add("open_drawer", "int", 0, 0, 4, "the drawer row pulled out, from the top; 0 none")
    add("drawer_open", "float", 0.4, 0.1, 0.55, "how far it is pulled out (share of depth)")
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
        self._rows()

    def _rows(self):
        """The rows' shares of the sides: doors and open rows weigh `door_height`, drawers 1,
        over the sides less the frame at both ends; the open rows start at `open_start`."""
        g, p = self.g, self.p
        has_drawers, has_doors = p["drawer_rows"] > 0, p["door_rows"] > 0
        self.has_open = p["open_rows"] > 0
        travel = g.when(p["open_drawer"] > 0, p["drawer_open"] * p["depth"], 0.0)
        # parameters of absent rows reach no geometry: their rules are inferred from these
        self.choices = {
            "travel": g.when(has_drawers, travel, 0.0),
            "drawer_columns": g.when(has_drawers, p["drawer_columns"], 1),
            "door_columns": g.when(has_doors, p["door_columns"], 1),
            "door_height": g.when(has_doors | self.has_open, p["door_height"], 1.0),
            "shelf_count": g.when(self.has_open, p["shelf_count"], 0),
            # the open rows stand this far back from the closed body's front
            "setback": g.when(self.has_open, (1.0 - p["open_depth"]) * p["depth"], 0.0),
            "front_style": p["front_style"], "panel_border": p["panel_border"]}
        tall = p["door_rows"] * self.choices["door_height"]
        self.rows = p["drawer_rows"] + p["door_rows"] + p["open_rows"]
        self.total = g.max(p["drawer_rows"] + tall + p["open_rows"]
                           * self.choices["door_height"], 1.0)
        self.usable = 1.0 - 2.0 * self.along(p["frame_width"])
        self.open_start = g.named("open start", self.along(p["frame_width"]) + self.usable
                                  * (p["drawer_rows"] + tall) / self.total)

    def mirrored(self, curve):
        return self.g.transform(curve, scale=(-1.0, 1.0, 1.0))

    def along(self, distance):
        """A distance along the sides as a share of their length."""
        return distance / self.side_length


def _band(c: _Cabinet, curve_a, curve_b, start, end, thickness, inset=0.0, back=0.0,
          rows=SIDE_RESOLUTION):
    """A board: the Loft between two of the sides over [start, end] of their length, its
    face `back` behind the body's front, `thickness` deep."""
    g = c.g
    surface = loft(g, curve_a=curve_a, curve_b=curve_b, start=start, end=end, inset=inset,
                   rows=rows)["Mesh"]
    moved = g.transform(surface, translation=g.vec(0, back, 0))
    return solidify(g, mesh=moved, thickness=thickness)["Mesh"]


def _body(c: _Cabinet):
    """The closed body below the open rows (all of it when there are none); around the open
    rows the sides, the top rail and a back wall, all `frame_width` thick (the shelves are
    built with their rows)."""
    g, p = c.g, c.p
    board, setback = p["frame_width"], c.choices["setback"]
    closed = _band(c, c.left, c.right, 0.0, g.when(c.has_open, c.open_start, 1.0), p["depth"])
    # the open rows' boards, `open_depth` of the body deep, their fronts set back on it
    depth = p["depth"] - setback
    top_rail = 1.0 - c.along(board)
    shell = g.join([
        _band(c, c.left, c.inner_left, c.open_start, 1.0, depth, back=setback,
              rows=OPEN_RESOLUTION),
        _band(c, c.inner_right, c.right, c.open_start, 1.0, depth, back=setback,
              rows=OPEN_RESOLUTION),
        _band(c, c.inner_left, c.inner_right, top_rail, 1.0, depth, back=setback, rows=1),
        _band(c, c.inner_left, c.inner_right, c.open_start, top_rail, board + SINK,
              back=p["depth"] - board, rows=OPEN_RESOLUTION),
    ])
    return g.label(g.join([closed, g.when(c.has_open, shell)]), BODY)


# -- fronts -------------------------------------------------------------------------------------

class _Row:
    """One pass of the rows' repeat zone: the row's place, kind and fronts (or shelves)."""

    def __init__(self, c: _Cabinet, zone: Repeat):
        g, p, choices = c.g, c.p, c.choices
        self.c, self.g, self.p = c, g, p
        self.is_door = zone.iteration < p["door_rows"]
        closed_rows = p["door_rows"] + p["drawer_rows"]
        self.is_open = zone.iteration >= closed_rows
        self.is_last = zone.iteration >= c.rows - 1
        self.columns = g.when(self.is_door, choices["door_columns"], choices["drawer_columns"])
        weight = g.when(self.is_door | self.is_open, choices["door_height"], 1.0)
        self.start = zone["start"]
        self.end = self.start + c.usable * weight / c.total
        gap = c.along(0.5 * p["gap"])
        self.low, self.high = self.start + gap, self.end - gap
        # counted from the top drawer row, the open drawer slides out by the travel
        from_top = closed_rows - zone.iteration
        is_open = g.compare("EQUAL", from_top, p["open_drawer"]) & ~self.is_door
        self.travel = g.when(is_open, choices["travel"], 0.0)
        self.label = g.when(self.is_door, DOORS, DRAWERS)
        # a framed front's border, at most a share of the front's smaller side
        middle = sample_curve(g, curve=c.inner_right, factor=g.lerp(self.low, self.high, 0.5))
        front_width = 2.0 * middle["Position"].x / self.columns - p["gap"]
        front_height = (self.high - self.low) * c.side_length
        self.border = g.min(choices["panel_border"],
                            BORDER_SHARE * g.min(front_width, front_height))
        # (switches of constants: the thickness reaches the fronts whatever the style)
        style = choices["front_style"]
        self.recess = (p["front_thickness"] * g.index_switch(style, [0.0, PANEL_RECESS, 1.0])
                       - g.index_switch(style, [0.0, 0.0, PANE]))

    def _loft(self, low, high, span_start, span_end, inset=None, rows=FRONT_ROWS):
        inset = 0.5 * self.p["gap"] if inset is None else inset
        return loft(self.g, curve_a=self.c.inner_left, curve_b=self.c.inner_right, start=low,
                    end=high, span_start=span_start, span_end=span_end,
                    inset=inset, rows=rows)["Mesh"]

    def _solid(self, surface, recess):
        """A surface moved to the front's face (less `recess`) and given the depth from
        there to the body (or to the open drawer's box)."""
        g, p = self.g, self.p
        face = g.transform(surface, translation=g.vec(0, recess - self.travel
                                                      - p["front_thickness"], 0))
        return solidify(g, mesh=face, thickness=p["front_thickness"] - recess + SINK)["Mesh"]

    def _framed(self, span_start, span_end):
        """A panel (or pane) `recess` behind a frame of `border` around it: rails along the
        top and bottom, stiles up the sides (Lofts of no span, widened by a negative inset
        and moved in along x, the way across the sides)."""
        g, p = self.g, self.p
        border, half_gap = self.border, 0.5 * p["gap"]
        rise = self.c.along(border)
        inner = half_gap + border
        offset = half_gap + 0.5 * border
        stiles = [g.transform(self._loft(self.low, self.high, span, span, -0.5 * border),
                              translation=g.vec(shift, 0, 0))
                  for span, shift in ((span_start, offset), (span_end, -offset))]
        rails = [self._loft(self.low, self.low + rise, span_start, span_end, inner, rows=1),
                 self._loft(self.high - rise, self.high, span_start, span_end, inner, rows=1)]
        panel = self._loft(self.low + rise, self.high - rise, span_start, span_end, inner)
        return g.join([self._solid(g.join([*stiles, *rails]), 0.0),
                       self._solid(panel, self.recess)])

    def front(self, span_start, span_end):
        """One front: a Loft over the row's share of the inner sides, standing out of the
        body's face, its back sunk into it (or, when open, into the drawer's box); a slab,
        or a panel or a glass pane in a frame."""
        g = self.g
        slab = self._solid(self._loft(self.low, self.high, span_start, span_end), 0.0)
        framed = self._framed(span_start, span_end)
        return g.when(self.c.choices["front_style"] > 0, framed, slab)

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

    def shelves(self):
        """An open row's boards, evenly spaced over it, one pass of a nested repeat zone
        each: `shelf_count` shelves, and one more on the row's top unless the top rail is
        there; from the front to the back wall, sunk into the sides."""
        g, p, c = self.g, self.p, self.c
        count = c.choices["shelf_count"]
        zone = Repeat(g, count + g.when(self.is_last, 0, 1), geometry=None)
        at = g.lerp(self.start, self.end, (zone.iteration + 1.0) / (count + 1.0))
        half = c.along(0.5 * p["frame_width"])
        setback = c.choices["setback"]
        board = _band(c, c.inner_left, c.inner_right, at - half, at + half,
                      p["depth"] - setback - p["frame_width"] + SINK, inset=-SINK,
                      back=setback, rows=1)
        boards = zone.close(geometry=g.join([zone["geometry"], board]))["geometry"]
        return g.label(boards, BODY)

    def handles(self):
        """A handle on each front: SampleCurveArray on the row's line across its fronts, at
        the handle's height on the fronts' face, gives the fronts' centres (on a framed
        front, the panel's face: a handle on the frame sinks into it)."""
        g, p, c = self.g, self.p, self.c
        height = g.lerp(self.low, self.high, g.when(self.is_door, 0.5, p["handle_height"]))
        edge = sample_curve(g, curve=c.inner_right, factor=height)["Position"]
        face = c.front - self.travel - p["front_thickness"] + self.recess
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
    """Rows from the bottom (doors first, then drawers, open rows on top), one pass of a
    repeat zone each: a row's share of the sides starts where the previous one ended."""
    g, p = c.g, c.p
    zone = Repeat(g, c.rows, geometry=None, start=c.along(p["frame_width"]))
    row = _Row(c, zone)
    closed = g.join([g.label(row.fronts(), row.label), row.handles()])
    built = g.join([zone["geometry"], g.when(row.is_open, row.shelves(), closed)])
    return zone.close(geometry=built, start=row.end)["geometry"]


# -- top and base --------------------------------------------------------------------------------

def _top_board(c: _Cabinet):
    g, p = c.g, c.p
    overhang, setback = p["top_overhang"], c.choices["setback"]
    # over the body's top: the open rows', set back on a hutch
    board = seat(g, width=p["width"] * p["top_width"] + 2.0 * overhang,
                 depth=p["depth"] - setback + overhang, roundness=0.0,
                 top=c.top + p["top_thickness"] - SINK, thickness=p["top_thickness"],
                 bevel=p["top_bevel"], label=TOP)["Mesh"]
    moved = g.transform(board, translation=g.vec(0, 0.5 * (setback - overhang), 0))
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
