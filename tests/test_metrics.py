"""Chamfer distance (docs/paper-numbers.md#evaluation) against a brute-force reference; the
cells' nearest neighbours against scipy's tree."""

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from geocode.metrics import Cells, chamfer, chamfer_meshes


def brute_chamfer(a, b):
    d = ((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)
    return (d.min(1).mean() + d.min(0).mean()) / 2


def test_chamfer_matches_brute_force():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(200, 3)), rng.normal(size=(150, 3))
    assert chamfer(a, b) == pytest.approx(brute_chamfer(a, b), rel=1e-10)


def test_chamfer_symmetric_and_zero_on_identical():
    rng = np.random.default_rng(1)
    a, b = rng.random((100, 3)), rng.random((80, 3))
    assert chamfer(a, b) == pytest.approx(chamfer(b, a), rel=1e-12)
    assert chamfer(a, a) == 0.0


def test_chamfer_known_value():
    """Clouds one unit apart along x: every squared nearest distance is 1."""
    a = np.array([[0.0, 0, 0], [0, 5, 0]])
    assert chamfer(a, a + [1.0, 0, 0]) == pytest.approx(1.0)


def test_chamfer_accepts_float32_and_rejects_empty():
    a = np.random.default_rng(2).random((50, 3)).astype(np.float32)
    assert chamfer(a, a + np.float32(0.5)) == pytest.approx(chamfer(a.astype(np.float64), a + 0.5), rel=1e-6)
    with pytest.raises(ValueError):
        chamfer(np.zeros((0, 3)), a)


def test_chamfer_meshes_normalises_scale_and_position():
    sphere = trimesh.creation.icosphere(3)
    moved = sphere.copy()
    moved.apply_scale(3.0)
    moved.apply_translation((5, -2, 1))
    same = chamfer_meshes(sphere, moved, n=5000, rng=np.random.default_rng(0))
    box = trimesh.creation.box((1, 1, 1))
    other = chamfer_meshes(sphere, box, n=5000, rng=np.random.default_rng(0))
    assert same < 1e-3 < other


def test_chamfer_meshes_is_reproducible():
    a, b = trimesh.creation.icosphere(2), trimesh.creation.box((1, 2, 1))
    assert chamfer_meshes(a, b, n=2000) == chamfer_meshes(a, b, n=2000)


def surface_cloud(n: int, seed: int) -> np.ndarray:
    """Points on a box and a sphere apart: flat, clustered, with empty space between."""
    rng = np.random.default_rng(seed)
    box = trimesh.creation.box((1.0, 0.2, 0.6)).sample(n // 2, seed=seed)
    ball = rng.normal(size=(n - n // 2, 3))
    return np.concatenate([box, 0.3 * ball / np.linalg.norm(ball, axis=1, keepdims=True) + [0.8, 0.5, 0.2]])


@pytest.mark.parametrize("per_cell", [1.0, 16.0, 1000.0])
def test_cells_find_what_the_tree_finds_to_the_bit(per_cell):
    """Queries on the cloud, near it, far outside its box and inside its empty space: the same
    distances as cKDTree to the last bit, and each index names a point at that distance."""
    rng = np.random.default_rng(0)
    cloud = surface_cloud(3000, 1)
    queries = np.concatenate([surface_cloud(1000, 2) * 1.05, rng.uniform(-4, 4, (300, 3)),
                              rng.normal(0, 20, (50, 3)), cloud[:100]])
    distance, index = Cells(cloud, per_cell).query(queries)
    expected = cKDTree(cloud).query(queries)[0]
    assert np.array_equal(distance, expected)
    assert np.array_equal(np.linalg.norm(cloud[index] - queries, axis=1), expected)


def test_cells_of_degenerate_clouds():
    """One point, a flat cloud, a line, repeated points: still exact."""
    rng = np.random.default_rng(3)
    queries = rng.normal(size=(200, 3))
    flat = np.c_[rng.random((500, 2)), np.zeros(500)]
    line = np.c_[rng.random(300), np.zeros((300, 2))]
    for cloud in (np.ones((1, 3)), flat, line, np.repeat(rng.random((5, 3)), 40, axis=0)):
        assert np.array_equal(Cells(cloud).query(queries)[0], cKDTree(cloud).query(queries)[0])


def test_cells_keep_their_points_in_cell_order():
    cloud = surface_cloud(500, 4)
    cells = Cells(cloud)
    assert sorted(map(tuple, cells.points)) == sorted(map(tuple, cloud))
    assert np.array_equal(cells.query(cells.points)[0], np.zeros(len(cloud)))


def test_cells_refuse_empty_or_non_finite_clouds():
    with pytest.raises(ValueError, match="at least one point"):
        Cells(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="finite"):
        Cells(np.array([[0.0, np.nan, 0.0]]))
    with pytest.raises(ValueError, match="finite"):
        Cells(np.zeros((3, 3))).query(np.array([[np.inf, 0.0, 0.0]]))
