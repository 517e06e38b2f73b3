"""Loft (a surface between two curves) and repeat zones, evaluated in Blender."""

import numpy as np
import pytest

pytest.importorskip("bpy")

from geocode.nodes import Evaluator, Graph, Repeat, loft, quadratic_cartesian  # noqa: E402
from geocode.nodes.visibility import infer_visibility  # noqa: E402

pytestmark = pytest.mark.blender


def _evaluate(build, values=None):
    g = Graph.new("probe")
    g.output("Geometry", "geometry", build(g))
    return Evaluator(g.tree).mesh(values)


def _sides(g):
    """A bowed right side from (0.4, 0, 0) to (0.3, 0, 1) and its mirror image."""
    right = quadratic_cartesian(g, start=(0.4, 0, 0), end=(0.3, 0, 1), offset=(0.1, 0, 0),
                                resolution=8)["Curve"]
    return g.transform(right, scale=(-1.0, 1.0, 1.0)), right


def test_loft_spans_the_two_curves_and_faces_forward(blender):
    def build(g):
        left, right = _sides(g)
        return loft(g, curve_a=left, curve_b=right, rows=8)["Mesh"]

    mesh = _evaluate(build)
    assert len(mesh.vertices) == 18 and len(mesh.faces) == 16
    # the edges are the curves: mirror images, bowed out past both ends' widths
    left = mesh.vertices[mesh.vertices[:, 0] < 0]
    right = mesh.vertices[mesh.vertices[:, 0] > 0]
    assert np.allclose(np.sort(left[:, 2]), np.sort(right[:, 2]))
    assert right[:, 0].max() > 0.4 and right[np.argmax(right[:, 2]), 0] == pytest.approx(0.3)
    assert np.allclose(mesh.face_normals, (0, -1, 0), atol=1e-6)  # left -> right, rising


def test_loft_cell_covers_its_share_with_gaps(blender):
    def build(g):
        left, right = _sides(g)
        return loft(g, curve_a=left, curve_b=right, start=0.25, end=0.75, span_start=0.5,
                    span_end=1.0, inset=0.01, rows=4)["Mesh"]

    v = _evaluate(build).vertices
    assert v[:, 2].min() > 0.2 and v[:, 2].max() < 0.8  # a middle share of the height
    assert v[:, 0].min() == pytest.approx(0.01)  # from the middle, moved in by the inset ...
    full = _evaluate(lambda g: loft(g, curve_a=_sides(g)[0], curve_b=_sides(g)[1], start=0.25,
                                    end=0.75, rows=4)["Mesh"]).vertices
    assert v[:, 0].max() == pytest.approx(full[:, 0].max() - 0.01)  # ... to the side


def test_repeat_zone_carries_its_state_through_the_passes(blender):
    def build(g):
        count = g.input("Count", "int", default=3, min=0, max=10)
        zone = Repeat(g, count, geometry=None, x=0.5)
        cube = g.node("GeometryNodeMeshCube", {"Size": (0.1, 0.1, 0.1)}).out
        placed = g.transform(cube, translation=g.vec(zone["x"], 0, zone.iteration))
        return zone.close(geometry=g.join([zone["geometry"], placed]),
                          x=zone["x"] * 2.0)["geometry"]

    mesh = _evaluate(build)
    centres = np.array(sorted({tuple(np.round(c, 4)) for c in
                               mesh.vertices.reshape(-1, 8, 3).mean(axis=1)}))
    assert np.allclose(centres, [(0.5, 0, 0), (1.0, 0, 1), (2.0, 0, 2)])
    assert len(_evaluate(build, {"Count": 0}).vertices) == 0


def test_repeat_zone_names_its_items(blender):
    g = Graph.new("probe")
    zone = Repeat(g, 2, geometry=None, x=0.0)
    with pytest.raises(TypeError, match="items are"):
        zone.close(geometry=None)


def test_visibility_passes_through_a_repeat_zone(blender):
    g = Graph.new("probe")
    extra = g.input("extra", "bool", default=False)
    size = g.input("size", "float", default=0.1, min=0.0, max=1.0)
    zone = Repeat(g, 2, geometry=None)
    cube = g.node("GeometryNodeMeshCube", {"Size": g.vec(size, size, size)}).out
    built = g.join([zone["geometry"], g.switch(extra, None, cube)])
    g.output("Geometry", "geometry", zone.close(geometry=built)["geometry"])
    assert str(infer_visibility(g.tree)["size"]) == "extra"
