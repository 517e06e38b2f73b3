"""Surface sampling, farthest point sampling, cloud files, robustness inputs, the shard stage."""

import logging

import numpy as np
import pytest
import trimesh

from geocode import meshio, points
from geocode.errors import UserError
from geocode.points import (
    add_noise,
    farthest_point_sampling,
    load_clouds,
    make_clouds,
    points_shard,
    sample_surface,
    save_clouds,
    simplify,
    sparse_cloud,
    surface_samples,
)


def two_triangles() -> trimesh.Trimesh:
    """Two disjoint right triangles with areas 1/2 and 3/2 (ratio 1:3)."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 0, 0], [8, 0, 0], [5, 1, 0]], dtype=float)
    return trimesh.Trimesh(v, [[0, 1, 2], [3, 4, 5]], process=False)


def test_sampling_is_area_weighted_and_on_the_surface():
    pts = sample_surface(two_triangles(), 40000, np.random.default_rng(0))
    assert pts.shape == (40000, 3) and pts.dtype == np.float32
    second = pts[:, 0] >= 5
    assert second.mean() == pytest.approx(0.75, abs=0.01)
    first = pts[~second]
    assert np.all(first[:, 0] + first[:, 1] <= 1 + 1e-6) and np.all(first >= -1e-6)
    # uniform inside a triangle: the mean is the centroid
    assert first[:, :2].mean(0) == pytest.approx([1 / 3, 1 / 3], abs=0.01)
    assert np.all(pts[:, 2] == 0)


def test_sampling_is_seeded():
    mesh = trimesh.creation.icosphere(2)
    a = sample_surface(mesh, 100, np.random.default_rng(7))
    b = sample_surface(mesh, 100, np.random.default_rng(7))
    assert np.array_equal(a, b)


def reference_samples(vertices, faces, n, rng):
    """`surface_samples`' definition in plain numpy, one array op at a time."""
    def mix(x):
        with np.errstate(over="ignore"):
            x = x + np.uint64(0x9E3779B97F4A7C15)
            x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            return x ^ (x >> np.uint64(31))

    def unit(x):
        return (x >> np.uint64(11)).astype(np.float64) * 2.0 ** -53

    tri = vertices[faces]
    area = np.sqrt(np.einsum("ij,ij->i", *[np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])] * 2)) / 2
    salt = mix(np.asarray(rng.integers(1 << 62, size=5), dtype=np.uint64))
    face = np.arange(len(faces), dtype=np.uint64)
    count = np.floor(area * (points.OVERSAMPLE * n / area.sum()) + unit(mix(face ^ salt[0]))).astype(np.int64)
    number = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    ids = (np.repeat(face, count) << np.uint64(24)) | number.astype(np.uint64)
    slot = (mix(ids ^ salt[1]) % np.uint64(n)).astype(np.int64)
    rank = mix(ids ^ salt[2]) >> np.uint64(1)
    best = np.full(n, np.iinfo(np.uint64).max)
    np.minimum.at(best, slot, rank)
    won = np.zeros(n, dtype=np.uint64)
    won[slot[rank == best[slot]]] = ids[rank == best[slot]]
    kept = np.flatnonzero(best != np.iinfo(np.uint64).max)
    ids = won[kept[np.searchsorted(kept, np.arange(n)) % len(kept)]]
    u, v = unit(mix(ids ^ salt[3])), unit(mix(ids ^ salt[4]))
    u, v = np.where(u + v > 1, 1 - u, u), np.where(u + v > 1, 1 - v, v)
    tri = vertices[faces[(ids >> np.uint64(24)).astype(np.int64)]]
    return tri[:, 0] + u[:, None] * (tri[:, 1] - tri[:, 0]) + v[:, None] * (tri[:, 2] - tri[:, 0])


def test_compiled_sampling_is_its_definition_to_the_bit():
    big = trimesh.creation.box((1, 1, 1))
    small = trimesh.creation.box((0.1, 0.1, 0.1)).apply_translation((3, 0, 0))
    for mesh in (trimesh.util.concatenate([big, small]), trimesh.creation.icosphere(3),
                 trimesh.creation.cylinder(0.3, 2.0, sections=37), two_triangles()):
        for n, seed in ((2048, 0), (20000, 5), (7, 1)):
            expected = reference_samples(mesh.vertices, mesh.faces, n, np.random.default_rng(seed))
            found = surface_samples(mesh.vertices, mesh.faces, n, np.random.default_rng(seed))
            assert np.array_equal(found, expected)
    assert np.array_equal(points.face_areas(big.vertices, big.faces), big.area_faces)
    with pytest.raises(ValueError, match="outside"):
        points.face_areas(big.vertices, big.faces + 100)


def test_a_mesh_moved_by_rounding_gives_the_same_points_moved_alike():
    """The point of the stratified, hashed sampler: inverse-CDF sampling sends about 1% of
    the points of a 20,480-face sphere to other faces when its vertices move by 1e-7."""
    mesh = trimesh.creation.icosphere(5)
    moved = mesh.vertices + np.random.default_rng(1).normal(0, 1e-7, mesh.vertices.shape)
    a = surface_samples(mesh.vertices, mesh.faces, 4096, np.random.default_rng(0))
    b = surface_samples(moved, mesh.faces, 4096, np.random.default_rng(0))
    assert np.abs(a - b).max() < 1e-6
    turn = trimesh.transformations.rotation_matrix(2.4, [0, 0, 1])[:3, :3]
    c = surface_samples(mesh.vertices @ turn.T, mesh.faces, 4096, np.random.default_rng(0))
    assert np.abs(c @ turn - a).max() < 1e-9


def test_fps_picks_far_apart_points():
    """Corners of a cube plus a dense cluster at its centre: from a corner, FPS takes the
    opposite corner, then the other corners, before any cluster point."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    cluster = 0.5 + 0.01 * np.random.default_rng(0).normal(size=(200, 3))
    pts = np.concatenate([corners, cluster])
    idx = farthest_point_sampling(pts, 8, start=0)
    assert idx[0] == 0 and idx[1] == 7  # (0,0,0) -> (1,1,1)
    assert set(idx) == set(range(8))
    idx9 = farthest_point_sampling(pts, 9, start=0)
    assert idx9[8] >= 8  # then a cluster point


def test_fps_matches_the_definition_and_is_deterministic():
    pts = np.random.default_rng(1).random((500, 3)).astype(np.float32)
    idx = farthest_point_sampling(pts, 50, start=3)
    assert np.array_equal(idx, farthest_point_sampling(pts, 50, start=3))
    assert len(set(idx)) == 50 and idx[0] == 3
    # brute force: each pick maximises the distance to the already chosen set
    for i in range(1, 50):
        d = np.linalg.norm(pts[:, None] - pts[idx[:i]][None], axis=2).min(1)
        assert d[idx[i]] == pytest.approx(d.max(), rel=1e-5)


def test_fps_rejects_bad_k():
    with pytest.raises(ValueError, match="k=5"):
        farthest_point_sampling(np.zeros((4, 3)), 5)


def test_make_clouds_shapes_and_surface():
    mesh = trimesh.creation.icosphere(3)
    clouds = make_clouds(mesh, surface=3000, fps=150, random=120, rng=np.random.default_rng(0))
    assert clouds["fps"].shape == (150, 3) and clouds["random"].shape == (120, 3)
    assert all(c.dtype == np.float32 for c in clouds.values())
    radius = np.linalg.norm(clouds["fps"], axis=1)
    assert radius.min() > 0.98 and radius.max() < 1.0 + 1e-5


def test_npz_round_trip_is_byte_stable(tmp_path):
    rng = np.random.default_rng(0)
    clouds = {
        "fps": rng.random((10, 3), dtype=np.float32),
        "random": rng.random((4, 3), dtype=np.float32),
    }
    save_clouds(tmp_path / "a.npz", clouds)
    save_clouds(tmp_path / "b.npz", clouds)
    back = load_clouds(tmp_path / "a.npz")
    assert set(back) == {"fps", "random"}
    assert all(np.array_equal(back[k], clouds[k]) for k in clouds)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_load_clouds_names_the_file(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_text("not a zip")
    with pytest.raises(ValueError, match="bad.npz"):
        load_clouds(bad)


def test_noise_and_sparse():
    rng = np.random.default_rng(0)
    pts = np.zeros((20000, 3), np.float32)
    noisy = add_noise(pts, 0.02, rng)
    assert noisy.dtype == np.float32 and noisy.std() == pytest.approx(0.02, rel=0.05)
    sparse = sparse_cloud(trimesh.creation.icosphere(2), 512, rng)
    assert sparse.shape == (512, 3)


@pytest.mark.parametrize("fraction", [0.1, 0.01])
def test_simplify_reduces_faces(fraction):
    mesh = trimesh.creation.icosphere(5)  # 20480 faces
    out = simplify(mesh, fraction)
    target = fraction * len(mesh.faces)
    assert 0.8 * target <= len(out.faces) <= 1.05 * target
    assert np.abs(np.linalg.norm(out.vertices, axis=1) - 1).max() < 0.1


def _split(tmp_path, n=3):
    split = tmp_path / "train"
    ids = [f"train-{i:06d}" for i in range(n)]
    for i, shape_id in enumerate(ids):
        meshio.write_obj(
            split / "shapes" / f"{shape_id}.obj", trimesh.creation.icosphere(1 + i % 2)
        )
    meshio.write_text(split / "done" / "export-0.txt", "".join(f"{i}\n" for i in ids))
    return split, ids


def test_points_shard_writes_clouds_then_done(tmp_path, caplog):
    split, ids = _split(tmp_path)
    cfg = {"surface": 2000, "fps": 100, "random": 100, "train_random": 80}
    with caplog.at_level(logging.INFO, logger="geocode.points"):
        done = points_shard(split, 0, cfg, seed=1)
    assert done.read_text().split() == ids
    first = {i: (split / "points" / f"{i}.npz").read_bytes() for i in ids}
    assert load_clouds(split / "points" / f"{ids[0]}.npz")["fps"].shape == (100, 3)
    assert len(caplog.records) <= 2  # a final progress line, not one per shape
    # rerun from scratch: byte-identical; a complete file is skipped (mtime unchanged)
    (split / "points" / f"{ids[1]}.npz").unlink()
    mtime = (split / "points" / f"{ids[0]}.npz").stat().st_mtime_ns
    points_shard(split, 0, cfg, seed=1)
    assert {i: (split / "points" / f"{i}.npz").read_bytes() for i in ids} == first
    assert (split / "points" / f"{ids[0]}.npz").stat().st_mtime_ns == mtime


def test_points_shard_seed_changes_clouds(tmp_path):
    split, ids = _split(tmp_path, n=1)
    cfg = {"surface": 500, "fps": 20, "random": 20}
    points_shard(split, 0, cfg, seed=1)
    a = (split / "points" / f"{ids[0]}.npz").read_bytes()
    (split / "points" / f"{ids[0]}.npz").unlink()
    points_shard(split, 0, cfg, seed=2)
    assert (split / "points" / f"{ids[0]}.npz").read_bytes() != a


def test_points_shard_missing_export(tmp_path):
    with pytest.raises(UserError, match="export-3.txt"):
        points_shard(tmp_path, 3, {"surface": 10, "fps": 5, "random": 5}, seed=0)


def _fps_by_definition(pts: np.ndarray, k: int, start: int) -> np.ndarray:
    """The straightforward O(k n) loop, as the reference for the pruned one."""
    dist = np.full(len(pts), np.inf, dtype=np.float32)
    out = [start]
    for _ in range(k - 1):
        diff = pts - pts[out[-1]]
        dist = np.minimum(dist, np.einsum("ij,ij->i", diff, diff))
        out.append(int(dist.argmax()))
    return np.array(out)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pruned_fps_picks_exactly_what_the_definition_picks(seed):
    rng = np.random.default_rng(seed)
    mesh = trimesh.creation.annulus(0.3, 1.0, 0.5) if seed == 2 else trimesh.creation.icosphere(3)
    pts = sample_surface(mesh, 6000, rng)                       # clustered on a surface
    for k, start in ((300, 0), (1000, 17)):
        assert np.array_equal(farthest_point_sampling(pts, k, start), _fps_by_definition(pts, k, start))
