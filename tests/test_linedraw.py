"""The numpy line renderer (`geocode.reconstruct.linedraw`): its camera, z-buffer and edges on shapes
whose drawing is known, its agreement with Freestyle, and the drawing distance."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from geocode.reconstruct import linedraw
from geocode.reconstruct.linedraw import (
    Outline,
    View,
    drawing_distance,
    edge_points,
    ink_points,
    strokes,
    zbuffer,
)

K = 224 / (2 * linedraw.MARGIN)   # px per unit at scale 1


def cube(half: float = 0.5) -> trimesh.Trimesh:
    return trimesh.creation.box((2 * half,) * 3)


def test_view_matches_blenders_front_camera():
    """From azimuth 0, elevation 0 (looking along +Y): +X is right, +Z up, depth grows
    along +Y; the origin lands on the image centre."""
    xy, depth = View(0.0, 0.0).project(np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [0, 1, 0.0]]))
    assert xy[0] == pytest.approx([112, 112])
    assert xy[1] == pytest.approx([112 + K, 112])
    assert xy[2] == pytest.approx([112, 112 - K])
    assert depth[3] - depth[0] == pytest.approx(K)
    # azimuth 90 looks from +X: +Y is right
    assert View(90.0, 0.0).project(np.array([[0, 1.0, 0]]))[0][0] == pytest.approx([112 + K, 112])


def test_front_cube_draws_its_square_and_nothing_inside():
    """A cube from the front: the four sides of its front face (crease and silhouette
    edges), not the diagonals of its triangles (flat), and no hidden back edge."""
    ink = strokes(Outline(cube().vertices, cube().faces), View(0.0, 0.0))
    lo, hi = int(np.floor(112 - 0.5 * K)), int(np.floor(112 + 0.5 * K))
    border = np.zeros_like(ink)
    border[lo:hi + 1, [lo, hi]] = border[[lo, hi], lo:hi + 1] = True
    assert ink[border].mean() > 0.97
    assert not ink[~border].any()


def test_three_quarter_cube_draws_its_nine_visible_edges_only():
    """From a raised three-quarter view a cube shows 9 of its 12 edges: all but the three
    of its far corner. The drawing is exactly those 9 edges' pixels (within 3 pixels), and
    none of the pixels only the 3 hidden edges would ink."""
    mesh = cube()
    view = View(35.0, 30.0)
    ink = strokes(Outline(mesh.vertices, mesh.faces), view)
    xy, depth = view.project(mesh.vertices)
    far = np.argmax(depth)
    edges = np.array([e for e in mesh.edges_unique
                      if np.sum(np.abs(mesh.vertices[e[0]] - mesh.vertices[e[1]]) > 1e-9) == 1])
    assert len(edges) == 12
    hidden = (edges == far).any(axis=1)
    seen = ink_points(edge_points(xy, depth, edges[~hidden])[0], 224)
    unseen = ink_points(edge_points(xy, depth, edges[hidden])[0], 224) & ~seen
    assert np.sum(ink ^ seen) <= 3
    assert unseen.sum() > 50 and (ink & unseen).sum() <= 3


def test_zbuffer_matches_a_per_triangle_rasteriser():
    rng = np.random.default_rng(3)
    xy, depth = rng.uniform(-10, 70, (60, 2)), rng.uniform(0, 5, 60)
    faces = rng.integers(0, 60, (80, 3))
    fast = zbuffer(xy, depth, faces, 64)
    slow = np.full((64, 64), np.inf)
    gx, gy = np.meshgrid(np.arange(64) + 0.5, np.arange(64) + 0.5)
    for f in faces:
        a, b, c = xy[f]
        m = np.array([a - c, b - c]).T
        if abs(np.linalg.det(m)) < 1e-9:
            continue
        la, lb = np.linalg.solve(m, np.stack([gx.ravel() - c[0], gy.ravel() - c[1]]))
        inside = (la >= -1e-6) & (lb >= -1e-6) & (1 - la - lb >= -1e-6)
        z = la * depth[f[0]] + lb * depth[f[1]] + (1 - la - lb) * depth[f[2]]
        np.minimum.at(slow.ravel(), np.nonzero(inside)[0], z[inside])
    assert np.array_equal(np.isfinite(fast), np.isfinite(slow))
    assert np.allclose(fast[np.isfinite(fast)], slow[np.isfinite(slow)])


def test_faces_turned_away_change_no_stroke_of_a_closed_solid(monkeypatch):
    """`strokes` z-buffers the faces turned towards the camera only: on closed solids (a box
    through a cylinder, from many views) it draws exactly what the z-buffer of every face
    draws."""
    mesh = trimesh.util.concatenate([trimesh.creation.box((1.0, 0.6, 0.3)),
                                     trimesh.creation.cylinder(0.2, 1.2, sections=24)])
    outline = Outline(mesh.vertices, mesh.faces)
    views = [View(a, e) for a in (0.0, 35.0, 100.0, 215.0) for e in (0.0, 30.0, 60.0)]
    culled = [strokes(outline, v) for v in views]
    every_face = linedraw.zbuffer
    monkeypatch.setattr(linedraw, "zbuffer", lambda xy, depth, faces, size: every_face(xy, depth, outline.faces, size))
    for view, ink in zip(views, culled, strict=True):
        assert ink.sum() > 100 and np.array_equal(ink, strokes(outline, view)), view


def test_roll_scale_and_offset_move_the_drawing():
    mesh = cube(0.3)
    outline = Outline(mesh.vertices, mesh.faces)
    base = strokes(outline, View(0.0, 0.0))
    shifted = strokes(outline, View(0.0, 0.0, offset=(5.0, -3.0)))
    assert np.array_equal(np.roll(np.roll(base, 5, axis=1), -3, axis=0), shifted)
    ys, xs = np.nonzero(strokes(outline, View(0.0, 0.0, scale=2.0)))
    assert xs.max() - xs.min() == pytest.approx(2 * 0.6 * K, abs=2)
    turned = strokes(outline, View(0.0, 0.0, roll=45.0))
    ys, xs = np.nonzero(turned)
    assert xs.max() - xs.min() == pytest.approx(np.sqrt(2) * 0.6 * K, abs=2)


def line(row: int) -> np.ndarray:
    image = np.ones((64, 64), dtype=np.float32)
    image[row, 10:50] = 0.0
    return image


def test_distance_of_parallel_lines_is_their_gap():
    assert drawing_distance(line(20), line(20)) == 0.0
    assert drawing_distance(line(20), line(23)) == pytest.approx(3.0)
    assert drawing_distance(line(20), line(23)) == drawing_distance(line(23), line(20))


def test_distance_is_truncated_and_blank_is_farthest():
    assert drawing_distance(line(10), line(50), truncate=8.0) == pytest.approx(8.0)
    assert drawing_distance(line(10), line(50), truncate=1e9) == pytest.approx(40.0)
    assert drawing_distance(np.ones((64, 64)), line(10)) == linedraw.TRUNCATE


def test_an_extra_stroke_costs_a_bounded_share():
    """A drawing with an extra far stroke as long as its only one: one direction's mean
    doubles at most to t/2, so the distance is at most t/4."""
    both = np.minimum(line(10), line(50))
    assert drawing_distance(both, line(10), truncate=8.0) == pytest.approx(2.0)


@pytest.mark.blender
def test_agrees_with_freestyle_on_program_shapes(tmp_path, blender):
    """Two chairs from a trained view: our drawing of each lies within half a pixel of
    Freestyle's (of order 0.2 px measured), ten times nearer than Freestyle's of the other."""
    from geocode.blender.sketch import Camera, renderer
    from geocode.meshio import normalise_unit_sphere
    from geocode.program import Program
    from geocode.steps.train_data import load_sketch

    program = Program.load("chair")
    rng = np.random.default_rng(1)
    meshes = [normalise_unit_sphere(program.evaluate(program.random_values(rng))) for _ in range(2)]
    ours, theirs = [], []
    for i, mesh in enumerate(meshes):
        renderer().set_mesh(mesh.vertices, mesh.faces)
        renderer().render(Camera("v", 35.0, 30.0), tmp_path / f"{i}.png")
        theirs.append(load_sketch(tmp_path / f"{i}.png"))
        ours.append(linedraw.render(mesh, View(35.0, 30.0)))
    other = drawing_distance(theirs[0], theirs[1])
    for a, b in zip(ours, theirs, strict=True):
        assert drawing_distance(a, b) < min(0.5, other / 10)
