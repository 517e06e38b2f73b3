"""geocode.reconstruct.pose: axis rotations, turns, normalisation, the 4x4 transform and its inverse, and
the up axis found on program shapes turned every way (accuracy per domain: see the numbers
that `python -m geocode.bench.up measure` prints; the thresholds here sit below them)."""

import math

import numpy as np
import pytest

from geocode.errors import UserError
from geocode.reconstruct import pose


def test_axis_rotation_brings_each_axis_up_and_y_is_the_old_convention():
    for label in pose.AXES:
        r = pose.axis_rotation(label)
        axis = np.zeros(3)
        axis["xyz".index(label[1])] = 1.0 if label[0] == "+" else -1.0
        assert np.allclose(r @ axis, [0, 0, 1]) and np.isclose(np.linalg.det(r), 1)
    p = np.array([[1.0, 2.0, 3.0]])
    assert np.allclose(p @ pose.axis_rotation("y").T, [[1, -3, 2]])   # reconstruct.z_up
    with pytest.raises(UserError, match="--up w"):
        pose.axis_rotation("w")


def test_the_24_axis_rotations_are_distinct_rotations():
    rots = pose.axis_rotations()
    assert len(rots) == 24 and len({r.tobytes() for r in rots}) == 24
    assert all(np.allclose(r @ r.T, np.eye(3)) and np.isclose(np.linalg.det(r), 1) for r in rots)


def test_turns_are_about_z_and_evenly_spaced():
    four = pose.turns(4)
    assert np.allclose(four[0], np.eye(3))
    assert np.allclose(four[1] @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(np.linalg.matrix_power(pose.turns(12)[1], 12), np.eye(3))
    assert all(np.allclose(t @ [0, 0, 1], [0, 0, 1]) for t in pose.turns(8))


def test_normalise_plain_is_the_datasets_and_robust_ignores_outliers():
    rng = np.random.default_rng(0)
    box = rng.uniform(-1, 1, (5000, 3)) * [2, 1, 0.5] + [10, 20, 30]
    unit, centre, scale = pose.normalise(box)
    assert np.isclose(np.linalg.norm(unit, axis=1).max(), 1)
    assert np.allclose((unit.min(0) + unit.max(0)) / 2, 0)
    stray = np.concatenate([box, [[100.0, 20, 30]] * 10])
    _, c_plain, s_plain = pose.normalise(stray)
    _, c_robust, s_robust = pose.normalise(stray, robust=True)
    assert np.linalg.norm(c_robust - [10, 20, 30]) < 0.05 and s_robust < 1.1 * scale
    assert s_plain > 10 * scale and c_plain[0] > 50
    with pytest.raises(UserError, match="coincide"):
        pose.normalise(np.ones((200, 3)))


def test_pose_matrix_and_its_inverse_put_a_result_back_over_the_scan():
    rng = np.random.default_rng(1)
    scan = rng.normal(size=(1000, 3)) * [1, 3, 2] * 250 + [1000, -40, 7]   # millimetres, Y up
    p = pose.find_pose(scan, up="y")
    canonical = p.to_canonical(scan)
    assert np.isclose(np.linalg.norm(canonical - (canonical.min(0) + canonical.max(0)) / 2, axis=1).max(), 1)
    assert np.ptp(canonical[:, 2]) == pytest.approx(np.ptp(scan[:, 1]) / p.scale)   # input y is up
    assert np.allclose(p.inverse @ p.matrix, np.eye(4))
    assert np.allclose(p.to_input_frame(canonical), scan)
    turned = p.turned(pose.turns(4)[1], 90.0)
    assert turned.turn == 90.0
    assert np.allclose(turned.to_input_frame(turned.to_canonical(scan)), scan)
    assert np.allclose(turned.to_canonical(scan), canonical @ pose.turns(4)[1].T)


def test_up_axis_is_deterministic_and_cheap_on_a_large_cloud():
    rng = np.random.default_rng(2)
    cloud = rng.normal(size=(200_000, 3))
    assert pose.up_axis(cloud)[1] == pose.up_axis(cloud)[1]


def program_clouds(domain, n_shapes, seed):
    from geocode.points import sample_surface
    from geocode.program import Program

    program = Program.load(domain)
    for i in range(n_shapes):
        rng = np.random.default_rng(seed + i)
        yield rng, sample_surface(program.evaluate(program.random_values(rng)), 3000, rng).astype(np.float64)


def scanned(points, rng):
    """Underside cut, a quarter of one side missing, 1% noise, 2% outliers."""
    p = points[points[:, 2] > points[:, 2].min() + 0.08 * np.ptp(points[:, 2])]
    d = rng.normal(size=2)
    s = p[:, :2] @ (d / np.linalg.norm(d))
    p = p[s < np.quantile(s, 0.75)]
    ext = np.ptp(p, 0).max()
    p = p + rng.normal(0, 0.01 * ext, p.shape)
    lo, hi = p.min(0), p.max(0)
    return np.concatenate([p, rng.uniform(lo - 0.1 * ext, hi + 0.1 * ext, (int(0.02 * len(p)), 3))])


# Shapes the weights were never fitted on (they were fitted on seeds 1000..1019); the bars sit
# under what `python -m geocode.bench.up measure` gives on 20 shapes x 6 ups x 4 perturbations
# (chair 0.91, table 1.00, ceiling lamp 0.77, vase 0.59, cabinet 0.68; `measure turned`, each
# shape also turned 10-80 degrees off the axes about its up: 0.91, 0.99, 0.77, 0.60, 0.66).
# The lamp's bar is lower since it makes flush mounts (a flat canopy and a dome: near
# symmetric top to bottom once noisy); these lamps give 0.65 (chair 0.83, table 1.00,
# vase 0.88, cabinet 0.81).
# 8 shapes a domain: with 4, one hard shape (a chair on a column, its back curved and arched,
# 3 misses of 6) alone took the chair's cases under its bar
SHAPES = 8
BARS = {"chair": 0.8, "table": 0.8, "ceiling_lamp": 0.55, "vase": 0.4, "cabinet": 0.4}


@pytest.mark.blender
@pytest.mark.parametrize("domain", sorted(BARS))
def test_up_axis_on_program_shapes_turned_every_way(domain):
    ups = [pose.axis_rotation(a).T for a in pose.AXES]   # +z -> each axis
    hits = []
    for i, (rng, base) in enumerate(program_clouds(domain, SHAPES, seed=7000)):
        for k, to_input in enumerate(ups):
            r = to_input @ pose.turn_z(90.0 * ((i + k) % 4) + (37.0 if k % 3 == 0 else 0.0))  # some off the axes
            points = scanned(base, rng) if k % 2 else base
            points = points @ r.T * rng.uniform(0.01, 100) + rng.normal(0, 10, 3)
            rotation, label = pose.up_axis(points, domain)
            hits.append(label == pose.AXES[k])
            if label == pose.AXES[k]:   # the rotation found brings the shape upright
                assert np.allclose(rotation @ r @ [0, 0, 1], [0, 0, 1])
    assert np.mean(hits) >= BARS[domain], hits


def test_a_mesh_is_normalised_by_its_vertices_as_the_dataset_is():
    import trimesh

    from geocode.meshio import normalise_unit_sphere
    from geocode.reconstruct.inputs import Geometry, surface_points

    mesh = trimesh.creation.box((0.4, 0.6, 1.0)).apply_translation((3, 4, 5))
    samples = surface_points(Geometry(None, None, mesh, "mesh"), 2000, np.random.default_rng(0))
    p = pose.find_pose(samples, up="z", mesh=mesh)
    assert np.allclose(p.to_canonical(mesh.vertices), normalise_unit_sphere(mesh).vertices)


def test_any_turn_of_a_shape_reaches_the_same_frame_up_to_a_quarter_turn():
    """The level turn squares the surface to the axes, so a turned input and the input give
    the same canonical cloud, but for a quarter-turn (which the front search covers)."""
    import trimesh
    from scipy.spatial import cKDTree

    shape = trimesh.util.concatenate([trimesh.creation.box((0.6, 1.2, 0.1)),
                                      trimesh.creation.box((0.1, 0.1, 1.0)).apply_translation((0.25, 0.5, -0.5)),
                                      trimesh.creation.cylinder(0.05, 0.8).apply_translation((-0.2, 0, 0.4))])
    base = trimesh.sample.sample_surface(shape, 6000, seed=1)[0]
    square = pose.find_pose(base, up="z")
    assert abs(square.turn) < 1.0
    reference = square.to_canonical(base)
    for degrees in (90.0, 137.0, 200.0, 333.3):
        turned = base @ pose.turn_z(degrees).T
        found = pose.find_pose(turned, up="z")
        assert abs(math.remainder(found.turn + degrees, 90.0)) < 1.0, degrees
        canonical = found.to_canonical(turned)
        gaps = [cKDTree(reference).query(canonical @ pose.turn_z(90.0 * k).T)[0].max() for k in range(4)]
        assert min(gaps) < 1e-3, degrees


def test_a_mesh_is_levelled_by_its_faces_exactly():
    """A mesh's level turn comes from its faces' normals: a turned mesh reaches the unturned
    one's frame to float precision (normals estimated from samples leave up to 2 degrees)."""
    import trimesh

    from geocode.reconstruct.inputs import Geometry, surface_points

    shape = trimesh.util.concatenate([trimesh.creation.box((0.6, 1.2, 0.1)),
                                      trimesh.creation.box((0.1, 0.1, 1.0)).apply_translation((0.25, 0.5, -0.5)),
                                      trimesh.creation.cylinder(0.05, 0.8).apply_translation((-0.2, 0, 0.4))])
    for degrees in (0.0, 137.0, 200.0, 333.3):
        mesh = shape.copy().apply_transform(trimesh.transformations.rotation_matrix(math.radians(degrees), [0, 0, 1]))
        samples = surface_points(Geometry(None, None, mesh, "mesh"), 3000, np.random.default_rng(0))
        found = pose.find_pose(samples, up="z", mesh=mesh)
        assert abs(math.remainder(found.turn + degrees, 90.0)) < 1e-6, degrees


def test_up_features_do_not_change_when_a_file_turns_its_shape_about_the_up_axis():
    """The file's up may be any of its axes and the shape turned about it by any angle: the
    features of the true up axis are those of the square file (raw ones see the diagonals)."""
    import trimesh

    shape = trimesh.util.concatenate([trimesh.creation.box((0.6, 1.2, 0.1)),
                                      trimesh.creation.box((0.1, 0.1, 1.0)).apply_translation((0.25, 0.5, -0.5)),
                                      trimesh.creation.cylinder(0.05, 0.8).apply_translation((-0.2, 0, 0.4))])
    base = trimesh.sample.sample_surface(shape, 3000, seed=1)[0]
    assert np.allclose(pose.square_rotation(base), np.eye(3))   # a square file stays as it is
    square = pose.up_features(base)[pose.AXES.index("+z")]
    for degrees in (137.0, 200.0):
        for up in ("+x", "-y", "+z"):
            points = base @ (pose.axis_rotation(up).T @ pose.turn_z(degrees)).T
            row = pose.AXES.index(up)
            assert np.abs(pose.up_features(points)[row] - square).max() < 0.01, (degrees, up)
            assert np.abs(pose.axis_features(points)[row] - square).max() > 0.05   # what it fixes


def test_a_wrong_up_candidate_still_lays_a_turned_shape_square_on_a_side():
    """With `squared` (auto's candidates), a file turned 137 degrees about its up (z), posed
    with x up, lies as square as the unturned file posed with x up: same extents."""
    import trimesh

    shape = trimesh.util.concatenate([trimesh.creation.box((0.6, 1.2, 0.1)),
                                      trimesh.creation.box((0.1, 0.1, 1.0)).apply_translation((0.25, 0.5, -0.5))])
    base = trimesh.sample.sample_surface(shape, 4000, seed=2)[0]
    turned = base @ pose.turn_z(137.0).T
    unturned_extent = np.sort(np.ptp(pose.find_pose(base, up="x", squared=True).to_canonical(base), axis=0))
    extent = np.sort(np.ptp(pose.find_pose(turned, up="x", squared=True).to_canonical(turned), axis=0))
    assert np.allclose(extent, unturned_extent, atol=0.02)
    tilted = np.sort(np.ptp(pose.find_pose(turned, up="x").to_canonical(turned), axis=0))
    assert not np.allclose(tilted, unturned_extent, atol=0.05)   # as given, x is a diagonal


def test_a_shape_a_little_off_square_reaches_one_frame_turned_or_not():
    """Every level turn is taken as found: a shape whose square directions lie 0.4 degrees
    off the axes is turned by them unturned as well as turned by 137 degrees (leaving the
    unturned one as it was parted the two frames by those 0.4 degrees)."""
    import trimesh

    shape = trimesh.util.concatenate([
        trimesh.creation.box((0.6, 1.2, 0.1)),
        trimesh.creation.box((0.1, 0.1, 1.0)).apply_transform(
            trimesh.transformations.rotation_matrix(math.radians(0.8), [0, 0, 1]))])
    turns = []
    for degrees in (0.0, 137.0):
        mesh = shape.copy().apply_transform(trimesh.transformations.rotation_matrix(math.radians(degrees), [0, 0, 1]))
        turns.append(pose.find_pose(mesh.vertices, up="z", mesh=mesh).turn + degrees)
    assert 0.05 < abs(turns[0]) < 1.0
    assert abs(math.remainder(turns[1] - turns[0], 90.0)) < 1e-9


def test_the_weights_fit_recovers_the_weights_of_a_softmax():
    """`bench.up.fit_weights` (what `python -m geocode.bench.up fit` fits WEIGHTS with): cases
    whose true axis is drawn from a softmax over the six axes with known weights give those
    weights back."""
    from geocode.bench.up import fit_weights

    rng = np.random.default_rng(0)
    truth = np.array([1.5, -1.0, 0.5, 0.0])
    cues = rng.normal(size=(4000, 6, len(truth)))
    scores = np.exp(cues @ truth)
    axes = np.array([rng.choice(6, p=s / s.sum()) for s in scores])
    assert fit_weights(cues, axes, l2=0.0) == pytest.approx(truth, abs=0.1)
    assert np.abs(fit_weights(cues, axes)).sum() < np.abs(truth).sum()   # the weight decay shrinks them


def test_every_weight_set_weighs_every_cue():
    cues = pose.axis_features(np.random.default_rng(0).normal(size=(500, 3))).shape[1]
    assert len(pose.CUES) == cues
    assert set(pose.WEIGHTS) == {"", "chair", "vase", "table", "ceiling_lamp", "cabinet"}
    assert all(len(w) == cues for w in pose.WEIGHTS.values())
