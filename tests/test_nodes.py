"""The Geometry Nodes builder and the node-group decorator, evaluated in real Blender."""

import numpy as np
import pytest

pytest.importorskip("bpy")

from geocode.nodes import Evaluator, Graph, node_group  # noqa: E402

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
        return g.combine(g.add(x, 2), g.mul(g.sub(x, 1), g.div(x, 2)),
                         g.lerp(10.0, 20.0, 0.25))

    assert _point(build) == pytest.approx([5.0, 3.0, 12.5])
    assert _point(build, {"x": 1.0}) == pytest.approx([3.0, 0.0, 12.5])


def test_switches_and_comparisons(blender):
    def build(g):
        n = g.input("n", "int", default=0, min=0, max=2)
        flag = g.compare("GREATER_THAN", n, 0, data_type="INT")
        chosen = g.index_switch(n, [1.0, 2.0, 4.0], data_type="FLOAT")
        return g.combine(g.switch(flag, -1.0, 1.0), chosen, g.map_range(0.5, 0, 1, 0, 8))

    evaluator = _point_graph(build)
    assert evaluator.mesh({"n": 0}).vertices[0] == pytest.approx([-1, 1, 4])
    assert evaluator.mesh({"n": 2}).vertices[0] == pytest.approx([1, 4, 4])


def test_vector_math_and_separate(blender):
    def build(g):
        v = g.vmath("CROSS_PRODUCT", (1, 0, 0), (0, 1, 0))
        length = g.vmath("LENGTH", (3, 4, 0))
        return g.combine(g.separate(v)["Z"], length, 0)

    assert _point(build) == pytest.approx([1, 5, 0])


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
        g.output("Result", "float", g.add(value, amount))

    assert offset.tree() is offset.tree()
    assert len(calls) == 1
    assert offset.tree().description == "Adds `Amount` to `Value`."
    assert _point(lambda g: g.combine(offset(g, value=2.0, amount=0.5)["Result"], 0, 0))[0] \
        == pytest.approx(2.5)
    blender.ops.wm.read_factory_settings(use_empty=True)
    assert offset.tree().name == "TestOffset"
    assert len(calls) == 2
    with pytest.raises(TypeError, match="no input 'bogus'"):
        offset(Graph.new("x"), bogus=1.0)


def test_part_labels_land_on_faces(blender):
    g = Graph.new("labelled")
    cube = g.node("GeometryNodeMeshCube", {"Size": (1, 1, 1)})
    g.output("Geometry", "geometry", g.label_part(cube, 7))
    mesh = Evaluator(g.tree).mesh()
    assert len(mesh.faces) == 12
    assert (mesh.metadata["part"] == 7).all()


def test_arrange_spreads_nodes_into_columns(blender):
    g = Graph.new("layout")
    x = g.input("x", "float")
    g.output("y", "float", g.add(g.mul(x, 2), 1))
    g.arrange()
    xs = sorted({node.location.x for node in g.tree.nodes})
    assert len(xs) == 4  # input, multiply, add, output
