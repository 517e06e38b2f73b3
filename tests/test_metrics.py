"""Chamfer distance (docs/paper-numbers.md#evaluation) against a brute-force reference."""

import numpy as np
import pytest
import trimesh

from geocode.metrics import chamfer, chamfer_meshes


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
