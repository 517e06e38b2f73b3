"""Geometry Nodes toolkit: a typed graph builder, cached node groups, and the building
blocks of GeoCode programs (docs/paper-numbers.md#building-blocks). Importing this package imports bpy.

A block is a `NodeGroup`; call it inside a builder to add an instance:

    profile = rectangle_fillet(g, width=2, height=2, roundness=r)["Curve"]
"""

from geocode.nodes import attachment, curves, parts, profiles, styles, symmetry, utils  # noqa: E402
from geocode.nodes.attachment import sample_curve, sample_curve_array, sample_points
from geocode.nodes.curves import (
    arc,
    bezier_segment,
    handle,
    quadratic_cartesian,
    quadratic_polar,
)
from geocode.nodes.graph import PART_ATTRIBUTE, Graph, Node, Socket
from geocode.nodes.group import NodeGroup, node_group
from geocode.nodes.modifier import Evaluator
from geocode.nodes.profiles import rectangle_fillet
from geocode.nodes.styles import leg_style, middle_expand_contract, rail, solidify, sweep
from geocode.nodes.symmetry import mirror, radial
from geocode.nodes.utils import align_curve_tilt_to_axis, align_curve_to_start_point

# Every block of every catalogue module, by its node-group name (parts.leg_mesh is "MeshLeg",
# styles.leg_style "StyleLeg"); a new block in these modules is listed without further edits.
BLOCKS: dict[str, NodeGroup] = {
    value.name: value
    for module in (profiles, curves, styles, attachment, symmetry, utils, parts)
    for value in vars(module).values() if isinstance(value, NodeGroup)
}

__all__ = [
    "BLOCKS", "PART_ATTRIBUTE", "Evaluator", "Graph", "Node", "NodeGroup", "Socket", "node_group",
    "rectangle_fillet", "quadratic_polar", "quadratic_cartesian", "bezier_segment", "arc",
    "handle", "sweep", "rail", "leg_style", "middle_expand_contract", "solidify", "sample_curve",
    "sample_curve_array", "sample_points", "radial", "mirror", "align_curve_to_start_point",
    "align_curve_tilt_to_axis",
]
