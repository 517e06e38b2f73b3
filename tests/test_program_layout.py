"""The trees programs build read like the paper's figures in Blender's node editor: a few
nodes at the top level, each a named node group or inside a labelled frame."""

import pytest

from geocode.program import Program, registry

pytestmark = pytest.mark.blender

MAX_TOP_LEVEL = 40


def _top_level(tree) -> list:
    return [node for node in tree.nodes if node.bl_idname != "NodeFrame"]


def _is_named_group(node) -> bool:
    return node.bl_idname == "GeometryNodeGroup" and bool(node.label) \
        and node.node_tree is not None


@pytest.mark.parametrize("domain", registry())
def test_top_level_is_small_and_every_node_is_in_a_group_or_a_frame(domain):
    tree = Program.load(domain).tree
    nodes = _top_level(tree)
    assert len(nodes) <= MAX_TOP_LEVEL, f"{domain}: {len(nodes)} nodes at the top level"
    loose = [n.name for n in nodes if not _is_named_group(n)
             and (n.parent is None or not n.parent.label)]
    assert loose == [], f"{domain}: nodes in no group and no labelled frame"
    groups = [n.label for n in nodes if _is_named_group(n)]
    assert len(groups) >= 5 and len(set(groups)) == len(groups), groups
