"""A small typed builder over a Blender Geometry Nodes tree.

`Graph` wraps one `GeometryNodeTree`: it adds nodes, links sockets or sets constants, exposes
group inputs/outputs, and offers math helpers that return output sockets, so that a block or
a program reads like ordinary arithmetic over sockets. Sockets are addressed by identifier or
by name, never by position (except the unnamed operands of Math-like nodes).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import bpy

Value = Any  # a bpy NodeSocket, a Node, or a constant (bool, int, float, 3-sequence)

# group-input kinds -> interface socket types
SOCKET_TYPES = {
    "bool": "NodeSocketBool",
    "int": "NodeSocketInt",
    "float": "NodeSocketFloat",
    "vector": "NodeSocketVector",
    "geometry": "NodeSocketGeometry",
    "rotation": "NodeSocketRotation",
}

# socket.type -> the data-type enum that Switch/Index Switch/Compare nodes use
_DATA_TYPES = {
    "VALUE": "FLOAT",
    "INT": "INT",
    "BOOLEAN": "BOOLEAN",
    "VECTOR": "VECTOR",
    "GEOMETRY": "GEOMETRY",
    "ROTATION": "ROTATION",
}

PART_ATTRIBUTE = "part"


class Node:
    """A node in a Graph; `node["Mesh"]` is its enabled output socket of that identifier/name."""

    def __init__(self, bl_node: bpy.types.Node):
        self.bl = bl_node

    def __getitem__(self, key: str) -> bpy.types.NodeSocket:
        return find_socket(self.bl.outputs, key, self.bl)

    @property
    def out(self) -> bpy.types.NodeSocket:
        """The first enabled output (the node's main result)."""
        return next(s for s in self.bl.outputs if s.enabled)

    def input(self, key: str) -> bpy.types.NodeSocket:
        return find_socket(self.bl.inputs, key, self.bl)


def find_socket(sockets, key: str, node) -> bpy.types.NodeSocket:
    """The enabled socket whose identifier is `key`, else the first enabled one named `key`."""
    enabled = [s for s in sockets if s.enabled]
    for socket in enabled:
        if socket.identifier == key:
            return socket
    for socket in enabled:
        if socket.name == key:
            return socket
    names = sorted({s.name for s in enabled})
    raise KeyError(f"{node.bl_idname} {node.name!r} has no socket {key!r}; it has {names}")


def as_socket(value: Value) -> bpy.types.NodeSocket | None:
    if isinstance(value, Node):
        return value.out
    if isinstance(value, bpy.types.NodeSocket):
        return value
    return None


def data_type_of(*values: Value, default: str = "FLOAT") -> str:
    """The Switch/Compare data type that fits the given operands (first linked one wins)."""
    for value in values:
        socket = as_socket(value)
        if socket is not None:
            return _DATA_TYPES.get(socket.type, default)
    for value in values:
        if isinstance(value, bool):
            return "BOOLEAN"
        if isinstance(value, Sequence) and len(value) == 3:
            return "VECTOR"
        if isinstance(value, int):
            return "INT"
    return default


class Graph:
    """Builder over one geometry node tree."""

    def __init__(self, tree: bpy.types.GeometryNodeTree):
        self.tree = tree

    @classmethod
    def new(cls, name: str) -> Graph:
        return cls(bpy.data.node_groups.new(name, "GeometryNodeTree"))

    # -- nodes and links ----------------------------------------------------------------------

    def node(self, bl_idname: str, inputs: Mapping[str, Value] | Sequence[Value] = (),
             **props) -> Node:
        """Add a node, set its properties (before inputs: they decide which sockets are
        enabled), then set inputs: a mapping by identifier/name, or a sequence for the
        positional operands of Math-like nodes."""
        node = Node(self.tree.nodes.new(bl_idname))
        for key, value in props.items():
            setattr(node.bl, key, value)
        if isinstance(inputs, Mapping):
            for key, value in inputs.items():
                if value is not None:
                    self.set(node.input(key), value)
        else:
            enabled = [s for s in node.bl.inputs if s.enabled]
            for socket, value in zip(enabled, inputs, strict=False):
                if value is not None:
                    self.set(socket, value)
        return node

    def set(self, target: bpy.types.NodeSocket, value: Value) -> None:
        """Link `value` into `target` if it is a socket/node, else store it as the constant."""
        source = as_socket(value)
        if source is not None:
            self.tree.links.new(source, target)
        elif isinstance(value, Sequence) and not isinstance(value, str):
            target.default_value = tuple(value)
        else:
            target.default_value = value

    def link(self, source: Value, target: bpy.types.NodeSocket) -> None:
        self.tree.links.new(as_socket(source), target)

    # -- group interface ----------------------------------------------------------------------

    def _io_node(self, bl_idname: str) -> bpy.types.Node:
        for node in self.tree.nodes:
            if node.bl_idname == bl_idname:
                return node
        return self.tree.nodes.new(bl_idname)

    def input(self, name: str, kind: str, default: Value = None, min: float | None = None,
              max: float | None = None, description: str = "") -> bpy.types.NodeSocket:
        """Expose a group input and return its socket. kind: bool|int|float|vector|geometry."""
        item = self.tree.interface.new_socket(name, in_out="INPUT",
                                              socket_type=SOCKET_TYPES[kind])
        item.description = description
        if min is not None and kind != "bool":  # bool sockets have no range
            item.min_value = min
        if max is not None and kind != "bool":
            item.max_value = max
        if default is not None:
            item.default_value = tuple(default) if kind == "vector" else default
        return find_socket(self._io_node("NodeGroupInput").outputs, item.identifier,
                           self.tree)

    def output(self, name: str, kind: str, value: Value) -> None:
        """Expose a group output named `name` and connect `value` to it."""
        item = self.tree.interface.new_socket(name, in_out="OUTPUT",
                                              socket_type=SOCKET_TYPES[kind])
        target = find_socket(self._io_node("NodeGroupOutput").inputs, item.identifier,
                             self.tree)
        self.set(target, value)

    # -- arithmetic -----------------------------------------------------------------------------

    def math(self, operation: str, *operands: Value) -> bpy.types.NodeSocket:
        return self.node("ShaderNodeMath", operands, operation=operation).out

    def add(self, a: Value, b: Value) -> bpy.types.NodeSocket:
        return self.math("ADD", a, b)

    def sub(self, a: Value, b: Value) -> bpy.types.NodeSocket:
        return self.math("SUBTRACT", a, b)

    def mul(self, a: Value, b: Value) -> bpy.types.NodeSocket:
        return self.math("MULTIPLY", a, b)

    def div(self, a: Value, b: Value) -> bpy.types.NodeSocket:
        return self.math("DIVIDE", a, b)

    def minimum(self, a: Value, b: Value) -> bpy.types.NodeSocket:
        return self.math("MINIMUM", a, b)

    def maximum(self, a: Value, b: Value) -> bpy.types.NodeSocket:
        return self.math("MAXIMUM", a, b)

    def lerp(self, a: Value, b: Value, t: Value) -> bpy.types.NodeSocket:
        """a + (b - a) t, linear interpolation (unclamped)."""
        return self.map_range(t, 0.0, 1.0, a, b, clamp=False)

    def int_math(self, operation: str, *operands: Value) -> bpy.types.NodeSocket:
        return self.node("FunctionNodeIntegerMath", operands, operation=operation).out

    def vmath(self, operation: str, *operands: Value) -> bpy.types.NodeSocket:
        """Vector math; SCALE takes (vector, scale), DOT/LENGTH/DISTANCE return a float."""
        node = self.node("ShaderNodeVectorMath", operation=operation)
        enabled = [s for s in node.bl.inputs if s.enabled]
        for socket, value in zip(enabled, operands, strict=False):
            self.set(socket, value)
        return node.out if operation not in ("DOT_PRODUCT", "LENGTH", "DISTANCE") \
            else node["Value"]

    def map_range(self, value: Value, from_min: Value, from_max: Value, to_min: Value,
                  to_max: Value, interpolation: str = "LINEAR",
                  clamp: bool = True) -> bpy.types.NodeSocket:
        return self.node("ShaderNodeMapRange", {
            "Value": value, "From Min": from_min, "From Max": from_max,
            "To Min": to_min, "To Max": to_max,
        }, interpolation_type=interpolation, clamp=clamp).out

    def combine(self, x: Value = 0.0, y: Value = 0.0, z: Value = 0.0) -> bpy.types.NodeSocket:
        return self.node("ShaderNodeCombineXYZ", {"X": x, "Y": y, "Z": z}).out

    def separate(self, vector: Value) -> Node:
        """Node with outputs X, Y, Z."""
        return self.node("ShaderNodeSeparateXYZ", {"Vector": vector})

    # -- logic ----------------------------------------------------------------------------------

    def compare(self, operation: str, a: Value, b: Value,
                data_type: str | None = None) -> bpy.types.NodeSocket:
        """operation: LESS_THAN, LESS_EQUAL, GREATER_THAN, GREATER_EQUAL, EQUAL, NOT_EQUAL."""
        data_type = data_type or data_type_of(a, b)
        return self.node("FunctionNodeCompare", {"A": a, "B": b}, data_type=data_type,
                         operation=operation)["Result"]

    def boolean(self, operation: str, *operands: Value) -> bpy.types.NodeSocket:
        return self.node("FunctionNodeBooleanMath", operands, operation=operation).out

    def switch(self, condition: Value, if_false: Value, if_true: Value,
               data_type: str | None = None) -> bpy.types.NodeSocket:
        data_type = data_type or data_type_of(if_false, if_true)
        return self.node("GeometryNodeSwitch", {
            "Switch": condition, "False": if_false, "True": if_true,
        }, input_type=data_type)["Output"]

    def index_switch(self, index: Value, items: Sequence[Value],
                     data_type: str | None = None) -> bpy.types.NodeSocket:
        """Output items[index]; an index out of range gives the type's zero value."""
        node = self.node("GeometryNodeIndexSwitch", data_type=data_type or data_type_of(*items))
        while len(node.bl.index_switch_items) < len(items):
            node.bl.index_switch_items.new()
        self.set(node.input("Index"), index)
        for i, item in enumerate(items):
            if item is not None:
                self.set(node.input(f"Item_{i}"), item)
        return node["Output"]

    # -- geometry helpers -------------------------------------------------------------------

    def join(self, geometries: Iterable[Value]) -> bpy.types.NodeSocket:
        """Join Geometry; the multi-input keeps the order of `geometries`."""
        node = self.node("GeometryNodeJoinGeometry")
        # multi-input sockets list links in reverse order of creation
        for geometry in reversed(list(geometries)):
            self.link(geometry, node.input("Geometry"))
        return node.out

    def transform(self, geometry: Value, translation: Value = None, rotation: Value = None,
                  scale: Value = None) -> bpy.types.NodeSocket:
        """Transform Geometry; rotation is an Euler vector (radians) or a rotation socket."""
        if rotation is not None and not _is_rotation(rotation):
            rotation = self.euler_to_rotation(rotation)
        return self.node("GeometryNodeTransform", {
            "Geometry": geometry, "Translation": translation, "Rotation": rotation,
            "Scale": scale,
        }).out

    def euler_to_rotation(self, euler: Value) -> bpy.types.NodeSocket:
        return self.node("FunctionNodeEulerToRotation", {"Euler": euler}).out

    def label_part(self, geometry: Value, label: Value) -> bpy.types.NodeSocket:
        """Store the integer segmentation label `part` on every face."""
        return self.node("GeometryNodeStoreNamedAttribute", {
            "Geometry": geometry, "Name": PART_ATTRIBUTE, "Value": label,
        }, data_type="INT", domain="FACE").out

    def spline_factor(self) -> bpy.types.NodeSocket:
        """Field: the fraction of the spline's length at each point, in [0, 1]."""
        return self.node("GeometryNodeSplineParameter")["Factor"]

    def position(self) -> bpy.types.NodeSocket:
        return self.node("GeometryNodeInputPosition").out

    # -- layout -----------------------------------------------------------------------------

    def arrange(self, dx: float = 260.0, dy: float = 200.0) -> None:
        """Place nodes in columns by their depth from the inputs, so that the tree is readable
        when the .blend is opened in Blender's node editor."""
        depth = {node.name: 0 for node in self.tree.nodes}
        for _ in range(len(depth)):
            changed = False
            for link in self.tree.links:
                new = depth[link.from_node.name] + 1
                if new > depth[link.to_node.name]:
                    depth[link.to_node.name] = new
                    changed = True
            if not changed:
                break
        rows: dict[int, int] = {}
        for node in self.tree.nodes:
            column = depth[node.name]
            node.location = (column * dx, -rows.get(column, 0) * dy)
            rows[column] = rows.get(column, 0) + 1


def _is_rotation(value: Value) -> bool:
    socket = as_socket(value)
    return socket is not None and socket.type == "ROTATION"
