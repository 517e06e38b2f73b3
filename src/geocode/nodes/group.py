"""`@node_group`: turn a builder function into a reusable, cached Geometry Nodes group.

The builder receives a fresh `Graph`, declares inputs with `g.input(...)` and outputs with
`g.output(...)`. The group is built once per Blender session: later uses find it by name in
`bpy.data.node_groups` (tagged with the builder's name), so a factory reset simply makes the
next use build it again; no Python reference to Blender data outlives a reset.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import bpy

from geocode.nodes.graph import Graph, Node, Socket, Value, find_socket

_TAG = "geocode_block"


def _key(name: str) -> str:
    """'Profile Curve', 'profile_curve' and 'ProfileCurve' all match."""
    return re.sub(r"[^a-z0-9]", "", name.lower())


class NodeGroup:
    """A cached node group; call it inside another builder to add an instance of it."""

    def __init__(self, build: Callable[[Graph], None], name: str):
        self.build = build
        self.name = name
        self.__doc__ = build.__doc__
        self.__name__ = build.__name__

    def tree(self) -> bpy.types.GeometryNodeTree:
        """The Blender node group, built on first use in this session."""
        tree = bpy.data.node_groups.get(self.name)
        if tree is not None and tree.get(_TAG) == self.name:
            return tree
        graph = Graph.new(self.name)
        graph.tree[_TAG] = self.name
        graph.tree.description = (self.build.__doc__ or "").strip().split("\n\n")[0]
        self.build(graph)
        graph.arrange()
        return graph.tree

    def __call__(self, g: Graph, **inputs: Value) -> Node:
        """Add a group node to `g`, set inputs by name (snake_case matches 'Title Case')."""
        node = g.node("GeometryNodeGroup", node_tree=self.tree())
        by_key = {_key(s.name): s for s in node.bl.inputs if s.enabled}
        for name, value in inputs.items():
            if value is None:
                continue
            socket = by_key.get(_key(name))
            if socket is None:
                raise TypeError(f"{self.name} has no input {name!r}; it has "
                                f"{sorted(s.name for s in by_key.values())}")
            g.set(socket, value)
        return _GroupNode(g, node.bl)


class _GroupNode(Node):
    """Group instance whose outputs also match snake_case: `handle["start_position"]`."""

    def __getitem__(self, key: str) -> Socket:
        for socket in self.bl.outputs:
            if socket.enabled and _key(socket.name) == _key(key):
                return Socket(self.g, socket)
        return Socket(self.g, find_socket(self.bl.outputs, key, self.bl))


def node_group(name: str) -> Callable[[Callable[[Graph], None]], NodeGroup]:
    """Decorator: `@node_group("ProfileRectangleFillet") def rectangle_fillet(g): ...`."""

    def wrap(build: Callable[[Graph], None]) -> NodeGroup:
        return NodeGroup(build, name)

    return wrap
