"""The chair program (79 parameters: 21 discrete, 58 continuous).

Layout: x = width, y = depth (the backrest at +y), z = up; a 0.5 x 0.5 seat before the
overall scale. Structure (every part touches the rest for every parameter combination):
- seat: MeshSeat; its `Corner` (the middle of the rounded corner of the outline) is the
  anchor of legs, backrest frame and armrests, so they follow the seat's roundness, and
  they all start inside the seat slab, so they follow its height; its back can bulge out
  behind (UtilBowInPlan: a D-shaped seat) without moving them;
- cushion: MeshCushion sunk a little into the seat's top;
- legs: four MeshLegs from under the seat corners to z = 0, optionally on a sled base
  (a MeshStraightFrame runner on the floor through each side's feet, the two optionally
  joined at the back by a tube across) and optionally joined by stretchers
  (MeshStraightFrame bars, a box or an H, their ends sampled on the legs' own axes) and an
  apron (MeshStraightFrame rails from leg top to leg top under the seat), or a
  monoleg (a column with StyleBezierSegment: a pedestal, or a slimmer column on tent legs:
  radial MeshQuadraticCartesian, optionally on caster wheels, MeshStraightFrame);
- backrest: two frames (MeshQuadraticCartesianAlignedXYFrame, mirrored in x) rising from
  the seat's back corners; cross rails (MeshCrossRail on SampleCurveArray points of the
  frame), vertical rails (the frame's path repeated across) or a solid panel (the frame's
  path swept with a panel profile) span the two frames; a MeshTopRail caps them;
  optionally the back curves in plan (the frames forward, the filling bowed back between
  them by UtilBowInPlan: a ladder-back's bowed rails, a shell back) and its top is arched
  (the top corners brought down by a smooth field over the whole chair);
  optionally the back is lifted off the seat onto a central post (MeshStraightFrame post
  and a yoke across the frames' feet: an office chair);
- armrests: from a point sampled on the frame forward, either a straight bar
  (MeshStraightFrame) with an optional support (MeshFrameFixedBottom) down into the seat
  and a pad, or a loop (MeshQuadraticPolarFrame) from the frame down into the seat; and
  optional side panels (a vertical MeshStraightFrame slab, up to a quarter of the seat
  thick) through the seat's sides, from the floor or the seat up to the arms' back
  attachment's height;
- the chair is scaled per axis and grounded so that its lowest point lies on z = 0.
Selectors reach the geometry only through Switch / Index Switch nodes, so visibility rules
are inferred from the graph. In Blender's node editor each piece is a node group: Seat,
Back Frame, Cushion, Legs, Monoleg, Backrest, Back Post, Armrests, Back Arch.
"""

from __future__ import annotations

import math

from geocode.nodes import (
    Graph,
    aligned_bevel_xy,
    bezier_segment_style,
    bow_in_plan,
    cross_rail,
    cushion_mesh,
    frame_fixed_bottom,
    leg_mesh,
    mirror,
    quadratic_cartesian_aligned_xy_frame,
    quadratic_cartesian_mesh,
    quadratic_polar_frame,
    radial,
    rectangle_fillet,
    sample_curve,
    sample_curve_array,
    seat,
    straight_frame,
    top_rail,
)

# labels (segmentation)
(SEAT, CUSHION, LEGS, BACK_FRAME, CROSS_RAILS, VERTICAL_RAILS, TOP_RAIL, BACK_PANEL,
 ARMRESTS, ARM_SUPPORTS, ARM_PADS, MONOLEG, TENT_LEGS, CASTERS, SIDE_PANELS,
 STRETCHERS, BACK_POST, APRON) = range(1, 19)

SEAT_SIZE = 0.5          # width and depth of the seat before the overall scale
LEG_INSET = 1.2          # legs sit this many radii inside the seat's corner
SINK = 0.5               # parts attached under/over a slab start this share inside it
TENT_HUB = 0.06          # height of the monoleg's foot above the floor with tent legs
TENT_COLUMN = 0.35       # a column on tent legs: this share of a pedestal's profile
CASTER_LIFT = 1.8        # tent legs' ends above the floor, in caster radii (sunk in the wheel)
CASTER_WIDTH = 0.8       # width of a caster wheel, in radii
STRETCHER_SHARE = 0.8    # a stretcher's width, in leg thicknesses (a leg is 2 wide, tapered 1)
APRON_SHARE = 0.6        # an apron's thickness, in leg thicknesses (within the legs' faces)
POST_WIDTH = 2.0         # the back post's width and its yoke's height, in frame widths
POST_DEPTH = 0.8         # the post's depth, in frame depths (within the yoke's faces)
PANEL_CUTS = 9           # points along each side of the panel's profile: it can bow
SEAT_CUTS = 7            # points along each side of the seat's outline: its back can bulge
WRAP_RISE = 0.25         # a wrapped back's bow grows over this lowest share of its rise
ARCH_ZONE = 0.5          # an arched back bends in this top share of its rise
PAD_SINK = 0.3           # share of an armrest pad sunk into its armrest
ARM_LOOP_BULGE = 0.35    # bulge of a loop armrest, as a share of its chord


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    for axis in "xyz":
        add(f"scale_{axis}", "float", 1.0, 0.8, 1.25, f"overall scale along {axis}")
    # seat and cushion
    add("seat_height", "float", 0.45, 0.35, 0.6, "height of the seat's top")
    add("seat_thickness", "float", 0.05, 0.03, 0.1, "thickness of the seat slab")
    add("seat_roundness", "float", 0.2, 0.0, 1.0, "seat outline: 0 square, 1 round")
    add("seat_bevel", "float", 0.05, 0.0, 0.2, "rounding of the seat's edges")
    add("seat_bulge", "float", 0.0, 0.0, 0.15,
        "how far the seat's back edge bows out behind its middle (a D-shaped seat)")
    add("cushion", "bool", False, 0, 1, "a pillow on the seat")
    add("cushion_thickness", "float", 0.05, 0.02, 0.07, "thickness of the pillow")
    add("cushion_fill", "float", 0.5, 0.0, 1.0, "pillow shape: 0 dome, 1 full")
    # four legs or a monoleg
    add("monoleg", "bool", False, 0, 1, "one central column instead of four legs")
    add("leg_thickness", "float", 0.025, 0.015, 0.04, "half-width of a leg at its top")
    add("leg_splay", "float", 0.02, 0.0, 0.08, "how far the feet spread outwards")
    add("leg_taper", "float", 0.8, 0.5, 1.2, "foot width / top width of a leg")
    add("leg_bevel", "float", 0.0, 0.0, 1.0, "leg profile: 0 square, 1 round")
    add("leg_curvature", "float", 0.5, 0.0, 1.0, "legs: 0 straight, 1 vertical at the top")
    add("back_leg_offset", "float", 0.03, 0.0, 0.1, "how far back the back feet reach")
    add("sled_base", "bool", False, 0, 1, "a runner on the floor joining each side's feet")
    add("sled_joined", "bool", False, 0, 1, "a tube across joining the runners at the back")
    add("stretchers", "int", 0, 0, 2, "bars between the legs: 0 none, 1 a box, 2 an H")
    add("stretcher_height", "float", 0.3, 0.15, 0.5, "stretchers' height (share of the legs)")
    add("apron", "bool", False, 0, 1, "rails under the seat from leg to leg (a wooden chair)")
    add("apron_height", "float", 0.06, 0.03, 0.12, "depth of the apron below the seat")
    add("monoleg_top_radius", "float", 0.06, 0.03, 0.12, "monoleg Bezier profile: top")
    add("monoleg_top_handle", "float", 0.06, 0.03, 0.12, "monoleg Bezier profile: upper handle")
    add("monoleg_bottom_handle", "float", 0.1, 0.05, 0.2, "monoleg Bezier profile: lower handle")
    add("monoleg_bottom_radius", "float", 0.22, 0.12, 0.3, "monoleg Bezier profile: foot")
    add("tent_legs", "bool", False, 0, 1, "legs spreading from the monoleg's foot")
    add("tent_leg_count", "int", 4, 3, 6, "number of tent legs")
    add("tent_leg_spread", "float", 0.3, 0.22, 0.38, "reach of the tent legs")
    add("tent_leg_thickness", "float", 0.02, 0.012, 0.03, "half-width of a tent leg")
    add("casters", "bool", False, 0, 1, "a caster wheel under each tent leg's end")
    add("caster_size", "float", 0.025, 0.015, 0.04, "radius of a caster wheel")
    # backrest frame
    add("backrest_height", "float", 0.45, 0.3, 0.6, "height of the backrest above the seat")
    add("backrest_slant", "float", 0.1, -0.05, 0.35, "backward lean of the backrest")
    add("backrest_curvature", "float", 0.0, -0.5, 0.5, "backward bow of the backrest")
    add("back_wrap", "bool", False, 0, 1, "the back curved in plan, its sides forward")
    add("back_wrap_depth", "float", 0.08, 0.02, 0.16,
        "how far the back's middle lies behind its sides (each moves half)")
    add("back_arch", "bool", False, 0, 1, "the back's top arched: its top corners lowered")
    add("back_arch_drop", "float", 0.2, 0.05, 0.4,
        "how far the top corners come down, as a share of the back's rise")
    add("back_frame_offset", "float", 0.0, 0.0, 0.5, "frames moved in from the seat corners")
    add("frame_width", "float", 0.04, 0.02, 0.06, "width of the backrest frames")
    add("frame_depth", "float", 0.04, 0.02, 0.06, "depth of the backrest frames")
    add("frame_roundness", "float", 0.0, 0.0, 1.0, "frame profile: 0 square, 1 round")
    add("rail_bevel", "float", 0.0, 0.0, 0.6, "bevel of the frames' top ends")
    add("back_post", "bool", False, 0, 1, "the backrest lifted off the seat on one central post")
    add("back_post_gap", "float", 0.1, 0.05, 0.2, "backrest's foot above the seat's top")
    # backrest filling
    add("backrest_solid", "bool", False, 0, 1, "a solid panel instead of rails")
    add("solid_thickness", "float", 0.025, 0.015, 0.04, "thickness of the solid panel")
    add("vertical_rails", "bool", False, 0, 1, "vertical rails instead of cross rails")
    add("cross_rail_count", "int", 2, 1, 4, "number of cross rails")
    add("cross_rail_thickness_y", "float", 0.02, 0.01, 0.03, "cross rail depth")
    add("cross_rail_thickness_z", "float", 0.04, 0.02, 0.08, "cross rail height")
    add("cross_rail_bottom_offset", "float", 0.3, 0.1, 0.5, "lowest cross rail (share of backrest)")
    add("cross_rail_top_offset", "float", 0.7, 0.3, 0.9, "highest cross rail (share of backrest)")
    add("cross_rail_roundness", "float", 0.0, 0.0, 1.0, "cross rail profile: square to round")
    add("vertical_rail_count", "int", 3, 1, 5, "number of vertical rails")
    add("vertical_rail_size", "float", 0.025, 0.01, 0.04, "width of a vertical rail")
    add("vertical_rail_roundness", "float", 0.0, 0.0, 1.0, "vertical rail profile")
    add("top_rail", "bool", True, 0, 1, "a rail across the frames' tops")
    add("top_rail_size", "float", 0.08, 0.04, 0.14, "height of the top rail")
    add("top_rail_depth", "float", 0.04, 0.02, 0.12, "depth of the top rail (a crest rail)")
    add("top_rail_roundness", "float", 0.0, 0.0, 1.0, "top rail profile: square to round")
    add("top_rail_fill", "float", 0.0, 0.0, 0.5, "swelling of the top rail's middle")
    # armrests
    add("armrest_style", "int", 0, 0, 2, "armrests: 0 none, 1 straight, 2 loop")
    add("armrest_support", "bool", True, 0, 1, "a support under a straight armrest")
    add("armrest_cushion", "bool", False, 0, 1, "a pad on a straight armrest")
    add("armrest_width", "float", 0.04, 0.02, 0.07, "width of an armrest")
    add("armrest_height", "float", 0.03, 0.02, 0.05, "height of an armrest's profile")
    add("armrest_roundness", "float", 0.0, 0.0, 1.0, "armrest profile: square to round")
    add("armrest_back_height", "float", 0.5, 0.35, 0.8, "attachment on the frame (share)")
    add("armrest_front_height", "float", 1.0, 0.7, 1.3, "front height / back height")
    add("armrest_mid", "float", 0.0, -0.6, 0.6, "where a loop armrest bulges (angle)")
    add("armrest_edge", "float", 0.8, 0.6, 1.0, "front attachment along the seat side")
    add("armrest_pad_thickness", "float", 0.02, 0.01, 0.03, "thickness of the pad")
    add("side_panels", "bool", False, 0, 1, "a solid slab along each side up to the arm height")
    add("side_panel_drop", "float", 1.0, 0.0, 1.0,
        "side panels' foot: 0 in the seat, 1 on the floor")
    add("side_panel_thickness", "float", 0.04, 0.02, 0.125,
        "thickness of a side panel (0.125: a quarter of the seat, a blocky armchair)")
    return p


class _Chair:
    """The seat and the anchors the other parts follow, so that every attached part
    follows edits: the seat corner, a height inside the slab, and the back frames' x."""

    def __init__(self, g: Graph, p: dict):
        self.g, self.p = g, p
        slab = seat(g, width=SEAT_SIZE, depth=SEAT_SIZE, roundness=p["seat_roundness"],
                    cuts=SEAT_CUTS, top=p["seat_height"], thickness=p["seat_thickness"],
                    bevel=p["seat_bevel"], label=SEAT)
        self.seat = self.bulged(slab["Mesh"])
        corner = slab["Corner"]
        self.corner_x = g.named("corner x", corner.x)
        self.corner_y = g.named("corner y", corner.y)
        # attachments start inside the slab: halfway down from its top
        self.inside = g.named("inside", p["seat_height"] - p["seat_thickness"] * SINK)
        # x of the right frame's axis: inside the seat corner, moved in by the offset
        x = self.corner_x - p["frame_width"] * 0.5
        self.frame_x = g.named("frame x", x * (1.0 - p["back_frame_offset"]))
        # y of the frames' axis (half a wrap forward), and their foot's lift above `inside`
        # (on a back post)
        self.wrap = g.named("back wrap", g.when(p["back_wrap"], p["back_wrap_depth"], 0.0))
        self.frame_y = g.named("frame y",
                               self.corner_y - p["frame_depth"] * 0.5 - self.wrap * 0.5)
        gap = p["back_post_gap"] + p["seat_thickness"] * SINK   # from `inside`
        self.lift = g.named("back lift", g.when(p["back_post"], gap, 0.0))

    def bulged(self, mesh):
        """`mesh` (the seat or its pillow) with its back half bowed out behind by up to
        `seat_bulge` in the middle, growing from nothing at y = 0 to all of it at the back
        edge: a D-shaped seat. The sides (|x| = half the seat) stay, and so does every
        part attached inside the outline: the seat only grows."""
        g = self.g
        half = SEAT_SIZE * 0.5
        grown = g.clamp(g.position().y / half)
        return bow_in_plan(g, geometry=mesh, depth=self.p["seat_bulge"] * grown,
                           half_width=half)["Geometry"]

    # -- backrest frame -------------------------------------------------------------------

    def above_seat(self, share):
        """The frame's factor at `share` of its part above the seat's top (the frame starts
        inside the slab), so attachments never vanish into the seat."""
        p = self.p
        sunk = p["seat_thickness"] * SINK
        start = sunk / (p["backrest_height"] + sunk)
        return self.g.lerp(start, 1.0, share)

    def build_frame(self):
        """The right back frame: from inside the seat's back corner (moved in by `frame_x`;
        with `back_post`, from `back_post_gap` above the seat's top instead) up by
        `backrest_height` (+ the sunk share of the slab), leaning back by `backrest_slant`
        x rise and bowed back by `backrest_curvature` x rise / 4."""
        g, p = self.g, self.p
        rise = p["backrest_height"] + p["seat_thickness"] * SINK
        bottom = g.vec(self.frame_x, self.frame_y, self.inside + self.lift)
        top = bottom + g.vec(0.0, p["backrest_slant"] * rise, rise)
        bow = g.vec(0.0, p["backrest_curvature"] * (rise * 0.25), 0.0)
        frame = quadratic_cartesian_aligned_xy_frame(
            g, start=bottom, end=top, offset=bow, width=p["frame_width"],
            depth=p["frame_depth"], roundness=p["frame_roundness"], bevel=p["rail_bevel"],
            label=BACK_FRAME)
        self.frame_curve = g.named("frame path", frame["Curve"])
        self.frame = frame["Mesh"]

    def frame_sweep(self, width, depth, roundness, label, cuts=0):
        """The frame's path moved to x = 0 and swept with another profile (panels, rails),
        `cuts` more points along each side of the profile."""
        g = self.g
        centred = g.transform(self.frame_curve, translation=g.vec(-self.frame_x, 0.0, 0.0))
        profile = rectangle_fillet(g, width=width, height=depth, roundness=roundness,
                                   resolution=2, cuts=cuts)["Curve"]
        return aligned_bevel_xy(g, curve=centred, profile_curve=profile, radius=1.0,
                                fill_caps=True, label=label)["Mesh"]


def _cushion(c: _Chair):
    """When `cushion`: a pillow on the seat's outline, its bottom sunk 20% of the slab."""
    g, p = c.g, c.p
    pillow = cushion_mesh(g, width=SEAT_SIZE * 0.97, depth=SEAT_SIZE * 0.97,
                          roundness=p["seat_roundness"], cuts=SEAT_CUTS,
                          bottom=p["seat_height"] - p["seat_thickness"] * 0.2,
                          thickness=p["cushion_thickness"], fill=p["cushion_fill"],
                          label=CUSHION)
    return g.when(p["cushion"], c.bulged(pillow["Mesh"]))


# -- legs -------------------------------------------------------------------------------------

def _four_legs(c: _Chair):
    """Unless `monoleg`: the right front and back legs (the left ones come from the chair's
    mirror), from inside the slab at the seat corner moved in by 1.2 radii, to feet spread
    by `leg_splay` (the back ones `back_leg_offset` further back); with `sled_base`, a
    runner on the floor through both feet."""
    g, p = c.g, c.p
    inset = p["leg_thickness"] * LEG_INSET
    x, y = c.corner_x - inset, c.corner_y - inset
    splay = p["leg_splay"]
    feet = {"front": g.vec(x + splay, -y - splay, 0.0),
            "back": g.vec(x + splay, y + splay + p["back_leg_offset"], 0.0)}
    tops = {"front": g.vec(x, -y, c.inside), "back": g.vec(x, y, c.inside)}
    legs = {k: leg_mesh(g, top=tops[k], bottom=feet[k], curvature=p["leg_curvature"],
                        top_radius=p["leg_thickness"],
                        bottom_radius=p["leg_thickness"] * p["leg_taper"],
                        roundness=p["leg_bevel"], label=LEGS) for k in ("front", "back")}
    runner = g.when(p["sled_base"], _sled(c, feet["front"], feet["back"]))
    stretchers = _stretchers(c, legs["front"]["Curve"], legs["back"]["Curve"])
    apron = g.when(p["apron"], _apron(c, tops["front"], tops["back"]))
    return g.when(p["monoleg"], None, g.join([legs["front"]["Mesh"], legs["back"]["Mesh"],
                                              runner, stretchers, apron]))


def _sled(c: _Chair, front, back):
    """The right runner: a tube as thick as the feet, its axis through the feet (so it is
    the lowest part and the legs end in it), from one foot radius before the front foot to
    one behind the back foot; with `sled_joined`, half of a tube across at the back (the
    mirror adds the other half)."""
    g, p = c.g, c.p
    radius = p["leg_thickness"] * p["leg_taper"]
    start = g.vec(front.x, front.y - radius, 0.0)
    end = g.vec(back.x, back.y + radius, 0.0)
    runner = straight_frame(g, start=start, end=end, width=radius * 2.0, depth=radius * 2.0,
                            roundness=p["leg_bevel"], label=LEGS)["Mesh"]
    across = straight_frame(g, start=g.vec(0.0, back.y, 0.0),
                            end=g.vec(back.x, back.y, 0.0), width=radius * 2.0,
                            depth=radius * 2.0, roundness=p["leg_bevel"],
                            axis=(0.0, 1.0, 0.0), label=LEGS)["Mesh"]
    return g.join([runner, g.when(p["sled_joined"], across)])


def _apron(c: _Chair, front, back):
    """The right side rail from the front leg's top to the back one's and the right halves
    of the rails across the front and the back (the mirror adds the rest): from inside the
    slab down to `apron_height` under the seat, on the legs' top axes, `APRON_SHARE` leg
    thicknesses thick."""
    g, p = c.g, c.p
    bottom = p["seat_height"] - p["seat_thickness"] - p["apron_height"]
    z = (c.inside + bottom) * 0.5
    height, thickness = c.inside - bottom, p["leg_thickness"] * APRON_SHARE

    def rail(start, end):   # upright: `height` along z
        return straight_frame(g, start=start, end=end, width=height, depth=thickness,
                              roundness=0.0, axis=(0.0, 0.0, 1.0), label=APRON)["Mesh"]

    side = rail(g.vec(front.x, front.y, z), g.vec(back.x, back.y, z))
    across = [rail(g.vec(0.0, end.y, z), g.vec(end.x, end.y, z)) for end in (front, back)]
    return g.join([side, *across])


def _stretchers(c: _Chair, front_axis, back_axis):
    """By `stretchers`: none; a box (the right side bar from the front leg to the back one,
    and the right halves of the bars across the front and the back, from x = 0: the mirror
    adds the rest); or an H (the side bar and the right half of one bar across from its
    middle). The ends are sampled at `stretcher_height` of the length from the foot on the
    very curves the legs are swept along, so they lie on the legs' axes for any splay,
    offset or curvature; the bars are `STRETCHER_SHARE` leg thicknesses wide, narrower than
    a leg anywhere along it (its half-width is at least half the top's for any taper)."""
    g, p = c.g, c.p
    factor = 1.0 - p["stretcher_height"]   # the curves run from the top down to the foot
    front = sample_curve(g, curve=front_axis, factor=factor)["Position"]
    back = sample_curve(g, curve=back_axis, factor=factor)["Position"]
    size = p["leg_thickness"] * STRETCHER_SHARE

    def bar(start, end, axis=(1.0, 0.0, 0.0)):
        return straight_frame(g, start=start, end=end, width=size, depth=size,
                              roundness=p["leg_bevel"], axis=axis, label=STRETCHERS)["Mesh"]

    def across(point):   # the right half of a bar across, ending on `point`
        return bar(g.vec(0.0, point.y, point.z), point, axis=(0.0, 1.0, 0.0))

    side = bar(front, back)
    box = g.join([side, across(front), across(back)])
    h_frame = g.join([side, across((front + back) * 0.5)])
    return g.index_switch(p["stretchers"], [None, box, h_frame])


def _monoleg(c: _Chair):
    """When `monoleg`: a column under the seat's centre whose silhouette is a Bezier profile:
    a pedestal standing on its foot; or, with tent legs, a slim column (the profile scaled
    by `TENT_COLUMN`: a gas lift, a bar stool's stem) whose foot is lifted by `TENT_HUB`
    (and the casters' height) and joined into the legs that carry the chair."""
    g, p = c.g, c.p
    lift = g.when(p["casters"], p["caster_size"] * CASTER_LIFT, 0.0)
    foot = g.when(p["tent_legs"], lift + TENT_HUB, 0.0)
    path = g.line(g.vec(0.0, 0.0, c.inside), g.vec(0.0, 0.0, foot), count=12)
    profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=1.0,
                               resolution=3)["Curve"]
    slim = g.when(p["tent_legs"], TENT_COLUMN, 1.0)
    column = bezier_segment_style(
        g, curve=path, profile_curve=profile, start=p["monoleg_top_radius"] * slim,
        start_handle=p["monoleg_top_handle"] * slim,
        end_handle=p["monoleg_bottom_handle"] * slim, end=p["monoleg_bottom_radius"] * slim,
        fill_caps=True, label=MONOLEG)["Mesh"]
    monoleg = g.join([column, g.when(p["tent_legs"], _tent_legs(c, foot, lift))])
    return g.when(p["monoleg"], monoleg)


def _tent_legs(c: _Chair, foot, lift):
    """`tent_leg_count` legs from 3 cm above the column's foot out to `tent_leg_spread`,
    their ends `lift` above the floor: on the floor, or on casters."""
    g, p = c.g, c.p
    hub = g.vec(0.0, 0.0, foot + 0.03)
    toe = g.vec(p["tent_leg_spread"], 0.0, lift)
    # the middle control point above the toe: the leg ends vertically on the floor (caster)
    offset = g.vec(p["tent_leg_spread"] * 0.5, 0.0, 0.0)
    one = quadratic_cartesian_mesh(g, start=hub, end=toe, offset=offset,
                                   radius=p["tent_leg_thickness"], roundness=1.0,
                                   axis=(0.0, 1.0, 0.0), label=TENT_LEGS)["Mesh"]
    leg = g.join([one, g.when(p["casters"], _caster(c, toe))])
    # one leg always points backwards (+y), under the backrest
    return radial(g, geometry=leg, count=p["tent_leg_count"], radius=0.0,
                  start_angle=math.pi / 2)["Geometry"]


def _caster(c: _Chair, toe):
    """A wheel of radius `caster_size` standing on the floor under the toe (the leg's end
    sunk into its top), its axle across the leg."""
    g, p = c.g, c.p
    r = p["caster_size"]
    half = r * CASTER_WIDTH * 0.5
    return straight_frame(g, start=g.vec(toe.x, -half, r), end=g.vec(toe.x, half, r),
                          width=r * 2.0, depth=r * 2.0, roundness=1.0, label=CASTERS)["Mesh"]


# -- backrest -------------------------------------------------------------------------------

def _cross_rails(c: _Chair):
    """`cross_rail_count` rails between the frames, spread from `cross_rail_bottom_offset`
    to `cross_rail_top_offset` of the frame above the seat."""
    g, p = c.g, c.p
    points = sample_curve_array(g, curve=c.frame_curve, count=p["cross_rail_count"],
                                start_margin=c.above_seat(p["cross_rail_bottom_offset"]),
                                end_margin=1.0 - c.above_seat(p["cross_rail_top_offset"]),
                                )["Points"]
    return cross_rail(g, points=points, half_length=c.frame_x,
                      thickness_y=p["cross_rail_thickness_y"],
                      thickness_z=p["cross_rail_thickness_z"],
                      roundness=p["cross_rail_roundness"], label=CROSS_RAILS)["Mesh"]


def _vertical_rails(c: _Chair):
    """`vertical_rail_count` copies of the frame's path spread evenly between the two
    frames (margins 1 / (count + 1) of the span)."""
    g, p = c.g, c.p
    one = c.frame_sweep(p["vertical_rail_size"], p["frame_depth"] * 0.6,
                        p["vertical_rail_roundness"], VERTICAL_RAILS)
    x = c.frame_x
    across = g.line(g.vec(-x, 0.0, 0.0), g.vec(x, 0.0, 0.0))
    margin = 1.0 / (p["vertical_rail_count"] + 1.0)
    points = sample_curve_array(g, curve=across, count=p["vertical_rail_count"],
                                start_margin=margin, end_margin=margin)["Points"]
    return g.instance_on_points(points, one)


def _top_rail(c: _Chair):
    """When `top_rail`: a rail over the frames' top ends, reaching their outer sides."""
    g, p = c.g, c.p
    end = sample_curve(g, curve=c.frame_curve, factor=1.0)
    mesh = top_rail(g, center=end["Position"], tangent=end["Tangent"],
                    half_length=c.frame_x + p["frame_width"] * 0.5,
                    size=p["top_rail_size"], depth=p["top_rail_depth"],
                    roundness=p["top_rail_roundness"], fill=p["top_rail_fill"],
                    label=TOP_RAIL)["Mesh"]
    return g.when(p["top_rail"], mesh)


def _backrest(c: _Chair):
    """Between the frames: a solid panel (`backrest_solid`), else cross or vertical rails
    with the optional top rail; with `back_wrap`, bowed back in the middle by its depth, its
    ends in the frames (moved forward by half of it) staying where they are, the bow growing
    over the lowest WRAP_RISE of the rise, so the filling's foot stays in the seat or on the
    back post's yoke."""
    g, p = c.g, c.p
    rails = g.when(p["vertical_rails"], _vertical_rails(c), _cross_rails(c))
    open_back = g.join([rails, _top_rail(c)])
    panel = c.frame_sweep(c.frame_x * 2.0, p["solid_thickness"], 0.0, BACK_PANEL, PANEL_CUTS)
    filling = g.when(p["backrest_solid"], panel, open_back)
    rise = (p["backrest_height"] + p["seat_thickness"] * SINK) * WRAP_RISE
    grown = g.clamp((g.position().z - c.inside - c.lift) / rise)
    return bow_in_plan(g, geometry=filling, depth=c.wrap * grown,
                       half_width=c.frame_x)["Geometry"]


def _back_post(c: _Chair):
    """When `back_post` (an office chair's back): a yoke across the frames' lifted feet (its
    middle at their foot's height, so they end inside it) and one post in the middle from
    inside the seat slab up to the yoke's middle; both on the frames' axis in y (inside the
    seat for every roundness: the seat reaches furthest back at x = 0), `POST_WIDTH` frame
    widths wide or tall; the post a little shallower than the yoke, so that no faces of
    the two coincide. Built whole, not mirrored."""
    g, p = c.g, c.p
    size = p["frame_width"] * POST_WIDTH
    foot = c.inside + c.lift
    yoke = straight_frame(g, start=g.vec(-c.frame_x, c.frame_y, foot),
                          end=g.vec(c.frame_x, c.frame_y, foot), width=p["frame_depth"],
                          depth=size, roundness=p["frame_roundness"], axis=(0.0, 1.0, 0.0),
                          label=BACK_POST)["Mesh"]
    post = straight_frame(g, start=g.vec(0.0, c.frame_y, c.inside),
                          end=g.vec(0.0, c.frame_y, foot), width=size,
                          depth=p["frame_depth"] * POST_DEPTH,
                          roundness=p["frame_roundness"], label=BACK_POST)["Mesh"]
    return g.when(p["back_post"], g.join([yoke, post]))


# -- armrests -------------------------------------------------------------------------------

class _Arm:
    """The right armrest's attachment points: on the frame at `armrest_back_height` (of
    its part above the seat), and over/on the seat at `armrest_edge` along its side."""

    def __init__(self, c: _Chair):
        g, p = c.g, c.p
        self.x = c.frame_x
        self.back = sample_curve(g, curve=c.frame_curve,
                                 factor=c.above_seat(p["armrest_back_height"]))["Position"]
        # between the back corner (edge 0) and the mirrored front corner (edge 1): the
        # segment lies inside the (convex, symmetric) seat for every roundness
        corner_y = c.corner_y - p["frame_depth"] * 0.5
        self.front_y = g.lerp(corner_y, -corner_y, p["armrest_edge"])
        self.seat_point = g.vec(self.x, self.front_y, c.inside)


def _straight_arm(c: _Chair, arm: _Arm):
    """A bar from the frame forward, its front end at `armrest_front_height` x the back
    end's height above the seat; a support down into the seat; a pad on top."""
    g, p = c.g, c.p
    rise = arm.back.z - p["seat_height"]
    front = g.vec(arm.x, arm.front_y, p["seat_height"] + rise * p["armrest_front_height"])
    bar = straight_frame(g, start=arm.back, end=front, width=p["armrest_width"],
                         depth=p["armrest_height"], roundness=p["armrest_roundness"],
                         label=ARMRESTS)["Mesh"]
    support = frame_fixed_bottom(g, bottom=arm.seat_point, top=front, curvature=1.0,
                                 width=p["armrest_width"] * 0.6,
                                 depth=p["armrest_width"] * 0.6,
                                 roundness=p["armrest_roundness"], label=ARM_SUPPORTS)["Mesh"]
    lift = g.vec(0.0, 0.0,
                 (p["armrest_height"] + p["armrest_pad_thickness"]) * (0.5 - PAD_SINK))
    pad = straight_frame(g, start=arm.back + lift, end=front + lift,
                         width=p["armrest_width"] * 1.2,
                         depth=p["armrest_pad_thickness"], roundness=1.0,
                         label=ARM_PADS)["Mesh"]
    return g.join([bar, g.when(p["armrest_support"], support),
                   g.when(p["armrest_cushion"], pad)])


def _loop_arm(c: _Chair, arm: _Arm):
    """A curve from the frame forward and down into the seat, bulging by a third of its
    chord at angle `armrest_mid`. QuadraticPolar bends in the XZ plane, so the arm is built
    turned by -90 degrees about Z and turned back."""
    g, p = c.g, c.p

    def to_local(point):  # world (x, y, z) -> local (y, -x, z)
        return g.vec(point.y, -point.x, point.z)

    start, end = to_local(arm.back), to_local(arm.seat_point)
    loop = quadratic_polar_frame(g, start=start, end=end, angle=p["armrest_mid"],
                                 distance=g.distance(start, end) * ARM_LOOP_BULGE,
                                 width=p["armrest_width"], depth=p["armrest_height"],
                                 roundness=p["armrest_roundness"], axis=(0.0, -1.0, 0.0),
                                 label=ARMRESTS)["Mesh"]
    return g.transform(loop, rotation=(0.0, 0.0, math.pi / 2))


def _side_panel(c: _Chair, arm: _Arm):
    """When `side_panels`: a slab `side_panel_thickness` thick standing on the seat's side
    (centred on the corner's x, so half of it is in the slab for every roundness: the seat
    is convex and symmetric, so its outline reaches past the corner's x between the back
    corner and the front attachment), from the seat's back edge to the arms' front
    attachment, up to their back attachment's height; its foot goes from inside the slab
    (`side_panel_drop` 0) down to the floor (1). A thick slab swallows the frame's foot and
    carries the arm on its top, as the solid sides of an upholstered armchair do."""
    g, p = c.g, c.p
    back_y = c.corner_y
    middle_y = (back_y + arm.front_y) * 0.5
    bottom = c.inside * (1.0 - p["side_panel_drop"])
    panel = straight_frame(g, start=g.vec(c.corner_x, middle_y, bottom),
                           end=g.vec(c.corner_x, middle_y, arm.back.z),
                           width=back_y - arm.front_y, depth=p["side_panel_thickness"],
                           roundness=p["armrest_roundness"], axis=(0.0, 1.0, 0.0),
                           label=SIDE_PANELS)["Mesh"]
    return g.when(p["side_panels"], panel)


def _armrests(c: _Chair):
    """By `armrest_style`: none, straight or loop; and the optional side panels (under
    the arms, or alone: the solid sides of an upholstered armchair)."""
    arm = _Arm(c)
    arms = c.g.index_switch(c.p["armrest_style"], [None, _straight_arm(c, arm),
                                                   _loop_arm(c, arm)])
    return c.g.join([arms, _side_panel(c, arm)])


def _arched(c: _Chair, chair):
    """With `back_arch`, every point of `chair` in the top ARCH_ZONE of the back's rise moved
    down by `back_arch_drop` x the rise x (|x| / the frames' outer x)^2 x its share of the
    way up the zone: the top corners come down into an arch, the middle stays. A smooth
    field, so every part stays joined to what it touched; the seat lies under the zone."""
    g, p = c.g, c.p
    rise = p["backrest_height"] + p["seat_thickness"] * SINK
    zone = rise * ARCH_ZONE
    bottom = c.inside + c.lift + rise - zone
    across = g.min(abs(g.position().x) / (c.frame_x + p["frame_width"] * 0.5), 1.0)
    up = g.clamp((g.position().z - bottom) / zone)
    drop = g.when(p["back_arch"], p["back_arch_drop"] * rise, 0.0)
    return g.set_position(chair, offset=g.vec(0.0, 0.0, -drop * across * across * up))


# -- assembly -------------------------------------------------------------------------------

def build(g: Graph) -> None:
    with g.frame("Parameters"):
        p = _parameters(g)
    with g.group("Seat"):
        c = _Chair(g, p)
    with g.group("Back Frame"):
        c.build_frame()
    with g.group("Cushion"):
        pillow = _cushion(c)
    with g.group("Legs"):
        legs = _four_legs(c)
    with g.group("Monoleg"):
        monoleg = _monoleg(c)
    with g.group("Backrest"):
        backrest = _backrest(c)
    with g.group("Back Post"):
        post = _back_post(c)
    with g.group("Armrests"):
        armrests = _armrests(c)
    with g.frame("Assembly"):
        # the right side is mirrored in x; the chair is scaled per axis and then rests on z = 0
        right = g.join([legs, c.frame, armrests])
        chair = g.join([c.seat, pillow, mirror(g, geometry=right, axis=0)["Geometry"],
                        monoleg, backrest, post])
    with g.group("Back Arch"):
        arched = _arched(c, chair)
    with g.frame("Scale"):
        scaled = g.transform(arched, scale=g.vec(p["scale_x"], p["scale_y"], p["scale_z"]))
        g.output("Geometry", "geometry", g.ground(scaled))
