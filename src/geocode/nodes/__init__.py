"""Geometry Nodes toolkit: a typed graph builder, cached node groups, and the building
blocks of GeoCode programs (docs/paper-numbers.md#building-blocks). Importing this package
imports bpy.

A block is a `NodeGroup`; call it inside a builder, its inputs by keyword, to add an instance:

    profile = rectangle_fillet(g, width=2, height=2, roundness=r)["Curve"]

Every block and builder helper is importable from here; the modules are the catalogue's
chapters: profiles, curves, styles, meshes (ready-made triplets: seat, legs, frames, rails),
shells, surfaces, attachment (sampling), symmetry, utils.
"""

from geocode.nodes.attachment import sample_curve, sample_curve_array, sample_points
from geocode.nodes.curves import (
    arc,
    bezier_segment,
    fixed_bottom,
    fixed_middle,
    fixed_top,
    handle,
    quadratic_cartesian,
    quadratic_polar,
)
from geocode.nodes.graph import LABEL_ATTRIBUTE, Graph, Node, Socket
from geocode.nodes.group import NodeGroup, node_group
from geocode.nodes.meshes import (
    cross_rail,
    cushion_mesh,
    frame_fixed_bottom,
    leg_mesh,
    quadratic_cartesian_aligned_xy_frame,
    quadratic_cartesian_mesh,
    quadratic_polar_frame,
    seat,
    straight_frame,
    top_rail,
)
from geocode.nodes.modifier import Evaluator
from geocode.nodes.profiles import corner_radius, rectangle_fillet
from geocode.nodes.repeat import Repeat
from geocode.nodes.shells import shell
from geocode.nodes.styles import (
    aligned_bevel_xy,
    bezier_segment_style,
    cushion_style,
    leg_style,
    middle_expand_contract,
    rail,
    seat_frame,
    solidify,
    sweep,
)
from geocode.nodes.surfaces import loft
from geocode.nodes.symmetry import mirror, radial
from geocode.nodes.utils import align_curve_tilt_to_axis, align_curve_to_start_point, bow_in_plan

# Every block, by its node-group name (leg_mesh is "MeshLeg", leg_style "StyleLeg");
# tests/test_nodes.py checks that it holds every block of the catalogue's modules.
BLOCKS: dict[str, NodeGroup] = {
    value.name: value for value in list(globals().values()) if isinstance(value, NodeGroup)
}

__all__ = [
    # the builder
    "Evaluator", "Graph", "LABEL_ATTRIBUTE", "Node", "NodeGroup", "Repeat", "Socket",
    "node_group", "BLOCKS",
    # profiles
    "corner_radius", "rectangle_fillet",
    # curves
    "arc", "bezier_segment", "fixed_bottom", "fixed_middle", "fixed_top", "handle",
    "quadratic_cartesian", "quadratic_polar",
    # styles
    "aligned_bevel_xy", "bezier_segment_style", "cushion_style", "leg_style",
    "middle_expand_contract", "rail", "seat_frame", "solidify", "sweep",
    # meshes
    "cross_rail", "cushion_mesh", "frame_fixed_bottom", "leg_mesh",
    "quadratic_cartesian_aligned_xy_frame", "quadratic_cartesian_mesh", "quadratic_polar_frame",
    "seat", "straight_frame", "top_rail",
    # shells, surfaces, attachment, symmetry, utils
    "shell", "loft", "sample_curve", "sample_curve_array", "sample_points", "mirror", "radial",
    "align_curve_tilt_to_axis", "align_curve_to_start_point", "bow_in_plan",
]
