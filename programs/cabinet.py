"""The cabinet program (33 parameters: 9 discrete, 24 continuous): the paper's example of the
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
Part labels: body 1, top 2, drawers 3, doors 4, handles 5, plinth 6, legs 7.
"""

from __future__ import annotations

import math

from geocode.nodes import (
    Graph,
    handle,
    mirror,
    quadratic_cartesian,
    rail,
    rectangle_fillet,
    sample_curve,
    sample_curve_array,
    solidify,
)
from geocode.nodes.loft import loft
from geocode.nodes.parts import leg, seat
from geocode.nodes.repeat import Repeat
from geocode.nodes.styles import bezier_segment_style

BODY, TOP, DRAWERS, DOORS, HANDLES, PLINTH, LEGS = range(1, 8)

SIDE_RESOLUTION = 16   # segments of each side curve (and rows of the body's loft)
FRONT_ROWS = 6         # loft rows of a front: enough to follow a bowed side
SINK = 0.004           # how far fronts, boxes, boards and handles reach into what holds them
BOX_MARGIN = 0.08      # an open drawer's box is this share of its front smaller on each side
DOOR_HANDLE_SHIFT = 0.7  # a door handle sits this share of the half-door off its centre
LEG_INSET = 1.2        # legs stand this many leg radii inside the body's corners


def _parameters(g: Graph) -> dict:
    p = {}

    def add(name, kind, default, low, high, description):
        p[name] = g.input(name, kind, default=default, min=low, max=high,
                          description=description)

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
        self.bottom = g.index_switch(p["base_style"], [0.0, p["base_height"], p["base_height"]],
                                     data_type="FLOAT")
        self.top = g.add(self.bottom, p["height"])
        self.front = g.mul(p["depth"], -0.5)
        half = g.mul(p["width"], 0.5)
        self.right = quadratic_cartesian(
            g, start=g.combine(half, self.front, self.bottom),
            end=g.combine(g.mul(half, p["top_width"]), self.front, self.top),
            offset=g.combine(p["side_curvature"], 0.0, 0.0),
            resolution=SIDE_RESOLUTION)["Curve"]
        self.left = self.mirrored(self.right)
        # the fronts' sides: the body's sides moved in by the frame
        self.inner_right = g.transform(self.right, translation=g.combine(
            g.mul(p["frame_width"], -1.0), 0.0, 0.0))
        self.inner_left = self.mirrored(self.inner_right)
        self.side_length = g.vmath("DISTANCE", g.combine(half, 0.0, self.bottom), g.combine(
            g.mul(half, p["top_width"]), 0.0, self.top))

    def mirrored(self, curve):
        return self.g.transform(curve, scale=(-1.0, 1.0, 1.0))

    def along(self, distance):
        """A distance along the sides as a share of their length."""
        return self.g.div(distance, self.side_length)


def _body(c: _Cabinet):
    g, p = c.g, c.p
    outline = loft(g, curve_a=c.left, curve_b=c.right, rows=SIDE_RESOLUTION)["Mesh"]
    return g.label_part(solidify(g, mesh=outline, thickness=p["depth"])["Mesh"], BODY)


# -- fronts -------------------------------------------------------------------------------------

class _Row:
    """One pass of the rows' repeat zone: the row's place, kind and fronts."""

    def __init__(self, c: _Cabinet, zone: Repeat, rows, total_weight, weights, columns):
        g, p = c.g, c.p
        self.c, self.g, self.p = c, g, p
        self.is_door = g.compare("LESS_THAN", zone.iteration, p["door_rows"], data_type="INT")
        self.columns = g.switch(self.is_door, columns["drawer"], columns["door"],
                                data_type="INT")
        weight = g.switch(self.is_door, 1.0, weights["door"], data_type="FLOAT")
        usable = g.sub(1.0, g.mul(c.along(p["frame_width"]), 2.0))
        self.start = zone["start"]
        self.end = g.add(self.start, g.mul(usable, g.div(weight, total_weight)))
        gap = c.along(g.mul(p["gap"], 0.5))
        self.low, self.high = g.add(self.start, gap), g.sub(self.end, gap)
        # counted from the top, the open drawer slides out by the travel
        from_top = g.int_math("SUBTRACT", rows, zone.iteration)
        is_open = g.boolean("AND", g.compare("EQUAL", from_top, p["open_drawer"],
                                             data_type="INT"),
                            g.boolean("NOT", self.is_door))
        self.travel = g.switch(is_open, 0.0, weights["travel"], data_type="FLOAT")
        self.label = g.switch(self.is_door, DRAWERS, DOORS, data_type="INT")

    def front(self, span_start, span_end):
        """One front: a Loft over the row's share of the inner sides, standing out of the
        body's face, its back sunk into it (or, when open, into the drawer's box)."""
        g, p = self.g, self.p
        surface = loft(g, curve_a=self.c.inner_left, curve_b=self.c.inner_right,
                       start=self.low, end=self.high, span_start=span_start,
                       span_end=span_end, inset=g.mul(p["gap"], 0.5), rows=FRONT_ROWS)["Mesh"]
        face = g.sub(g.mul(self.travel, -1.0), p["front_thickness"])
        moved = g.transform(surface, translation=g.combine(0.0, face, 0.0))
        return solidify(g, mesh=moved, thickness=g.add(p["front_thickness"], SINK))["Mesh"]

    def box(self, span_start, span_end):
        """The open drawer's box, a little smaller than its front, from the front's back
        into the body: it holds the pulled-out drawer."""
        g, p = self.g, self.p
        low = g.lerp(self.low, self.high, BOX_MARGIN)
        high = g.lerp(self.low, self.high, 1.0 - BOX_MARGIN)
        margin = g.mul(g.sub(span_end, span_start), BOX_MARGIN)
        surface = loft(g, curve_a=self.c.inner_left, curve_b=self.c.inner_right, start=low,
                       end=high, span_start=g.add(span_start, margin),
                       span_end=g.sub(span_end, margin), inset=g.mul(p["gap"], 0.5),
                       rows=FRONT_ROWS)["Mesh"]
        moved = g.transform(surface, translation=g.combine(0.0, g.mul(self.travel, -1.0), 0.0))
        box = solidify(g, mesh=moved, thickness=g.add(self.travel, SINK))["Mesh"]
        is_open = g.compare("GREATER_THAN", self.travel, 0.0, data_type="FLOAT")
        return g.switch(is_open, None, box, data_type="GEOMETRY")

    def fronts(self):
        """The row's fronts, one pass of a nested repeat zone per column."""
        g = self.g
        zone = Repeat(g, self.columns, geometry=None)
        span_start = g.div(zone.iteration, self.columns)
        span_end = g.div(g.add(zone.iteration, 1.0), self.columns)
        cell = g.join([self.front(span_start, span_end), self.box(span_start, span_end)])
        return zone.close(geometry=g.join([zone["geometry"], cell]))["geometry"]

    def handles(self, handle_shapes):
        """A handle on each front: SampleCurveArray on the row's line across its fronts, at
        the handle's height on the fronts' face, gives the fronts' centres."""
        g, p, c = self.g, self.p, self.c
        height = g.lerp(self.low, self.high,
                        g.switch(self.is_door, p["handle_height"], 0.5, data_type="FLOAT"))
        x = g.separate(sample_curve(g, curve=c.inner_right, factor=height)["Position"])
        face = g.sub(c.front, g.add(self.travel, p["front_thickness"]))
        line = g.node("GeometryNodeCurvePrimitiveLine", {
            "Start": g.combine(g.mul(x["X"], -1.0), face, x["Z"]),
            "End": g.combine(x["X"], face, x["Z"])}).out
        margin = g.div(0.5, self.columns)
        centres = sample_curve_array(g, curve=line, count=self.columns, start_margin=margin,
                                     end_margin=margin)["Points"]
        front_width = g.sub(g.div(g.mul(x["X"], 2.0), self.columns), p["gap"])
        front_height = g.mul(g.sub(self.high, self.low), c.side_length)
        # doors: the handle moves towards the cabinet's middle, beside the door's inner edge
        here = g.separate(g.position())["X"]
        shift = g.mul(g.math("SIGN", here), g.mul(front_width, -0.5 * DOOR_HANDLE_SHIFT))
        placed = g.node("GeometryNodeSetPosition", {
            "Geometry": centres, "Offset": g.combine(
                g.switch(self.is_door, 0.0, shift, data_type="FLOAT"), 0.0, 0.0)}).out
        length = g.mul(p["handle_length"], g.switch(self.is_door, front_width, front_height,
                                                    data_type="FLOAT"))
        shape = g.switch(self.is_door, handle_shapes(length, upright=False),
                         handle_shapes(length, upright=True), data_type="GEOMETRY")
        copies = g.node("GeometryNodeInstanceOnPoints", {"Points": placed, "Instance": shape})
        return g.node("GeometryNodeRealizeInstances", {"Geometry": copies}).out


def _handle_shapes(c: _Cabinet):
    """handle(length, upright): the chosen handle at the origin, its foot on the plane y = 0,
    standing out to -y; a bar lies along x (along z when upright)."""
    g, p = c.g, c.p

    def bar(length):
        # CurveHandle works in the XZ plane, bulging to +x: built there, then turned
        attach = g.node("GeometryNodeCurvePrimitiveLine", {
            "Start": g.combine(0.0, 0.0, g.mul(length, -0.5)),
            "End": g.combine(0.0, 0.0, g.mul(length, 0.5))}).out
        curve = handle(g, curve=attach, start=0.0, end=1.0, reach=p["handle_reach"],
                       peak=0.5, inset=SINK, resolution=12)["Curve"]
        profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=p["handle_roundness"],
                                   resolution=2)["Curve"]
        return rail(g, curve=curve, profile_curve=profile, radius=p["handle_thickness"],
                    fill_caps=True, part=HANDLES)["Mesh"]

    def knob():
        stem = g.node("GeometryNodeResampleCurve", {
            "Curve": g.node("GeometryNodeCurvePrimitiveLine", {
                "Start": g.combine(-SINK, 0.0, 0.0),
                "End": g.combine(p["handle_reach"], 0.0, 0.0)}),
            "Mode": "Count", "Count": 8}).out
        profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=1.0,
                                   resolution=2)["Curve"]
        size = p["knob_size"]
        return bezier_segment_style(g, curve=stem, profile_curve=profile,
                                    start=g.mul(size, 0.4), start_handle=g.mul(size, 0.4),
                                    end_handle=g.mul(size, 1.3), end=g.mul(size, 0.6),
                                    fill_caps=True, part=HANDLES)["Mesh"]

    def shapes(length, upright):
        local = g.index_switch(p["handle_style"], [None, bar(length), knob()],
                               data_type="GEOMETRY")
        # local +x (out of the front) -> world -y; local z (along the bar) -> world z or x
        if upright:
            return g.transform(local, rotation=(0.0, 0.0, -math.pi / 2))
        along_x = g.transform(local, rotation=(0.0, math.pi / 2, 0.0))
        return g.transform(along_x, rotation=(-math.pi / 2, 0.0, 0.0))

    return shapes


def _fronts(c: _Cabinet):
    """Rows from the bottom (doors first), one pass of a repeat zone each: a row's share of
    the sides starts where the previous one ended."""
    g, p = c.g, c.p
    has_drawers = g.compare("GREATER_THAN", p["drawer_rows"], 0, data_type="INT")
    has_doors = g.compare("GREATER_THAN", p["door_rows"], 0, data_type="INT")
    opened = g.compare("GREATER_THAN", p["open_drawer"], 0, data_type="INT")
    travel = g.switch(has_drawers, 0.0, g.switch(opened, 0.0, g.mul(p["drawer_open"],
                                                                    p["depth"]),
                                                 data_type="FLOAT"), data_type="FLOAT")
    weights = {"door": g.switch(has_doors, 1.0, p["door_height"], data_type="FLOAT"),
               "travel": travel}
    columns = {"drawer": g.switch(has_drawers, 1, p["drawer_columns"], data_type="INT"),
               "door": g.switch(has_doors, 1, p["door_columns"], data_type="INT")}
    rows = g.int_math("ADD", p["drawer_rows"], p["door_rows"])
    total = g.maximum(g.add(p["drawer_rows"], g.mul(p["door_rows"], weights["door"])), 1.0)
    shapes = _handle_shapes(c)
    zone = Repeat(g, rows, geometry=None, start=c.along(p["frame_width"]))
    row = _Row(c, zone, rows, total, weights, columns)
    built = g.join([zone["geometry"], g.label_part(row.fronts(), row.label),
                    row.handles(shapes)])
    return zone.close(geometry=built, start=row.end)["geometry"]


# -- top and base --------------------------------------------------------------------------------

def _top_board(c: _Cabinet):
    g, p = c.g, c.p
    overhang = p["top_overhang"]
    board = seat(g, width=g.add(g.mul(p["width"], p["top_width"]), g.mul(overhang, 2.0)),
                 depth=g.add(p["depth"], overhang), roundness=0.0,
                 top=g.add(c.top, g.sub(p["top_thickness"], SINK)),
                 thickness=p["top_thickness"], bevel=p["top_bevel"], part=TOP)["Mesh"]
    moved = g.transform(board, translation=g.combine(0.0, g.mul(overhang, -0.5), 0.0))
    return g.switch(p["top_board"], None, moved, data_type="GEOMETRY")


def _plinth(c: _Cabinet):
    g, p = c.g, c.p
    inset = g.mul(p["plinth_inset"], 2.0)
    return seat(g, width=g.sub(p["width"], inset), depth=g.sub(p["depth"], inset),
                roundness=0.0, top=g.add(c.bottom, SINK), thickness=g.add(c.bottom, SINK),
                bevel=0.0, part=PLINTH)["Mesh"]


def _legs(c: _Cabinet):
    """Four legs from inside the body's bottom corners to the floor (one, mirrored twice)."""
    g, p = c.g, c.p
    inset = g.mul(p["leg_thickness"], LEG_INSET)
    x = g.sub(g.mul(p["width"], 0.5), inset)
    y = g.sub(g.mul(p["depth"], 0.5), inset)
    one = leg(g, top=g.combine(x, y, g.add(c.bottom, SINK)),
              bottom=g.combine(g.add(x, p["leg_splay"]), g.add(y, p["leg_splay"]), 0.0),
              curvature=1.0, top_radius=p["leg_thickness"],
              bottom_radius=g.mul(p["leg_thickness"], p["leg_taper"]),
              roundness=p["leg_roundness"], part=LEGS)["Mesh"]
    pair = mirror(g, geometry=one, axis=0)["Geometry"]
    return mirror(g, geometry=pair, axis=1)["Geometry"]


def build(g: Graph) -> None:
    p = _parameters(g)
    c = _Cabinet(g, p)
    base = g.index_switch(p["base_style"], [None, _plinth(c), _legs(c)], data_type="GEOMETRY")
    cabinet = g.join([_body(c), _fronts(c), _top_board(c), base])
    # ground it: a splayed leg's foot dips a little below its axis' end
    lowest = g.separate(g.node("GeometryNodeBoundBox", {"Geometry": cabinet})["Min"])["Z"]
    g.output("Geometry", "geometry",
             g.transform(cabinet, translation=g.combine(0.0, 0.0, g.mul(lowest, -1.0))))
