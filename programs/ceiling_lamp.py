"""The ceiling lamp program: a canopy on the ceiling and a chandelier (a rod, arms leaving a
hub on the rod, a shade with a bulb at the end of each arm), a pendant (one shade hanging
from the rod's end, `pendant`) or a flush mount (a shade upside down right under the canopy:
a dome, a drum; `flush`) (24 parameters: 4 discrete, 20 continuous).

Layout: z = up, the ceiling is the plane z = 0 and the lamp hangs below it. Structure
(every part hangs from the canopy through the others, for every parameter combination):
- canopy: a sweep of a RectangleFillet outline (square to round) whose top lies on the
  ceiling, narrowing downwards by `canopy_taper` (a dome-like cap, or a flat plate at 0);
- rod (not flush): a MeshStraightFrame from inside the canopy straight down by
  `rod_length` (a thin one is a cord);
- hub (a chandelier): a cylinder on the rod at the point sampled at `arm_attach` of the
  rod's length (SampleCurve), so the arms follow the rod when it lengthens; on a short rod
  it stays low enough for the arms to clear the canopy (the rod then reaches down to it);
- arms (a chandelier): a MeshQuadraticCartesian from inside the hub out to
  `hub_radius + arm_length` and `arm_rise` up, bowed up by `arm_curvature` (it always
  arrives level or falling, so it never runs through its shade), copied about the rod by
  SymmetryRadial;
- socket (not flush): a short vertical cylinder around each arm's end, or the rod's end
  for a pendant (at least as wide as a cord's socket);
- shade: a StyleShell (open rim, closed top, a wall of `shade_thickness`) hanging from the
  socket, which pierces its top; its profile along the height is a cone, a bell, a cylinder
  (a box when square), a globe or a dome (an Index Switch). A chandelier's rims
  (`shade_size`) shrink where needed so that neighbouring shades never touch each other or
  the hub; a pendant's shade hangs on the rod's axis; a flush mount's is upside down, its
  open rim inside the canopy (shrunk where needed to fit in it) and its closed end
  FLUSH_DEPTH `shade_height` below that: low-profile (a dome shade makes a bowl);
- bulb (not flush): a round sweep hanging from the socket's bottom inside the shade.
The choices are Switches on `flush` (over everything) and `pendant` (over the arms), so the
visibility rules follow from them.
Labels: canopy 1, rod 2, hub 3, arms 4, sockets 5, shades 6, bulbs 7.
The lamp hangs: `HANGS` tells the evaluation that a drop test does not apply to it.
"""

from __future__ import annotations

import math

from geocode.nodes import (
    Graph,
    align_curve_tilt_to_axis,
    quadratic_cartesian_mesh,
    radial,
    rectangle_fillet,
    sample_curve,
    shell,
    straight_frame,
    sweep,
)

HANGS = True  # hung from the ceiling: valid = one piece; no drop test (stability "n/a")

CANOPY, ROD, HUB, ARMS, SOCKETS, SHADES, BULBS = range(1, 8)
CONE, BELL, CYLINDER, GLOBE, DOME = range(5)

SOCKET_LENGTH = 0.035   # a socket reaches this far below its arm's end ...
SOCKET_WIDTH = 1.8      # ... and is this many arm radii wide
SHADE_GAP = 0.85        # a shade's half-width stays below this share of the free room
BULB_FIT = 0.6          # a bulb's radius stays below this share of its shade's rim
GLOBE_RIM = 0.25        # a globe's bottom opening, per unit of its width
DOME_TOP = 0.2          # a dome's (flat) top, per unit of its rim
CORD_SOCKET = 0.006     # a pendant's socket is SOCKET_WIDTH times at least this radius wide
UNCROWDED = 1.0         # the room of a pendant's shade: more than any rim
FLUSH_FIT = 0.9         # a flush mount's rim stays within this share of the canopy's middle
FLUSH_DEPTH = 0.5       # a flush mount's shade is this share of shade_height deep (low-profile)
SHADE_RINGS = 10        # path points along a shade's height
# the arch of an arm: its middle control point rises up to this share of the arm's length
# above the arm's end (kept below the ceiling for every combination of the ranges)
ARM_ARCH = 0.2


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    add("pendant", "bool", False, 0, 1, "one shade hanging from the rod, no hub or arms")
    add("flush", "bool", False, 0, 1, "a flush mount: the shade upside down under the canopy")
    add("canopy_radius", "float", 0.08, 0.05, 0.14, "half-width of the canopy on the ceiling")
    add("canopy_height", "float", 0.03, 0.02, 0.06, "height of the canopy")
    add("canopy_roundness", "float", 1.0, 0.0, 1.0, "canopy outline: 0 square, 1 round")
    add("canopy_taper", "float", 0.4, 0.0, 0.6, "how much the canopy narrows: 0 a flat plate")
    add("rod_length", "float", 0.5, 0.05, 0.9, "length of the rod below the canopy")
    add("rod_thickness", "float", 0.01, 0.003, 0.018, "radius of the rod")
    add("arm_attach", "float", 1.0, 0.5, 1.0, "where the hub sits on the rod (fraction)")
    add("hub_radius", "float", 0.04, 0.025, 0.08, "radius of the hub the arms leave from")
    add("hub_height", "float", 0.04, 0.03, 0.08, "height of the hub")
    add("arm_count", "int", 5, 2, 8, "number of arms (radial symmetry)")
    add("arm_length", "float", 0.3, 0.15, 0.45, "radial reach of an arm beyond the hub")
    add("arm_rise", "float", -0.05, -0.25, 0.08, "height of an arm's end above its start")
    add("arm_curvature", "float", 0.4, 0.0, 1.0, "arm bow: 0 arrives level, 1 arches up")
    add("arm_thickness", "float", 0.008, 0.005, 0.012, "radius of an arm")
    add("shade_shape", "int", CONE, CONE, DOME,
        "shade: 0 cone, 1 bell, 2 cylinder, 3 globe, 4 dome")
    add("shade_size", "float", 0.1, 0.05, 0.16, "half-width of a shade's rim")
    add("shade_height", "float", 0.12, 0.04, 0.22, "height of a shade")
    add("shade_top", "float", 0.4, 0.2, 0.8, "top width per rim width (cone, bell, globe)")
    add("shade_flare", "float", 0.5, 0.0, 1.0, "how sharply a bell flares at its rim")
    add("shade_roundness", "float", 1.0, 0.0, 1.0, "shade cross-section: 0 square, 1 round")
    add("shade_thickness", "float", 0.005, 0.003, 0.01, "thickness of a shade's wall")
    add("bulb_size", "float", 0.025, 0.015, 0.04, "radius of a bulb")
    return p


def _vertical_path(g: Graph, x, start, end, points: int):
    """Vertical path at distance x from the axis (on +X) from z=start to z=end (up or
    down), its profile's X pinned to world X."""
    path = g.line(g.vec(x, 0.0, start), g.vec(x, 0.0, end), count=points)
    return align_curve_tilt_to_axis(g, curve=path, axis=(1.0, 0.0, 0.0))["Curve"]


def _outline(g: Graph, roundness, resolution: int):
    """A 2 x 2 square-to-round outline: sweeps scale it by their half-width."""
    return rectangle_fillet(g, width=2.0, height=2.0, roundness=roundness,
                            resolution=resolution)["Curve"]


def _corner_reach(roundness):
    """How far the outline reaches from its centre, per unit half-width: sqrt(2) for a
    square, 1 for a circle."""
    return (1.0 - roundness) * math.sqrt(2.0) + roundness


def _canopy(g: Graph, p: dict):
    """Half-width canopy_radius (1 - canopy_taper (1 - t)^2) at t = (z + canopy_height) /
    canopy_height, from z = -canopy_height up to the ceiling."""
    path = _vertical_path(g, 0.0, -p["canopy_height"], 0.0, 6)
    below = 1.0 - g.spline_factor()
    scale = p["canopy_radius"] * (1.0 - p["canopy_taper"] * below * below)
    return sweep(g, curve=path, profile_curve=_outline(g, p["canopy_roundness"], 4),
                 scale=scale, fill_caps=True, label=CANOPY)["Mesh"]


def _upright(g: Graph, top, bottom, radius, label):
    """A vertical cylinder of `radius` on the axis from z=top down to z=bottom."""
    return straight_frame(g, start=g.vec(0.0, 0.0, top), end=g.vec(0.0, 0.0, bottom),
                          width=radius * 2.0, depth=radius * 2.0, roundness=1.0, label=label)


def _arm_lift(p: dict):
    """Height of an arm's middle control point above its start: half the rise, plus the arch
    of arm_curvature ARM_ARCH arm_length."""
    return p["arm_rise"] * 0.5 + p["arm_curvature"] * p["arm_length"] * ARM_ARCH


def _hub_z(g: Graph, p: dict, sampled):
    """The hub's height: where the rod is sampled, but at least as far below the canopy's
    middle as the hub and the arms reach above it (an arm stays inside the hull of its
    control points: max(0, lift, rise), its socket 1.5 arm radii higher), so that on a
    short rod the arms clear the canopy."""
    reach = g.max(g.max(_arm_lift(p), p["arm_rise"]), 0.0) + p["arm_thickness"] * 1.5
    clear = g.max(reach, p["hub_height"] * 0.5) + p["canopy_height"] * 0.5
    return g.min(sampled, -clear)


def _arm(g: Graph, p: dict, hub_z):
    """The arm on +X (the radial copies make the others): a quadratic curve from
    (hub_radius / 2, 0, hub_z) inside the hub to its end (hub_radius + arm_length, 0,
    hub_z + arm_rise), the middle control point arm_curvature ARM_ARCH arm_length above the
    end's height: the arm arrives level or falling, never up through its shade."""
    end = g.named("arm_end", g.vec(p["hub_radius"] + p["arm_length"], 0.0,
                                   hub_z + p["arm_rise"]))
    mesh = quadratic_cartesian_mesh(
        g, start=g.vec(p["hub_radius"] * 0.5, 0.0, hub_z), end=end,
        offset=g.vec(0.0, 0.0, _arm_lift(p)), radius=p["arm_thickness"], roundness=1.0,
        axis=(0.0, 1.0, 0.0), label=ARMS)["Mesh"]
    return mesh, end


def _socket(g: Graph, end, radius):
    """A cylinder SOCKET_WIDTH radii wide around the end of what holds it (an arm, the rod)
    of `radius`, from 1.5 radii above the end down to SOCKET_LENGTH below it."""
    width = radius * (2 * SOCKET_WIDTH)
    return straight_frame(g, start=end + g.vec(0.0, 0.0, radius * 1.5),
                          end=end - (0.0, 0.0, SOCKET_LENGTH), width=width, depth=width,
                          roundness=1.0, label=SOCKETS)["Mesh"]


def _room(g: Graph, p: dict, end):
    """The room a chandelier's shade has for its rim half-width: SHADE_GAP of half the
    distance to the next arm's end (reach sin(pi / arm_count)) and of the arm's length
    (clear of the hub), divided by how far the outline's corner reaches."""
    between = end.x * g.sin(math.pi / p["arm_count"])
    return g.min(between, p["arm_length"]) * SHADE_GAP / _corner_reach(p["shade_roundness"])


def _flush_room(g: Graph, p: dict):
    """The room a flush mount's rim has: FLUSH_FIT of the canopy's half-width at its middle
    height, canopy_radius (1 - canopy_taper / 4), divided by how far the outline's corner
    reaches, so that the shade's wall runs through the canopy."""
    middle = p["canopy_radius"] * (1.0 - p["canopy_taper"] * 0.25)
    return middle * FLUSH_FIT / _corner_reach(p["shade_roundness"])


def _shade_profile(g: Graph, p: dict):
    """The shade's half-width per unit rim half-width at t (0 = rim, 1 = top)."""
    t, top = g.spline_factor(), p["shade_top"]
    cone = g.lerp(1.0, top, t)
    bell = top + (1.0 - top) * g.math("POWER", 1.0 - t, 1.0 + p["shade_flare"] * 3.0)
    # a sphere's outline, kept open at the rim and at the top
    centred = t * 2.0 - 1.0
    globe = g.max(g.sqrt(g.max(1.0 - centred * centred, 0.0)), g.lerp(GLOBE_RIM, top, t))
    # a half ellipsoid from the rim up to a small flat top of DOME_TOP
    rising = t * math.sqrt(1.0 - DOME_TOP * DOME_TOP)
    dome = g.sqrt(1.0 - rising * rising)
    return g.index_switch(p["shade_shape"], [cone, bell, 1.0, globe, dome], data_type="FLOAT")


def _shade(g: Graph, p: dict, end, rim):
    """A shell of half-width rim x the profile, shade_height tall. Hanging (chandelier,
    pendant): its closed top SOCKET_LENGTH / 2 under the end (the socket pierces it), its
    open rim below. Flush mount: upside down, its open rim inside the canopy, half the
    canopy's height up, its closed end FLUSH_DEPTH shade_height below."""
    hangs = g.named("hangs", g.switch(p["flush"], 1.0, 0.0))
    anchor = g.switch(p["flush"], end.z - SOCKET_LENGTH / 2, p["canopy_height"] * -0.5)
    rim_z = anchor - p["shade_height"] * hangs
    top_z = anchor - p["shade_height"] * ((1.0 - hangs) * FLUSH_DEPTH)
    path = _vertical_path(g, end.x, rim_z, top_z, SHADE_RINGS)
    return shell(g, curve=path, profile_curve=_outline(g, p["shade_roundness"], 3),
                 scale=rim * _shade_profile(g, p), thickness=p["shade_thickness"],
                 label=SHADES)["Mesh"]


def _bulb(g: Graph, p: dict, end, rim):
    """A round bulb of radius min(bulb_size, BULB_FIT rim) whose top reaches 0.2 radius into
    the socket's bottom."""
    radius = g.min(p["bulb_size"], rim * BULB_FIT)
    top = end.z - SOCKET_LENGTH + radius * 0.2
    path = _vertical_path(g, end.x, top - radius * 1.8, top, 8)
    # a sphere's outline over 0.9 of its height, flat at both ends
    centred = g.spline_factor() * 1.8 - 0.9
    return sweep(g, curve=path, profile_curve=_outline(g, 1.0, 2),
                 scale=radius * g.sqrt(1.0 - centred * centred), fill_caps=True,
                 label=BULBS)["Mesh"]


def _styled(g: Graph, p: dict, chandelier=None, pendant=None, flush=None):
    """The value of the lamp's form (None: nothing): `flush` decides over `pendant`."""
    return g.switch(p["flush"], g.switch(p["pendant"], chandelier, pendant), flush)


def build(g: Graph) -> None:
    with g.frame("Parameters"):
        p = _parameters(g)
    with g.group("Canopy"):
        canopy = _canopy(g, p)
    with g.group("Rod"):  # from inside the canopy down by rod_length below it
        top, bottom = p["canopy_height"] * -0.5, -p["canopy_height"] - p["rod_length"]
        rod = _upright(g, top, bottom, p["rod_thickness"], ROD)
        # a chandelier's hub where the rod is sampled at arm_attach of its length, low
        # enough for the arms; the rod reaches down to it
        at = sample_curve(g, curve=rod["Curve"], factor=p["arm_attach"])["Position"]
        hub_z = g.named("hub_z", _hub_z(g, p, at.z))
        stem = _upright(g, top, g.min(bottom, hub_z), p["rod_thickness"], ROD)["Mesh"]
        rod_end = g.named("rod_end", g.vec(0.0, 0.0, bottom))
        rods = _styled(g, p, chandelier=stem, pendant=rod["Mesh"])
    with g.group("Hub"):
        half = p["hub_height"] * 0.5
        hub = _styled(g, p, chandelier=_upright(g, hub_z + half, hub_z - half,
                                                p["hub_radius"], HUB)["Mesh"])
    with g.group("Arm"):  # the end a shade hangs from: an arm's, else the rod's
        arm, arm_end = _arm(g, p, hub_z)
        end = g.named("end", _styled(g, p, chandelier=arm_end, pendant=rod_end))
        arm = _styled(g, p, chandelier=arm)
    with g.group("Socket"):  # as wide as an arm, or a cord or rod (at least CORD_SOCKET)
        holder = _styled(g, p, chandelier=p["arm_thickness"],
                         pendant=g.max(p["rod_thickness"], CORD_SOCKET))
        socket = _socket(g, end, holder)
        socket = _styled(g, p, chandelier=socket, pendant=socket)
    with g.group("Shade"):  # a chandelier's shades are crowded, a flush mount's held in
        room = _styled(g, p, chandelier=_room(g, p, end), pendant=UNCROWDED,
                       flush=_flush_room(g, p))
        rim = g.named("rim", g.min(p["shade_size"], room))
        shade = _shade(g, p, end, rim)
    with g.group("Bulb"):
        bulb = _bulb(g, p, end, rim)
        bulb = _styled(g, p, chandelier=bulb, pendant=bulb)
    with g.frame("Assembly"):
        one = g.join([arm, socket, shade, bulb])
        count = _styled(g, p, chandelier=p["arm_count"], pendant=1, flush=1)
        arms = radial(g, geometry=one, count=count, radius=0.0)["Geometry"]
        g.output("Geometry", "geometry", g.join([canopy, rods, hub, arms]))
