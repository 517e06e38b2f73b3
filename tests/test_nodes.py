"""The Geometry Nodes builder and the node-group decorator, evaluated in real Blender."""

import importlib

import numpy as np
import pytest

from geocode.nodes import Evaluator, Graph, NodeGroup, node_group

pytestmark = pytest.mark.blender


def _point_graph(build) -> Evaluator:
    """A graph whose output is one vertex at the vector `build(g)` returns."""
    g = Graph.new("probe")
    vector = build(g)
    vertex = g.node("GeometryNodeMeshLine", {"Count": 1, "Start Location": vector})
    g.output("Geometry", "geometry", vertex)
    return Evaluator(g.tree)


def _point(build, values=None) -> np.ndarray:
    return _point_graph(build).mesh(values).vertices[0]


def test_input_declares_typed_interface_sockets(blender):
    g = Graph.new("inputs")
    g.input("size", "float", default=0.5, min=0.1, max=2.0, description="how big")
    g.input("count", "int", default=3, min=0, max=9)
    g.input("on", "bool", default=True)
    g.input("offset", "vector", default=(1, 2, 3), min=-5, max=5)
    items = {i.name: i for i in g.tree.interface.items_tree if i.in_out == "INPUT"}
    assert items["size"].socket_type == "NodeSocketFloat"
    assert items["size"].min_value == pytest.approx(0.1)
    assert items["size"].max_value == pytest.approx(2.0)
    assert items["size"].default_value == pytest.approx(0.5)
    assert items["size"].description == "how big"
    assert items["count"].socket_type == "NodeSocketInt"
    assert items["on"].socket_type == "NodeSocketBool" and items["on"].default_value
    assert tuple(items["offset"].default_value) == (1, 2, 3)


def test_arithmetic_helpers_compute_in_blender(blender):
    def build(g):
        x = g.input("x", "float", default=3.0)
        return g.vec(x + 2, (x - 1) * (x / 2), g.lerp(10.0, 20.0, 0.25))

    assert _point(build) == pytest.approx([5.0, 3.0, 12.5])
    assert _point(build, {"x": 1.0}) == pytest.approx([3.0, 0.0, 12.5])


def test_switches_and_comparisons(blender):
    def build(g):
        n = g.input("n", "int", default=0, min=0, max=2)
        flag = g.compare("GREATER_THAN", n, 0, data_type="INT")
        chosen = g.index_switch(n, [1.0, 2.0, 4.0], data_type="FLOAT")
        return g.vec(g.switch(flag, -1.0, 1.0), chosen, g.map_range(0.5, 0, 1, 0, 8))

    evaluator = _point_graph(build)
    assert evaluator.mesh({"n": 0}).vertices[0] == pytest.approx([-1, 1, 4])
    assert evaluator.mesh({"n": 2}).vertices[0] == pytest.approx([1, 4, 4])


def test_when_is_the_switch_read_as_an_if(blender):
    def build(g):
        n = g.input("n", "int", default=0, min=0, max=2)
        on = g.compare("GREATER_THAN", n, 0, data_type="INT")
        return g.vec(g.when(on, 1.0, -1.0), g.when(on, 2.0), 0.0)

    evaluator = _point_graph(build)
    assert evaluator.mesh({"n": 1}).vertices[0] == pytest.approx([1, 2, 0])
    assert evaluator.mesh({"n": 0}).vertices[0] == pytest.approx([-1, 0, 0])
    switch = next(n for n in evaluator.object.modifiers[0].node_group.nodes
                  if n.bl_idname == "GeometryNodeSwitch")
    assert switch.inputs["True"].default_value == 1.0
    assert switch.inputs["False"].default_value == -1.0


def test_every_block_and_helper_is_exported():
    import geocode.nodes as nodes

    catalogue = ("attachment", "curves", "meshes", "profiles", "shells", "styles", "surfaces",
                 "symmetry", "utils")
    for chapter in catalogue:
        module = importlib.import_module(f"geocode.nodes.{chapter}")
        blocks = {name for name, value in vars(module).items()
                  if isinstance(value, NodeGroup) and value.build.__module__ == module.__name__}
        helpers = {name for name, value in vars(module).items()
                   if callable(value) and getattr(value, "__module__", "") == module.__name__
                   and not name.startswith("_")}
        assert blocks | helpers <= set(nodes.__all__), (chapter, blocks | helpers)
        assert all(nodes.BLOCKS[getattr(module, name).name] is getattr(module, name)
                   for name in blocks)
    assert all(hasattr(nodes, name) for name in nodes.__all__)



def test_vector_math_and_separate(blender):
    def build(g):
        v = g.cross((1, 0, 0), (0, 1, 0))
        return g.vec(v.z, g.length((3, 4, 0)), g.distance((1, 1, 1), (1, 1, 3)))

    assert _point(build) == pytest.approx([1, 5, 2])


def test_sockets_are_found_by_name_and_errors_name_the_choices(blender):
    g = Graph.new("names")
    node = g.node("GeometryNodeCurveToMesh")
    assert node.input("Profile Curve").identifier == "Profile Curve"
    with pytest.raises(KeyError, match="Profile Curve"):
        node.input("Profil")


def test_node_group_is_cached_and_rebuilt_after_reset(blender):
    calls = []

    @node_group("TestOffset")
    def offset(g):
        """Adds `Amount` to `Value`."""
        value = g.input("Value", "float", default=0.0)
        amount = g.input("Amount", "float", default=1.0)
        calls.append(1)
        g.output("Result", "float", value + amount)

    assert offset.tree() is offset.tree()
    assert len(calls) == 1
    assert offset.tree().description == "Adds `Amount` to `Value`."
    assert _point(lambda g: g.vec(offset(g, value=2.0, amount=0.5)["Result"], 0, 0))[0] \
        == pytest.approx(2.5)
    blender.ops.wm.read_factory_settings(use_empty=True)
    assert offset.tree().name == "TestOffset"
    assert len(calls) == 2
    with pytest.raises(TypeError, match="no input 'bogus'"):
        offset(Graph.new("x"), bogus=1.0)


def test_labels_land_on_faces(blender):
    g = Graph.new("labelled")
    cube = g.node("GeometryNodeMeshCube", {"Size": (1, 1, 1)})
    g.output("Geometry", "geometry", g.label(cube, 7))
    mesh = Evaluator(g.tree).mesh()
    assert len(mesh.faces) == 12
    assert (mesh.metadata["part"] == 7).all()


def test_arrange_spreads_nodes_into_columns(blender):
    g = Graph.new("layout")
    x = g.input("x", "float")
    g.output("y", "float", x * 2 + 1)
    g.arrange()
    xs = sorted({node.location.x for node in g.tree.nodes})
    assert len(xs) == 4  # input, multiply, add, output


# -- socket operators ---------------------------------------------------------------------------

def _signature(tree) -> list:
    """The graph as data: each node's type, operation/data type and unlinked input values,
    in creation order, then every link by (node index, socket identifier)."""
    index = {node.name: i for i, node in enumerate(tree.nodes)}
    nodes = []
    for node in tree.nodes:
        props = tuple(getattr(node, p, None) for p in ("operation", "data_type", "mode"))
        values = tuple((s.identifier, _rounded(s.default_value)) for s in node.inputs
                       if s.enabled and not s.is_linked and hasattr(s, "default_value"))
        nodes.append((node.bl_idname, props, values))
    links = sorted((index[k.from_node.name], k.from_socket.identifier, index[k.to_node.name],
                    k.to_socket.identifier) for k in tree.links)
    return [nodes, links]


def _rounded(value):
    try:
        return tuple(round(v, 6) for v in value)
    except TypeError:
        return round(value, 6) if isinstance(value, float) else value


def _inputs(g):
    return (g.input("x", "float", default=0.3), g.input("splay", "float", default=0.1),
            g.input("v", "vector", default=(1, 2, 3)), g.input("on", "bool", default=True),
            g.input("n", "int", default=2))


def test_operators_build_the_same_graph_as_explicit_calls(blender):
    def with_operators(g):
        x, splay, v, on, n = _inputs(g)
        foot = g.vec(x + splay, -x - splay, 0.0)
        g.vec(1.0 - x, 2 * x / splay, abs(x))
        v * x, x * v, v + (1, 0, 0), (0, 0, 1) - v, v / 2, -v, abs(v)
        (x < 0.5) & ~on | (0.5 <= x) | (n > 0)
        _ = x >= splay
        return foot.x, foot.y, foot.z

    def explicit(g):
        x, splay, v, on, n = _inputs(g)
        foot = g.node("ShaderNodeCombineXYZ", {
            "X": g.math("ADD", x, splay),
            "Y": g.math("SUBTRACT", g.math("MULTIPLY", x, -1.0), splay), "Z": 0.0}).out
        g.node("ShaderNodeCombineXYZ", {
            "X": g.math("SUBTRACT", 1.0, x),
            "Y": g.math("DIVIDE", g.math("MULTIPLY", 2, x), splay),
            "Z": g.math("ABSOLUTE", x)})
        g.vmath("SCALE", v, x), g.vmath("SCALE", v, x), g.vmath("ADD", v, (1, 0, 0))
        g.vmath("SUBTRACT", (0, 0, 1), v), g.vmath("DIVIDE", v, (2.0, 2.0, 2.0))
        g.vmath("SCALE", v, -1.0), g.vmath("ABSOLUTE", v)
        below = g.compare("LESS_THAN", x, 0.5, data_type="FLOAT")
        either = g.boolean("OR", g.boolean("AND", below, g.boolean("NOT", on)),
                           g.compare("GREATER_EQUAL", x, 0.5, data_type="FLOAT"))
        g.boolean("OR", either, g.compare("GREATER_THAN", n, 0, data_type="INT"))
        g.compare("GREATER_EQUAL", x, splay, data_type="FLOAT")
        xyz = g.node("ShaderNodeSeparateXYZ", {"Vector": foot})
        return xyz["X"], xyz["Y"], xyz["Z"]

    graphs = []
    for build in (with_operators, explicit):
        g = Graph.new(build.__name__)
        build(g)
        graphs.append(_signature(g.tree))
    assert graphs[0] == graphs[1]


def test_operators_compute_in_blender(blender):
    def build(g):
        x = g.input("x", "float", default=3.0)
        v = g.vec(x, 1.0, -2.0)
        flag = (x > 2) & ~(x >= 5)
        w = (v * 2 + (1, 1, 1)) / x - v
        return g.vec(g.switch(flag, -1.0, 1.0) + abs(v.z) + w.x, 1.0 - x / 2, -w.y)

    assert _point(build) == pytest.approx([1 + 2 + 7 / 3 - 3, -0.5, 0.0])
    assert _point(build, {"x": 6.0}) == pytest.approx([-1 + 2 + 13 / 6 - 6, -2.0, 0.5])


def test_sockets_forward_bpy_attributes_and_refuse_truth_and_vector_order(blender):
    g = Graph.new("misuse")
    x = g.input("x", "float", default=0.0)
    v = g.vec(x, x, x)
    assert x.type == "VALUE" and x.name == "x" and v.type == "VECTOR"
    assert v.x.node == v.y.node  # one Separate XYZ per vector
    with pytest.raises(TypeError, match="truth value"):
        bool(x < 1)
    with pytest.raises(TypeError, match="truth value"):
        max(x, 1.0)
    with pytest.raises(TypeError, match="no order"):
        _ = v < 1.0


def test_geometry_helpers_ground_and_bound(blender):
    g = Graph.new("ground")
    h = g.input("h", "float", default=0.5)
    line = g.line(g.vec(0.0, 0.0, h), g.vec(1.0, 0.0, h + 1), count=5)
    grounded = g.ground(g.node("GeometryNodeCurveToMesh", {"Curve": line}))
    g.output("Geometry", "geometry", grounded)
    vertices = Evaluator(g.tree).mesh({"h": 0.7}).vertices
    assert len(vertices) == 5
    assert vertices[:, 2].min() == pytest.approx(0.0, abs=1e-6)
    assert vertices[:, 2].max() == pytest.approx(1.0)


# -- groups and frames ----------------------------------------------------------------------------

def test_groups_capture_inputs_and_outputs_and_compute_the_same(blender):
    def build(g):
        x = g.input("x", "float", default=3.0)
        with g.group("Double"):
            doubled = g.named("doubled", 2 * x)
            with g.group("Inner"):
                inner = doubled + x       # x enters through both groups
        with g.group("Sibling"):
            sibling = inner * 10          # from one group's inner group into a sibling
        with g.frame("Assembly"):
            return g.vec(doubled, sibling, x - 1)

    evaluator = _point_graph(build)
    assert evaluator.mesh().vertices[0] == pytest.approx([6, 90, 2])
    assert evaluator.mesh({"x": 1.0}).vertices[0] == pytest.approx([2, 30, 0])
    tree = blender.data.node_groups["probe"]
    groups = {n.label: n for n in tree.nodes if n.bl_idname == "GeometryNodeGroup"}
    assert set(groups) == {"Double", "Sibling"}
    double = groups["Double"].node_tree
    assert [i.name for i in double.interface.items_tree if i.in_out == "INPUT"] == ["x"]
    assert {i.name for i in double.interface.items_tree if i.in_out == "OUTPUT"} \
        == {"doubled", "Value"}
    inner = next(n for n in double.nodes if n.label == "Inner").node_tree
    assert [i.name for i in inner.interface.items_tree if i.in_out == "INPUT"] \
        == ["doubled", "x"]
    framed = [n for n in tree.nodes if n.parent is not None]
    assert {n.parent.label for n in framed} == {"Assembly"}
    assert {n.bl_idname for n in framed} == {"ShaderNodeCombineXYZ", "ShaderNodeMath"}
