"""A small typed builder over a Blender Geometry Nodes tree.

`Graph` wraps one `GeometryNodeTree`: it adds nodes, links sockets or sets constants, exposes
group inputs/outputs, and offers named helpers for the nodes programs use often. Every output
it hands out is a `Socket`, which overloads Python's operators, so that a block or a program
reads as ordinary arithmetic: `g.vec(x + splay, -y - splay, 0)` adds the same Math, Vector
Math and Combine XYZ nodes as spelling each of them out (docs/guide/programs.md lists the rules).
Sockets are addressed by identifier or by name, never by position (except the unnamed
operands of Math-like nodes).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

import bpy

Value = Any  # a Socket, a bpy NodeSocket, a Node, or a constant (bool, int, float, 3-sequence)

# group-input kinds -> interface socket types
SOCKET_TYPES = {
    "bool": "NodeSocketBool",
    "int": "NodeSocketInt",
    "float": "NodeSocketFloat",
    "vector": "NodeSocketVector",
    "geometry": "NodeSocketGeometry",
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

# socket.type -> the interface socket type that carries it into or out of a group
_INTERFACE_TYPES = {
    "VALUE": "NodeSocketFloat",
    "INT": "NodeSocketInt",
    "BOOLEAN": "NodeSocketBool",
    "VECTOR": "NodeSocketVector",
    "GEOMETRY": "NodeSocketGeometry",
    "ROTATION": "NodeSocketRotation",
}

# the face attribute that holds the segmentation label; its stored name "part" is what the
# exported datasets (.parts.npy), `mesh.metadata["part"]` and their readers know
LABEL_ATTRIBUTE = "part"


class Socket:
    """An output socket of a node in Graph `g`, usable as a value in Python expressions.

    Each operator adds one node to `g`: `+ - * /` a Math node (Vector Math when an operand is
    a vector; a vector times a number is SCALE), unary `-` a multiplication by -1, `abs()`
    ABSOLUTE, `< <= > >=` a Compare node, `& | ~` a Boolean Math node; constants work on
    either side (`1.0 - t`). `==` keeps its Python meaning (identity). `.x .y .z` read a
    vector's components. Other attributes are the bpy socket's (`.type`, `.name`, ...).
    """

    __slots__ = ("g", "bl")

    def __init__(self, g: Graph, bl_socket: bpy.types.NodeSocket):
        self.g, self.bl = g, bl_socket

    def __getattr__(self, name: str):
        if name in Socket.__slots__:  # not yet set (copying, unpickling)
            raise AttributeError(name)
        return getattr(self.bl, name)

    def __repr__(self) -> str:
        return f"Socket({self.bl.node.name!r}.{self.bl.identifier!r})"

    def __bool__(self) -> bool:
        raise TypeError("a socket has no truth value while the graph is built (it varies "
                        "per evaluation): use g.when(...), & | ~, or g.min/g.max")

    __hash__ = object.__hash__  # hashable although the comparisons below return sockets

    def __add__(self, other): return self.g.arithmetic("ADD", self, other)
    def __radd__(self, other): return self.g.arithmetic("ADD", other, self)
    def __sub__(self, other): return self.g.arithmetic("SUBTRACT", self, other)
    def __rsub__(self, other): return self.g.arithmetic("SUBTRACT", other, self)
    def __mul__(self, other): return self.g.arithmetic("MULTIPLY", self, other)
    def __rmul__(self, other): return self.g.arithmetic("MULTIPLY", other, self)
    def __truediv__(self, other): return self.g.arithmetic("DIVIDE", self, other)
    def __rtruediv__(self, other): return self.g.arithmetic("DIVIDE", other, self)
    def __neg__(self): return self.g.arithmetic("MULTIPLY", self, -1.0)

    def __abs__(self):
        return self.g.vmath("ABSOLUTE", self) if is_vector(self) \
            else self.g.math("ABSOLUTE", self)

    def __lt__(self, other): return self.g.compare("LESS_THAN", self, other)
    def __le__(self, other): return self.g.compare("LESS_EQUAL", self, other)
    def __gt__(self, other): return self.g.compare("GREATER_THAN", self, other)
    def __ge__(self, other): return self.g.compare("GREATER_EQUAL", self, other)
    def __and__(self, other): return self.g.boolean("AND", self, other)
    def __rand__(self, other): return self.g.boolean("AND", other, self)
    def __or__(self, other): return self.g.boolean("OR", self, other)
    def __ror__(self, other): return self.g.boolean("OR", other, self)
    def __invert__(self): return self.g.boolean("NOT", self)

    @property
    def x(self) -> Socket:
        return self.g.xyz(self)["X"]

    @property
    def y(self) -> Socket:
        return self.g.xyz(self)["Y"]

    @property
    def z(self) -> Socket:
        return self.g.xyz(self)["Z"]


class Node:
    """A node in Graph `g`; `node["Mesh"]` is its enabled output socket of that
    identifier/name, as a `Socket`."""

    def __init__(self, g: Graph, bl_node: bpy.types.Node):
        self.g, self.bl = g, bl_node

    def __getitem__(self, key: str) -> Socket:
        return Socket(self.g, find_socket(self.bl.outputs, key, self.bl))

    @property
    def out(self) -> Socket:
        """The first enabled output (the node's main result)."""
        return Socket(self.g, next(s for s in self.bl.outputs if s.enabled))

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
    """The bpy socket behind `value`, or None for a constant."""
    if isinstance(value, Socket):
        return value.bl
    if isinstance(value, Node):
        return value.out.bl
    if isinstance(value, bpy.types.NodeSocket):
        return value
    return None


def data_type_of(*values: Value) -> str:
    """The Switch/Compare data type that fits the given operands (first linked one wins)."""
    for value in values:
        socket = as_socket(value)
        if socket is not None:
            return _DATA_TYPES.get(socket.type, "FLOAT")
    for value in values:
        if isinstance(value, bool):
            return "BOOLEAN"
        if isinstance(value, Sequence) and len(value) == 3:
            return "VECTOR"
        if isinstance(value, int):
            return "INT"
    return "FLOAT"


def is_vector(value: Value) -> bool:
    """Whether `value` is a vector socket or a 3-sequence constant."""
    socket = as_socket(value)
    if socket is not None:
        return socket.type == "VECTOR"
    return isinstance(value, Sequence) and not isinstance(value, str) and len(value) == 3


def _as_vector_constant(value: Value) -> Value:
    """A number broadcast to (v, v, v) for a vector input; anything else unchanged."""
    if as_socket(value) is None and isinstance(value, int | float):
        return (float(value),) * 3
    return value


class _Level:
    """A tree being built: the program's own, or a group's (a group node in `parent`)."""

    def __init__(self, tree, parent: _Level | None = None, node=None):
        self.tree, self.parent, self.node = tree, parent, node
        self.frame = None           # the labelled frame new nodes go into
        self.imported: dict = {}    # outer socket pointer -> this tree's group-input socket
        self.exported: dict = {}    # inner socket pointer -> the group node's output socket


class Parameters(dict):
    """A program's parameters by name (their sockets), in the order they were added."""

    def __init__(self, graph: Graph):
        super().__init__()
        self.graph = graph

    def add(self, name: str, kind: str, default: Value, min: float, max: float,
            description: str) -> Socket:
        """Declare a parameter: `Graph.input`'s arguments, in its order."""
        self[name] = self.graph.input(name, kind, default=default, min=min, max=max,
                                      description=description)
        return self[name]


class Graph:
    """Builder over one geometry node tree.

    `with g.group("Handles"):` builds what follows inside a named node group; a value from
    outside becomes an input of that group, and a value used outside after the block
    becomes an output, so a program reads the same with or without groups. `with
    g.frame("Assembly"):` puts the nodes that follow into a labelled frame.
    """

    def __init__(self, tree: bpy.types.GeometryNodeTree):
        self.root = _Level(tree)
        self._open = [self.root]                 # innermost last
        self._levels = {tree.name: self.root}    # every tree built here, by name
        self._names: dict[int, str] = {}         # socket pointer -> name given by `named`
        self._components: dict[tuple, Node] = {}  # (tree, vector) pointers -> Separate XYZ

    @classmethod
    def new(cls, name: str) -> Graph:
        return cls(bpy.data.node_groups.new(name, "GeometryNodeTree"))

    @property
    def tree(self) -> bpy.types.GeometryNodeTree:
        """The tree new nodes go into: the innermost open group's, else the program's."""
        return self._open[-1].tree

    # -- groups and frames --------------------------------------------------------------------

    @contextmanager
    def group(self, name: str) -> Iterator[None]:
        """Build the block's nodes inside a new node group, `name` in the node editor."""
        outer = self._open[-1]
        tree = bpy.data.node_groups.new(f"{self.root.tree.name}: {name}", "GeometryNodeTree")
        node = self.node("GeometryNodeGroup", node_tree=tree).bl
        node.label = name
        level = self._levels[tree.name] = _Level(tree, outer, node)
        self._open.append(level)
        try:
            yield
        finally:
            self._open.pop()

    @contextmanager
    def frame(self, label: str) -> Iterator[None]:
        """Put the nodes added in the block into a frame labelled `label`."""
        level = self._open[-1]
        frame = level.tree.nodes.new("NodeFrame")
        frame.label = label
        frame.parent = level.frame
        previous, level.frame = level.frame, frame
        try:
            yield
        finally:
            level.frame = previous

    def named(self, name: str, value: Socket) -> Socket:
        """Name `value`: the input or output that carries it into or out of a group is called
        `name`, and so is its node when that has one output."""
        self._names[value.bl.as_pointer()] = name
        node = value.bl.node
        if sum(s.enabled for s in node.outputs) == 1:
            node.label = name
        return value

    def _crossing_name(self, socket) -> str:
        if socket.as_pointer() in self._names:
            return self._names[socket.as_pointer()]
        if socket.node.bl_idname in ("NodeGroupInput", "GeometryNodeGroup"):
            return socket.name
        return socket.node.label or socket.name

    def _bring(self, socket, tree) -> bpy.types.NodeSocket:
        """A socket of `tree` that carries the value of `socket`, from whichever tree of
        this graph it lives in: through the outputs of the groups it is inside of, then the
        inputs of the groups `tree` is inside of."""
        source = socket.id_data
        if source == tree:
            return socket
        level = self._levels[source.name]
        if self._inside(level, tree):
            return self._bring(self._export(level, socket), tree)
        inner = self._levels[tree.name]
        return self._import(inner, self._bring(socket, inner.parent.tree))

    def _inside(self, level: _Level, tree) -> bool:
        while level.parent is not None:
            level = level.parent
            if level.tree == tree:
                return True
        return False

    def _import(self, level: _Level, outer) -> bpy.types.NodeSocket:
        key = outer.as_pointer()
        if key not in level.imported:
            item = level.tree.interface.new_socket(self._crossing_name(outer), in_out="INPUT",
                                                   socket_type=_INTERFACE_TYPES[outer.type])
            level.parent.tree.links.new(outer, find_socket(level.node.inputs, item.identifier,
                                                           level.node))
            level.imported[key] = find_socket(self._io_node(level, "NodeGroupInput").outputs,
                                              item.identifier, level.tree)
        return level.imported[key]

    def _export(self, level: _Level, inner) -> bpy.types.NodeSocket:
        key = inner.as_pointer()
        if key not in level.exported:
            # a group's geometry is called after the group unless it was given a name
            name = self._names.get(key) or (level.node.label if inner.type == "GEOMETRY"
                                            else self._crossing_name(inner))
            item = level.tree.interface.new_socket(name, in_out="OUTPUT",
                                                   socket_type=_INTERFACE_TYPES[inner.type])
            level.tree.links.new(inner, find_socket(
                self._io_node(level, "NodeGroupOutput").inputs, item.identifier, level.tree))
            level.exported[key] = find_socket(level.node.outputs, item.identifier, level.node)
        return level.exported[key]

    @staticmethod
    def _io_node(level: _Level, bl_idname: str) -> bpy.types.Node:
        """The Group Input or Group Output node of `level`'s tree, added (into the level's
        open frame) if missing."""
        for node in level.tree.nodes:
            if node.bl_idname == bl_idname:
                return node
        node = level.tree.nodes.new(bl_idname)
        node.parent = level.frame
        return node

    # -- nodes and links ----------------------------------------------------------------------

    def node(self, bl_idname: str, inputs: Mapping[str, Value] | Sequence[Value] = (),
             **props) -> Node:
        """Add a node, set its properties (before inputs: they decide which sockets are
        enabled), then set inputs: a mapping by identifier/name, or a sequence for the
        positional operands of Math-like nodes."""
        node = Node(self, self.tree.nodes.new(bl_idname))
        node.bl.parent = self._open[-1].frame
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
        if as_socket(value) is not None:
            self.link(value, target)
        elif isinstance(value, Sequence) and not isinstance(value, str):
            target.default_value = tuple(value)
        else:
            target.default_value = value

    def link(self, source: Value, target: bpy.types.NodeSocket) -> None:
        tree = target.id_data
        tree.links.new(self._bring(as_socket(source), tree), target)

    # -- group interface ----------------------------------------------------------------------

    def input(self, name: str, kind: str, *, default: Value = None, min: float | None = None,
              max: float | None = None, description: str = "") -> Socket:
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
        return Socket(self, find_socket(self._io_node(self._open[-1], "NodeGroupInput").outputs,
                                        item.identifier, self.tree))

    def parameters(self) -> Parameters:
        """An empty table of a program's parameters: `add(name, kind, default, min, max,
        meaning)` declares each as a group input, the one place its range is written."""
        return Parameters(self)

    def output(self, name: str, kind: str, value: Value) -> None:
        """Expose a group output named `name` and connect `value` to it."""
        item = self.tree.interface.new_socket(name, in_out="OUTPUT",
                                              socket_type=SOCKET_TYPES[kind])
        target = find_socket(self._io_node(self._open[-1], "NodeGroupOutput").inputs,
                             item.identifier, self.tree)
        self.set(target, value)

    # -- arithmetic (the operators of Socket land here) ---------------------------------------

    def math(self, operation: str, *operands: Value) -> Socket:
        """Math node; operation is its enum (ADD, SQRT, POWER, ...)."""
        return self.node("ShaderNodeMath", operands, operation=operation).out

    def vmath(self, operation: str, *operands: Value) -> Socket:
        """Vector math; SCALE takes (vector, scale), DOT/LENGTH/DISTANCE return a float."""
        node = self.node("ShaderNodeVectorMath", operation=operation)
        enabled = [s for s in node.bl.inputs if s.enabled]
        for socket, value in zip(enabled, operands, strict=False):
            self.set(socket, value)
        return node.out if operation not in ("DOT_PRODUCT", "LENGTH", "DISTANCE") \
            else node["Value"]

    def arithmetic(self, operation: str, a: Value, b: Value) -> Socket:
        """`a op b` for ADD/SUBTRACT/MULTIPLY/DIVIDE: Math on numbers; Vector Math when either
        is a vector, where a vector times a number is SCALE and a number elsewhere is
        broadcast to (n, n, n). Integer sockets are computed as floats, as Math does."""
        if not (is_vector(a) or is_vector(b)):
            return self.math(operation, a, b)
        if operation == "MULTIPLY" and not (is_vector(a) and is_vector(b)):
            vector, number = (a, b) if is_vector(a) else (b, a)
            return self.vmath("SCALE", vector, number)
        return self.vmath(operation, _as_vector_constant(a), _as_vector_constant(b))

    def min(self, a: Value, b: Value) -> Socket:
        return self.math("MINIMUM", a, b)

    def max(self, a: Value, b: Value) -> Socket:
        return self.math("MAXIMUM", a, b)

    def clamp(self, value: Value, low: Value = 0.0, high: Value = 1.0) -> Socket:
        return self.node("ShaderNodeClamp", {"Value": value, "Min": low, "Max": high}).out

    def sqrt(self, value: Value) -> Socket:
        return self.math("SQRT", value)

    def sin(self, radians: Value) -> Socket:
        return self.math("SINE", radians)

    def cos(self, radians: Value) -> Socket:
        return self.math("COSINE", radians)

    def lerp(self, a: Value, b: Value, t: Value) -> Socket:
        """a + (b - a) t, linear interpolation (unclamped)."""
        return self.map_range(t, 0.0, 1.0, a, b, clamp=False)

    def map_range(self, value: Value, from_min: Value, from_max: Value, to_min: Value,
                  to_max: Value, *, interpolation: str = "LINEAR",
                  clamp: bool = True) -> Socket:
        return self.node("ShaderNodeMapRange", {
            "Value": value, "From Min": from_min, "From Max": from_max,
            "To Min": to_min, "To Max": to_max,
        }, interpolation_type=interpolation, clamp=clamp).out

    def int_math(self, operation: str, *operands: Value) -> Socket:
        return self.node("FunctionNodeIntegerMath", operands, operation=operation).out

    # -- vectors --------------------------------------------------------------------------------

    def vec(self, x: Value = 0.0, y: Value = 0.0, z: Value = 0.0) -> Socket:
        """Combine XYZ."""
        return self.node("ShaderNodeCombineXYZ", {"X": x, "Y": y, "Z": z}).out

    def xyz(self, vector: Value) -> Node:
        """Separate XYZ (outputs X, Y, Z); one node per vector socket, however often asked
        (`v.x`, `v.y` and `v.z` share it)."""
        socket = as_socket(vector)
        if socket is None:  # a constant: nothing to share
            return self.node("ShaderNodeSeparateXYZ", {"Vector": vector})
        key = (self.tree.as_pointer(), socket.as_pointer())
        if key not in self._components:
            self._components[key] = self.node("ShaderNodeSeparateXYZ", {"Vector": vector})
        return self._components[key]

    def dot(self, a: Value, b: Value) -> Socket:
        return self.vmath("DOT_PRODUCT", a, b)

    def cross(self, a: Value, b: Value) -> Socket:
        return self.vmath("CROSS_PRODUCT", a, b)

    def length(self, vector: Value) -> Socket:
        return self.vmath("LENGTH", vector)

    def distance(self, a: Value, b: Value) -> Socket:
        return self.vmath("DISTANCE", a, b)

    def normalize(self, vector: Value) -> Socket:
        return self.vmath("NORMALIZE", vector)

    # -- logic ----------------------------------------------------------------------------------

    def compare(self, operation: str, a: Value, b: Value, *,
                data_type: str | None = None) -> Socket:
        """operation: LESS_THAN, LESS_EQUAL, GREATER_THAN, GREATER_EQUAL, EQUAL, NOT_EQUAL."""
        if data_type is None and (is_vector(a) or is_vector(b)):
            raise TypeError("vectors have no order: compare their .x/.y/.z or g.length(v)")
        data_type = data_type or data_type_of(a, b)
        return self.node("FunctionNodeCompare", {"A": a, "B": b}, data_type=data_type,
                         operation=operation)["Result"]

    def boolean(self, operation: str, *operands: Value) -> Socket:
        return self.node("FunctionNodeBooleanMath", operands, operation=operation).out

    def when(self, condition: Value, then: Value, otherwise: Value = None) -> Socket:
        """`then` where `condition` holds, else `otherwise` (None: nothing, e.g. no geometry):
        the Switch node of `switch`, its values in the order of an if."""
        return self.switch(condition, otherwise, then)

    def switch(self, condition: Value, if_false: Value, if_true: Value, *,
               data_type: str | None = None) -> Socket:
        """The Switch node, its values in the node's order (False, then True)."""
        data_type = data_type or data_type_of(if_false, if_true)
        return self.node("GeometryNodeSwitch", {
            "Switch": condition, "False": if_false, "True": if_true,
        }, input_type=data_type)["Output"]

    def index_switch(self, index: Value, items: Sequence[Value], *,
                     data_type: str | None = None) -> Socket:
        """Output items[index]; an index out of range gives the type's zero value."""
        node = self.node("GeometryNodeIndexSwitch", data_type=data_type or data_type_of(*items))
        while len(node.bl.index_switch_items) < len(items):
            node.bl.index_switch_items.new()
        self.set(node.input("Index"), index)
        for i, item in enumerate(items):
            if item is not None:
                self.set(node.input(f"Item_{i}"), item)
        return node["Output"]

    # -- fields -----------------------------------------------------------------------------

    def position(self) -> Socket:
        return self.node("GeometryNodeInputPosition").out

    def normal(self) -> Socket:
        return self.node("GeometryNodeInputNormal")["Normal"]

    def tangent(self) -> Socket:
        return self.node("GeometryNodeInputTangent").out

    def index(self) -> Socket:
        return self.node("GeometryNodeInputIndex").out

    def spline_factor(self) -> Socket:
        """Field: the fraction of the spline's length at each point, in [0, 1]."""
        return self.node("GeometryNodeSplineParameter")["Factor"]

    # -- curves -----------------------------------------------------------------------------

    def line(self, start: Value, end: Value, *, count: Value = None) -> Socket:
        """A straight curve from `start` to `end`; with `count`, resampled to that many
        evenly spaced points (else its two end points)."""
        line = self.node("GeometryNodeCurvePrimitiveLine", {"Start": start, "End": end}).out
        return line if count is None else self.resample(line, count)

    def resample(self, curve: Value, count: Value) -> Socket:
        """Resample Curve to `count` evenly spaced points."""
        return self.node("GeometryNodeResampleCurve", {"Curve": curve, "Mode": "Count",
                                                       "Count": count}).out

    def set_tilt(self, curve: Value, tilt: Value) -> Socket:
        return self.node("GeometryNodeSetCurveTilt", {"Curve": curve, "Tilt": tilt}).out

    # -- geometry ---------------------------------------------------------------------------

    def join(self, geometries: Iterable[Value]) -> Socket:
        """Join Geometry; the multi-input keeps the order of `geometries`."""
        node = self.node("GeometryNodeJoinGeometry")
        # multi-input sockets list links in reverse order of creation
        for geometry in reversed(list(geometries)):
            self.link(geometry, node.input("Geometry"))
        return node.out

    def transform(self, geometry: Value, *, translation: Value = None, rotation: Value = None,
                  scale: Value = None) -> Socket:
        """Transform Geometry; rotation is an Euler vector (radians) or a rotation socket."""
        if rotation is not None and not _is_rotation(rotation):
            rotation = self.euler_to_rotation(rotation)
        return self.node("GeometryNodeTransform", {
            "Geometry": geometry, "Translation": translation, "Rotation": rotation,
            "Scale": scale,
        }).out

    def euler_to_rotation(self, euler: Value) -> Socket:
        return self.node("FunctionNodeEulerToRotation", {"Euler": euler}).out

    def set_position(self, geometry: Value, *, position: Value = None,
                     offset: Value = None) -> Socket:
        return self.node("GeometryNodeSetPosition", {
            "Geometry": geometry, "Position": position, "Offset": offset}).out

    def delete_faces(self, geometry: Value, selection: Value) -> Socket:
        """Delete the selected faces only, keeping their edges and points."""
        return self.node("GeometryNodeDeleteGeometry", {
            "Geometry": geometry, "Selection": selection},
            domain="FACE", mode="ONLY_FACE").out

    def bounding_box(self, geometry: Value) -> Node:
        """Bounding Box: outputs `Bounding Box` (a mesh), `Min` and `Max` (vectors)."""
        return self.node("GeometryNodeBoundBox", {"Geometry": geometry})

    def instance_on_points(self, points: Value, instance: Value, *, rotation: Value = None,
                           scale: Value = None) -> Socket:
        """A copy of `instance` on every point, turned by `rotation` and sized by `scale`
        (fields), realized into plain geometry."""
        copies = self.node("GeometryNodeInstanceOnPoints", {
            "Points": points, "Instance": instance, "Rotation": rotation, "Scale": scale,
        }).out
        return self.realize(copies)

    def realize(self, geometry: Value) -> Socket:
        return self.node("GeometryNodeRealizeInstances", {"Geometry": geometry}).out

    def label(self, geometry: Value, label: Value) -> Socket:
        """Store the integer segmentation label `label` on every face (LABEL_ATTRIBUTE)."""
        return self.node("GeometryNodeStoreNamedAttribute", {
            "Geometry": geometry, "Name": LABEL_ATTRIBUTE, "Value": label,
        }, data_type="INT", domain="FACE").out

    def ground(self, geometry: Value) -> Socket:
        """`geometry` moved along z so that its lowest point lies on z = 0."""
        lowest = self.bounding_box(geometry)["Min"].z
        return self.transform(geometry, translation=self.vec(0.0, 0.0, -lowest))

    # -- layout -----------------------------------------------------------------------------

    def arrange(self) -> None:
        """Lay out the program's tree and its groups for Blender's node editor."""
        for level in self._levels.values():
            arrange(level.tree)


def arrange(tree, dx: float = 260.0, dy: float = 200.0) -> None:
    """Columns by depth from the inputs; the nodes of each frame in a band of their own,
    bands stacked downwards in the order the frames were made."""
    nodes = [node for node in tree.nodes if node.bl_idname != "NodeFrame"]
    depth = {node.name: 0 for node in nodes}
    for _ in range(len(depth)):
        changed = False
        for link in tree.links:
            new = depth[link.from_node.name] + 1
            if new > depth[link.to_node.name]:
                depth[link.to_node.name] = new
                changed = True
        if not changed:
            break
    bands: dict[str, list] = {}  # frame name ("" outside frames) -> its nodes
    for node in nodes:
        bands.setdefault(node.parent.name if node.parent else "", []).append(node)
    top = 0.0
    for band in bands.values():
        rows: dict[int, int] = {}
        for node in band:
            column = depth[node.name]
            node.location_absolute = (column * dx, top - rows.get(column, 0) * dy)
            rows[column] = rows.get(column, 0) + 1
        top -= (max(rows.values()) + 1) * dy


def _is_rotation(value: Value) -> bool:
    socket = as_socket(value)
    return socket is not None and socket.type == "ROTATION"
