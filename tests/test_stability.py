"""Loose parts and the drop test on small hand-built shapes (trimesh primitives)."""

import numpy as np
import pytest
import trimesh

from geocode.stability import DropConfig, drop_test, is_stable, loose_parts


def _box(size, centre):
    box = trimesh.creation.box(size)
    box.apply_translation(centre)
    return box


def stool() -> trimesh.Trimesh:
    """Seat 1 x 1 x 0.1 on four 0.08-wide legs, 1 tall, resting on z = 0."""
    legs = [_box((0.08, 0.08, 1.0), (x, y, 0.5)) for x in (-0.4, 0.4) for y in (-0.4, 0.4)]
    return trimesh.util.concatenate([_box((1, 1, 0.1), (0, 0, 1.05)), *legs])


def top_heavy(offset: float) -> trimesh.Trimesh:
    """A 0.1-wide post, 1 tall, under a 0.6 x 0.6 x 0.4 block shifted by `offset` in x."""
    return trimesh.util.concatenate(
        [_box((0.1, 0.1, 1.0), (0, 0, 0.5)), _box((0.6, 0.6, 0.4), (offset, 0, 1.2))]
    )


def cube_on_edge(perturbation_deg: float) -> trimesh.Trimesh:
    cube = trimesh.creation.box((1, 1, 1))
    angle = np.radians(45 + perturbation_deg)
    cube.apply_transform(trimesh.transformations.rotation_matrix(angle, (1, 0, 0)))
    return cube


def test_stool_stands():
    result = drop_test(stool())
    assert result["loose_parts"] == 0
    assert result["stable"]
    assert result["height_change"] < 0.005
    assert result["tilt_deg"] < 1
    assert result["settled"]


def test_top_heavy_off_balance_tips():
    result = drop_test(top_heavy(offset=0.12))  # centre of mass beyond the post's edge
    assert result["loose_parts"] == 0
    assert not result["stable"]
    assert result["tilt_deg"] > 45


def test_top_heavy_balanced_stands():
    assert is_stable(top_heavy(offset=0.0))


def test_floating_part_is_loose():
    shape = trimesh.util.concatenate([stool(), _box((0.2, 0.2, 0.2), (0, 0, 2.0))])
    assert loose_parts(shape) == 1
    result = drop_test(shape)
    assert result["loose_parts"] == 1 and not result["stable"]
    assert not is_stable(shape)


def test_cube_on_edge_falls_onto_a_face():
    result = drop_test(cube_on_edge(perturbation_deg=2.0))
    assert not result["stable"]
    assert result["height_change"] > 0.02
    assert result["height_after"] == pytest.approx(1.0, abs=0.01)  # resting on a face
    assert result["settled"]


def test_cube_on_face_lands_flat():
    result = drop_test(trimesh.creation.box((1, 1, 1)))
    assert result["stable"] and result["tilt_deg"] < 0.5


def test_open_mesh_uses_convex_hull_mass():
    cube = trimesh.creation.box((1, 1, 1))
    open_cube = trimesh.Trimesh(cube.vertices, cube.faces[:-2], process=False)
    result = drop_test(open_cube)
    assert result["mass_source"] == "convex_hull" and result["stable"]


def test_free_fall_integrates_correctly():
    """Far above the plane: z(t) = z0 - g t^2 / 2 (semi-implicit Euler adds g dt t / 2), and
    with no contact there is no torque, so the orientation stays the identity."""
    from geocode.stability import GRAVITY, _rigid_body, _rotation, _simulate

    body, _ = _rigid_body(trimesh.creation.box((1, 2, 3)), DropConfig())
    cfg = DropConfig(duration=0.5, rest_time=10.0)
    out = _simulate(body, 3.0, 100.0, cfg)
    t = 0.5
    assert out["x"][2] == pytest.approx(100 - GRAVITY * t**2 / 2, abs=GRAVITY * cfg.dt * t)
    assert np.allclose(_rotation(out["q"]), np.eye(3))


def test_a_step_too_long_for_a_light_top_heavy_body_is_halved():
    """A small table with a thick top on thin X-frame legs (its mass near the centre, its feet
    far below): the contact springs turn it faster than the 2 ms step can follow, and at that
    step it gains energy and flips over. The drop reruns it at a shorter step, where it stands."""
    from geocode.stability import _Body, _simulate, _simulate_stably

    feet = np.array([[sx * 0.12, y, -0.408 if y in (-0.14, 0.155) else -0.414]
                     for sx in (-1, 1) for y in (-0.14, -0.125, 0.14, 0.155)])
    top = np.array([[sx * 0.2, sy * 0.145, 0.05] for sx in (-1, 1) for sy in (-1, 1)])
    points = np.concatenate([feet, top])
    body = _Body(0.0064, np.diag([7.2e-5, 1.13e-4, 1.15e-4]), points, "solid")
    height = float(np.ptp(points[:, 2]))
    start = 0.414 + 0.05 * height
    assert _simulate(body, height, start, DropConfig())["unstable"]
    out, cfg = _simulate_stably(body, height, start, DropConfig())
    assert not out["unstable"] and cfg.dt < DropConfig().dt
    assert out["x"][2] == pytest.approx(0.414, abs=0.005)            # on its feet
    assert np.allclose(out["q"], [1, 0, 0, 0], atol=0.02)             # not turned


def test_a_body_the_step_can_follow_keeps_it():
    assert drop_test(trimesh.creation.box((1, 1, 1)))["dt"] == DropConfig().dt


# ---- loose parts -----------------------------------------------------------------------------


def _cylinder(axis, radius=0.1, length=2.0, centre=(0, 0, 0)):
    cyl = trimesh.creation.cylinder(radius, length, sections=24)
    cyl.apply_transform(trimesh.geometry.align_vectors((0, 0, 1), axis))
    cyl.apply_translation(centre)
    return cyl


def test_crossing_tubes_touch():
    """The walls cross with no vertex near the other surface: edge-piercing catches it."""
    shape = trimesh.util.concatenate([_cylinder((0, 0, 1)), _cylinder((0, 1, 0))])
    assert loose_parts(shape) == 0


def test_part_inside_another_touches():
    outer = trimesh.creation.box((1, 1, 1))
    inner = _box((0.2, 0.2, 0.2), (0.1, 0, 0))
    assert loose_parts(trimesh.util.concatenate([outer, inner])) == 0


def test_gap_larger_than_tolerance_is_loose():
    a = _box((1, 1, 1), (0, 0, 0))
    near = _box((1, 1, 1), (1.0005, 0, 0))  # gap 5e-4 < 1e-3 * diagonal
    far = _box((1, 1, 1), (1.05, 0, 0))
    assert loose_parts(trimesh.util.concatenate([a, near])) == 0
    assert loose_parts(trimesh.util.concatenate([a, far])) == 1


def test_counts_components_outside_largest_group():
    chain = [_box((1, 1, 1), (x, 0, 0)) for x in (0, 0.9, 1.8)]  # one touching group of 3
    pair = [_box((1, 1, 1), (x, 5, 0)) for x in (0, 0.9)]  # a separate group of 2
    single = [_box((1, 1, 1), (0, 10, 0))]
    assert loose_parts(trimesh.util.concatenate(chain + pair + single)) == 3


def test_duplicate_vertices_are_welded():
    """A cube whose faces do not share vertices (as some exporters write) is one part."""
    cube = trimesh.creation.box((1, 1, 1))
    tri = cube.vertices[cube.faces].reshape(-1, 3)
    soup = trimesh.Trimesh(tri, np.arange(len(tri)).reshape(-1, 3), process=False)
    assert loose_parts(soup) == 0


def test_single_component():
    assert loose_parts(trimesh.creation.icosphere(2)) == 0


def test_stacked_crossing_planks_touch_only_along_edges():
    """A '+' of two planks, one 0.001 above the other (within tol = 1e-3 * diagonal 2.8):
    no vertex of either lies over the other's faces and no edge pierces, so only the
    edge-edge test sees the contact."""
    low = _box((2.0, 0.2, 0.1), (0, 0, 0.05))
    high = _box((0.2, 2.0, 0.1), (0, 0, 0.151))
    assert loose_parts(trimesh.util.concatenate([low, high])) == 0
    lifted = _box((0.2, 2.0, 0.1), (0, 0, 0.2))
    assert loose_parts(trimesh.util.concatenate([low, lifted])) == 1


def test_fine_tubes_plugged_into_a_body():
    """Nine thin tubes (ring spacing below tol) pierce a sphere; one moved off floats.
    Guards against welding at tol, which would collapse each tube's rings."""
    assert loose_parts(tubes_in_a_sphere()) == 0
    assert loose_parts(tubes_in_a_sphere(detached=1)) == 1


def tubes_in_a_sphere(seed: int = 0, detached: int = 0) -> trimesh.Trimesh:
    """About 10K faces in 10 closed components: a sphere (5120 faces) pierced by nine tubes
    (512 faces each) in random directions; the first `detached` tubes float free."""
    rng = np.random.default_rng(seed)
    parts = [trimesh.creation.icosphere(subdivisions=4, radius=0.5)]
    for i in range(9):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        tube = trimesh.creation.cylinder(0.05, 0.6, sections=128)
        pose = trimesh.geometry.align_vectors((0, 0, 1), axis)
        pose[:3, 3] = axis * (1.5 if i < detached else 0.7)
        tube.apply_transform(pose)
        parts.append(tube)
    return trimesh.util.concatenate(parts)
