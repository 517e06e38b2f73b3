"""The vase program: a hollow body of revolution-like sweep with handles, lid, rim, band
and foot (39 parameters: 7 discrete, 32 continuous).

Structure (every part touches the rest for every parameter combination):
- body: a vertical path swept with a RectangleFillet profile (square -> round cross-section,
  optional twist), scaled along the height by a smooth radius profile through six widths;
  the open top is solidified into a wall of `wall_thickness` with a closed bottom;
- handles: CurveHandle on the body's silhouette (the body's outline in the XZ plane), so
  both ends sit on the body wall; copied radially `handle_count` times;
- lid and knob on the lip, a rim around the lip, a band around the body;
- foot: none, a pedestal, or radially placed legs; the whole vase is then grounded so that
  its lowest point lies on z = 0.
Labels: body 1, rim 2, band 3, handle 4, lid 5, knob 6, foot 7. In Blender's node
editor each piece is a node group: Body, Lip Rim, Band, Handles, Lid, Pedestal, Legs.
"""

from __future__ import annotations

from geocode.nodes import (
    Graph,
    align_curve_tilt_to_axis,
    handle,
    leg_style,
    middle_expand_contract,
    node_group,
    quadratic_cartesian,
    radial,
    rail,
    rectangle_fillet,
    sample_curve,
    solidify,
    sweep,
)

BODY, RIM, BAND, HANDLE, LID, KNOB, FOOT = 1, 2, 3, 4, 5, 6, 7
BODY_RINGS = 40          # path points along the body's height
PROFILE_RESOLUTION = 5   # fillet points per corner of the body's cross-section
TUBE_RESOLUTION = 2      # ... of thin parts (handles, rim, band, legs)
LIP_OVERHANG = 1.04      # the lid is a little wider than the lip it rests on
# Parts that rest on another overlap it by this much: their contact faces lie within any
# touching tolerance of each other whatever the wall's shape (a sweep's thin bottom slab
# cannot hide a leg's end inside the cavity).
OVERLAP = 2e-4
KNOTS = ("Base", "Lower", "Belly", "Shoulder", "Neck", "Lip")


@node_group("VaseRadius")
def vase_radius(g: Graph) -> None:
    """The body's half-width at `Factor` (fraction of its height): a smooth curve through
    six (height, width) knots; between two knots it eases with a smoothstep, so it never
    overshoots the knots and stays positive."""
    factor = g.input("Factor", "float", default=0.0, min=0.0, max=1.0)
    knots = []
    for name in KNOTS:
        height = g.input(f"{name} Height", "float", default=0.0, min=0.0, max=1.0)
        width = g.input(f"{name} Width", "float", default=0.5, min=0.0)
        knots.append((height, width))
    radius = knots[0][1]
    for (t0, w0), (t1, w1) in zip(knots, knots[1:], strict=False):
        step = g.map_range(factor, t0, t1, 0.0, 1.0, interpolation="SMOOTHSTEP")
        radius = radius + (w1 - w0) * step
    g.output("Radius", "float", radius)


class _Body:
    """Quantities of the body that its parts are placed from, so that they follow edits."""

    def __init__(self, g: Graph, p: dict):
        self.g, self.p = g, p
        self.height = p["body_height"]

    def radius(self, factor):
        knots = {"base_height": 0.0, "lower_height": self.p["lower_height"],
                 "belly_height": self.p["belly_height"],
                 "shoulder_height": self.p["shoulder_height"],
                 "neck_height": self.p["neck_height"], "lip_height": 1.0}
        widths = {f"{n.lower()}_width": self.p[f"{n.lower()}_width"] for n in KNOTS}
        return vase_radius(self.g, factor=factor, **knots, **widths)["Radius"]

    def profile(self, resolution=PROFILE_RESOLUTION):
        return rectangle_fillet(self.g, width=2.0, height=2.0,
                                roundness=self.p["roundness"], resolution=resolution)["Curve"]

    def corner_reach(self):
        """Distance from the axis to the cross-section's corner, per unit half-width:
        sqrt(2) for a square, 1 for a circle (corner arc of radius `roundness`)."""
        roundness = self.p["roundness"]
        return (1.0 - roundness) * 2 ** 0.5 + roundness

    def twist_at(self, factor):
        return self.p["twist"] * factor

    def path(self, bottom, top, points):
        """Vertical path from z=bottom to z=top, its profile's +X pinned to world +X."""
        g = self.g
        path = g.line(g.vec(0.0, 0.0, bottom), g.vec(0.0, 0.0, top), count=points)
        return align_curve_tilt_to_axis(g, curve=path, axis=(1.0, 0.0, 0.0))["Curve"]

    def loop_at(self, factor):
        """The body's outline at `factor` of its height, as a closed curve."""
        g = self.g
        scale = self.radius(factor)
        return g.transform(self.profile(),
                           translation=g.vec(0.0, 0.0, factor * self.height),
                           rotation=g.vec(0.0, 0.0, self.twist_at(factor)),
                           scale=g.vec(scale, scale, 1.0))


def _parameters(g: Graph) -> dict:
    p = g.parameters()
    add = p.add

    add("body_height", "float", 1.0, 0.6, 1.6, "height of the body")
    add("base_width", "float", 0.3, 0.15, 0.5, "half-width of the body at its base")
    add("lower_width", "float", 0.4, 0.2, 0.6, "half-width at the lower knot")
    add("lower_height", "float", 0.15, 0.08, 0.3, "height of the lower knot (fraction)")
    add("belly_width", "float", 0.5, 0.25, 0.75, "half-width at the belly")
    add("belly_height", "float", 0.42, 0.32, 0.55, "height of the belly (fraction)")
    add("shoulder_width", "float", 0.4, 0.2, 0.65, "half-width at the shoulder")
    add("shoulder_height", "float", 0.68, 0.6, 0.75, "height of the shoulder (fraction)")
    add("neck_width", "float", 0.2, 0.1, 0.4, "half-width at the neck")
    add("neck_height", "float", 0.86, 0.8, 0.92, "height of the neck (fraction)")
    add("lip_width", "float", 0.25, 0.1, 0.5, "half-width at the lip (top)")
    add("roundness", "float", 1.0, 0.0, 1.0, "cross-section: 0 square, 1 round")
    add("twist", "float", 0.0, 0.0, 1.5, "twist of the cross-section over the height (rad)")
    add("wall_thickness", "float", 0.02, 0.01, 0.03, "thickness of the body's wall")
    add("lip_rim", "bool", True, 0, 1, "a rounded rim around the lip")
    add("lip_rim_size", "float", 0.02, 0.01, 0.04, "radius of the rim's tube")
    add("band", "bool", False, 0, 1, "a decorative band around the body")
    add("band_height", "float", 0.5, 0.2, 0.8, "height of the band (fraction)")
    add("band_size", "float", 0.02, 0.01, 0.04, "radius of the band's tube")
    add("handle_count", "int", 2, 0, 4, "number of handles (radial symmetry)")
    add("handle_bottom", "float", 0.3, 0.15, 0.45, "lower attachment (fraction of outline)")
    add("handle_top", "float", 0.8, 0.55, 0.95, "upper attachment (fraction of outline)")
    add("handle_reach", "float", 0.15, 0.06, 0.35, "how far the handle bulges out")
    add("handle_peak", "float", 0.5, 0.0, 1.0, "where the bulge peaks: 0 low, 1 high")
    add("handle_thickness", "float", 0.025, 0.015, 0.04, "half-width of the handle")
    add("handle_roundness", "float", 1.0, 0.0, 1.0, "handle cross-section: square to round")
    add("lid", "bool", False, 0, 1, "a lid on the lip")
    add("lid_thickness", "float", 0.04, 0.02, 0.08, "thickness of the lid's flat part")
    add("lid_dome", "float", 0.05, 0.0, 0.15, "height of the lid's dome")
    add("knob", "bool", True, 0, 1, "a knob on the lid")
    add("knob_size", "float", 0.04, 0.02, 0.08, "half-width of the knob")
    add("knob_height", "float", 0.06, 0.03, 0.12, "height of the knob")
    add("knob_roundness", "float", 1.0, 0.0, 1.0, "knob cross-section: square to round")
    add("foot_style", "int", 0, 0, 2, "foot: 0 none, 1 pedestal, 2 legs")
    add("foot_height", "float", 0.08, 0.03, 0.2, "height of the foot")
    add("foot_width", "float", 1.0, 0.6, 1.4, "pedestal's bottom width (times the base)")
    add("leg_count", "int", 3, 3, 5, "number of legs")
    add("leg_thickness", "float", 0.025, 0.015, 0.04, "half-width of a leg at its top")
    add("leg_splay", "float", 0.05, 0.0, 0.15, "how far the legs spread outwards")
    return p


def _body_mesh(body: _Body):
    """The body: the profile swept up the height `body_height`, scaled by the radius curve
    and twisted by `twist` x height; its top cap removed and the open surface given a wall
    of `wall_thickness` inwards."""
    g, p = body.g, body.p
    path = g.set_tilt(body.path(0.0, body.height, BODY_RINGS),
                      body.twist_at(g.spline_factor()))
    outer = sweep(g, curve=path, profile_curve=body.profile(),
                  scale=body.radius(g.spline_factor()), fill_caps=True, label=BODY)["Mesh"]
    is_top_cap = (g.position().z > body.height - 1e-4) & (g.normal().z > 0.9)
    open_top = g.delete_faces(outer, is_top_cap)
    return solidify(g, mesh=open_top, thickness=p["wall_thickness"])["Mesh"]


def _silhouette(body: _Body):
    """The body's outermost outline in the XZ plane: at each height, the farthest the
    cross-section reaches in any direction (its corner), so that a handle built on it clears
    the body at every azimuth and twist."""
    g = body.g
    path = body.path(0.0, body.height, BODY_RINGS)
    reach = body.radius(g.spline_factor()) * body.corner_reach()
    return g.set_position(path, offset=g.vec(reach, 0.0, 0.0))


def _tube_profile(g: Graph, roundness=1.0):
    return rectangle_fillet(g, width=2.0, height=2.0, roundness=roundness,
                            resolution=TUBE_RESOLUTION)["Curve"]


def _handles(body: _Body):
    """`handle_count` handles (radial copies, none at 0), each a CurveHandle on the
    silhouette from `handle_bottom` to `handle_top` (fractions of the outline) bulging out
    by `handle_reach`; its ends sunk into the wall by `inset` (below)."""
    g, p = body.g, body.p
    silhouette = _silhouette(body)
    # The ends sit on the outermost outline; sink them to the inner face of the wall at its
    # nearest azimuth (the flat side): corner excess + half the wall, for the wider end.
    ends_x = [sample_curve(g, curve=silhouette, factor=p[f])["Position"].x
              for f in ("handle_bottom", "handle_top")]
    excess = 1.0 - 1.0 / body.corner_reach()
    inset = g.max(*ends_x) * excess + p["wall_thickness"] * 0.5
    curve = handle(g, curve=silhouette, start=p["handle_bottom"], end=p["handle_top"],
                   reach=p["handle_reach"], peak=p["handle_peak"], inset=inset,
                   resolution=20)["Curve"]
    one = rail(g, curve=curve, profile_curve=_tube_profile(g, p["handle_roundness"]),
               radius=p["handle_thickness"], fill_caps=True, label=HANDLE)["Mesh"]
    copies = radial(g, geometry=one, count=p["handle_count"], radius=0.0)["Geometry"]
    return g.when(p["handle_count"] > 0, copies)


def _ring(body: _Body, shown, factor, size, label):
    """When `shown`: a tube of radius `size` around the body's outline at `factor` of its
    height."""
    g = body.g
    ring = rail(g, curve=body.loop_at(factor), profile_curve=_tube_profile(g), radius=size,
                fill_caps=False, label=label)["Mesh"]
    return g.when(shown, ring)


def _lid(body: _Body):
    """When `lid`: a lid from just below the lip (`OVERLAP`) up by `lid_thickness`, then a
    quarter-ellipse dome of height `lid_dome` narrowing to 30% of the lid's width
    (`lip_width` x `LIP_OVERHANG`); when `knob` too, a knob of height `knob_height` on top."""
    g, p = body.g, body.p
    bottom = body.height - OVERLAP
    flat_top = body.height + p["lid_thickness"]
    top = flat_top + p["lid_dome"]
    path = g.set_tilt(body.path(bottom, top, 10), p["twist"])
    u = g.map_range(g.position().z, flat_top, flat_top + g.max(p["lid_dome"], 1e-4), 0, 1)
    dome = 0.3 + 0.7 * g.sqrt(1.0 - u * u)
    scale = p["lip_width"] * LIP_OVERHANG * dome
    lid = sweep(g, curve=path, profile_curve=body.profile(), scale=scale, fill_caps=True,
                label=LID)["Mesh"]
    knob_path = body.path(top - OVERLAP, top + p["knob_height"], 8)
    knob = middle_expand_contract(
        g, curve=knob_path, profile_curve=_tube_profile(g, p["knob_roundness"]),
        radius=p["knob_size"], amount=0.6, fill_caps=True, label=KNOB)["Mesh"]
    with_knob = g.join([lid, g.when(p["knob"], knob)])
    return g.when(p["lid"], with_knob)


def _pedestal(body: _Body):
    """A pedestal of height `foot_height` (+ `OVERLAP` into the body) whose width goes from
    `base_width` x `foot_width` at the floor to 0.8 `base_width` at the top, pinched by
    20% in the middle (1 - 0.2 sin(pi t))."""
    g, p = body.g, body.p
    path = body.path(0.0, p["foot_height"] + OVERLAP, 8)
    t = g.spline_factor()
    width = g.lerp(p["base_width"] * p["foot_width"], p["base_width"] * 0.8, t)
    waist = 1.0 - 0.2 * g.sin(t * 3.14159265)
    return sweep(g, curve=path, profile_curve=body.profile(), scale=width * waist,
                 fill_caps=True, label=FOOT)["Mesh"]


def _legs(body: _Body):
    """`leg_count` legs (radial copies from 45 degrees), each a quadratic curve from
    (0.6 `base_width`, 0, `foot_height` + `OVERLAP`) down to the floor, its foot spread
    outwards by `leg_splay` and its middle bowed out by 0.3 `leg_splay`; tapering to 0.7 of
    `leg_thickness` at the foot."""
    g, p = body.g, body.p
    x = p["base_width"] * 0.6
    start = g.vec(x, 0.0, p["foot_height"] + OVERLAP)
    end = g.vec(x + p["leg_splay"], 0.0, 0.0)
    curve = quadratic_cartesian(g, start=start, end=end,
                                offset=g.vec(p["leg_splay"] * 0.3, 0.0, 0.0),
                                resolution=8)["Curve"]
    one = leg_style(g, curve=curve, profile_curve=_tube_profile(g),
                    top_radius=p["leg_thickness"], bottom_radius=p["leg_thickness"] * 0.7,
                    fill_caps=True, label=FOOT)["Mesh"]
    return radial(g, geometry=one, count=p["leg_count"], radius=0.0,
                  start_angle=0.785398)["Geometry"]


def build(g: Graph) -> None:
    with g.frame("Parameters"):
        p = _parameters(g)
    body = _Body(g, p)
    with g.group("Body"):
        wall = _body_mesh(body)
    with g.group("Lip Rim"):
        rim = _ring(body, p["lip_rim"], 1.0, p["lip_rim_size"], RIM)
    with g.group("Band"):
        band = _ring(body, p["band"], p["band_height"], p["band_size"], BAND)
    with g.group("Handles"):
        handles = _handles(body)
    with g.group("Lid"):
        lid = _lid(body)
    with g.group("Pedestal"):
        pedestal = _pedestal(body)
    with g.group("Legs"):
        legs = _legs(body)
    with g.frame("Assembly"):
        # the foot lifts the rest by its height; the lowest point then rests on z = 0
        upper = g.join([wall, rim, band, handles, lid])
        lift = g.index_switch(p["foot_style"], [0.0, p["foot_height"], p["foot_height"]])
        foot = g.index_switch(p["foot_style"], [None, pedestal, legs])
        vase = g.join([g.transform(upper, translation=g.vec(0.0, 0.0, lift)), foot])
        g.output("Geometry", "geometry", g.ground(vase))
