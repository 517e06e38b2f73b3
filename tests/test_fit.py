"""The fit (`geocode.reconstruct.fit`): its distance, its pose search and its restarts; and the nearest
training shape (`geocode.reconstruct.retrieval`), on shapes made here."""

import math

import numpy as np
import pytest
import trimesh

from geocode.config import compose, settings
from geocode.points import sample_surface
from geocode.reconstruct.fit import CloudDistance, Placement, Start, align, trimmed_mean

CLOUD_FIT = settings(compose([])).fit.cloud   # the config's defaults (conf/fit/default.yaml)


def box_points(n: int, seed: int, bottom: bool = True) -> np.ndarray:
    box = trimesh.creation.box((1.0, 0.6, 0.8))
    points = sample_surface(box, n, np.random.default_rng(seed)).astype(np.float64)
    return points if bottom else points[points[:, 2] > -0.399]


def test_plain_distance_is_the_metric_chamfer():
    from geocode.metrics import chamfer

    a, b = box_points(500, 0), box_points(700, 1) * 1.1
    assert CloudDistance(b, trim=0.0)(a) == pytest.approx(chamfer(a, b))


def test_the_distance_built_once_per_target_is_the_distance_from_scratch():
    """The target's cells are built once: the distance of any shape is, to the bit, the
    trimmed (and the plain) Chamfer distance computed afresh with scipy's trees."""
    from scipy.spatial import cKDTree

    target = box_points(5000, 5) * [1.0, 1.1, 0.9]
    for trim in (0.02, 0.0):
        distance = CloudDistance(target, trim)
        for seed in (6, 7):
            shape = Placement(turn=0.1, scale=0.95).apply(box_points(2048, seed))
            to_target = cKDTree(target).query(shape)[0] ** 2
            to_shape = cKDTree(shape, balanced_tree=False, compact_nodes=False).query(target)[0] ** 2
            expected = ((trimmed_mean(to_target, trim) + trimmed_mean(to_shape, trim)) / 2 if trim
                        else float((np.mean(to_target) + np.mean(to_shape)) / 2))
            assert distance(shape) == expected


def test_align_finds_the_pose_of_a_turned_scaled_moved_copy():
    def shape(n: int, seed: int) -> np.ndarray:   # a box and a post at one corner: no symmetry
        mesh = trimesh.util.concatenate([trimesh.creation.box((1.0, 0.6, 0.2)),
                                         trimesh.creation.box((0.2, 0.2, 0.8)).apply_translation((0.4, 0.2, 0.5))])
        return sample_surface(mesh, n, np.random.default_rng(seed)).astype(np.float64)

    truth = Placement(turn=0.25, scale=0.9, offset=(0.05, -0.03, 0.02))
    distance = CloudDistance(truth.apply(shape(4000, 8)), CLOUD_FIT.trim)
    found = align(shape(2048, 9), distance, Placement(), steps=30)   # (a fit's evaluation takes 3)
    assert found.turn == pytest.approx(truth.turn, abs=0.05)
    assert found.scale == pytest.approx(truth.scale, abs=0.02)
    assert found.offset == pytest.approx(truth.offset, abs=0.01)


def test_trimmed_mean_drops_the_largest_share():
    assert trimmed_mean(np.array([1.0, 2.0, 3.0, 100.0]), 0.25) == pytest.approx(2.0)
    assert trimmed_mean(np.array([5.0]), 0.5) == 5.0


def test_trimmed_distance_tolerates_a_missing_underside_and_outliers():
    """A scan without its bottom face and with 3% far outliers: the whole box is near it
    by the trimmed distance, and a box 20% too tall is not."""
    rng = np.random.default_rng(2)
    scan = box_points(3000, 3, bottom=False)
    scan = np.concatenate([scan, rng.uniform(-1.5, 1.5, (90, 3))])
    shape, taller = box_points(2000, 4), box_points(2000, 4) * [1.0, 1.0, 1.2]
    plain, trimmed = CloudDistance(scan, trim=0.0), CloudDistance(scan, trim=0.1)
    assert trimmed(shape) < 0.2 * plain(shape)
    assert trimmed(shape) < 0.5 * trimmed(taller)


def test_placement_turns_scales_then_offsets():
    pose = Placement(turn=math.pi / 2, scale=2.0, offset=(0.0, 0.0, 1.0))
    assert pose.apply(np.array([[1.0, 0.0, 0.0]])) == pytest.approx(np.array([[0.0, 2.0, 1.0]]))
    assert pose.to_dict() == {"turn_deg": 90.0, "scale": 2.0, "offset": [0.0, 0.0, 1.0]}


@pytest.mark.blender
class TestFitOnAProgram:
    SHAPE = {"body_height": 1.2, "handle_count": 1, "belly_width": 0.6}

    @pytest.fixture(scope="class")
    def vase(self):
        from geocode.program import Program

        program = Program.load("vase")
        return program, program.recipe()

    def target(self, vase, pose: Placement) -> np.ndarray:
        from geocode.reconstruct.fit import shape_points

        program, _ = vase
        return pose.apply(shape_points(program, self.SHAPE, 3000))

    def test_the_pose_of_a_turned_scaled_moved_shape_is_found(self, vase):
        from geocode.reconstruct.fit import fit, shape_points

        program, recipe = vase
        truth = Placement(turn=0.3, scale=0.9, offset=(0.05, 0.0, -0.04))
        result = fit(program, recipe, [Start(dict(self.SHAPE))], self.target(vase, truth),
                     budget=60, tuning=CLOUD_FIT, seed=0)
        unposed = CloudDistance(self.target(vase, truth), CLOUD_FIT.trim)(shape_points(program, self.SHAPE))
        assert result.after < 0.5 * unposed
        assert result.pose.scale == pytest.approx(truth.scale, abs=0.05)
        assert result.curve == sorted(result.curve, reverse=True)   # best so far, per evaluation
        assert len(result.curve) == result.evaluations == 60

    def test_helper_processes_give_the_same_fit(self, vase):
        """Candidates scored in a helper process (its own Blender) beside this one: the same
        distances in the same order, so the same fit."""
        from geocode.reconstruct.fit import Scorer, fit

        program, recipe = vase
        target = self.target(vase, Placement(turn=0.2, scale=0.95))
        alone, shared = (fit(program, recipe, [Start(dict(self.SHAPE))], target, budget=40, tuning=CLOUD_FIT, seed=0,
                             helpers=helpers) for helpers in (0, 1))
        assert shared.curve == alone.curve and shared.values == alone.values and shared.pose == alone.pose
        rng = np.random.default_rng(0)   # a batch, as a CMA-ES generation is shared out
        batch = [(program.random_values(rng), 0.3 * k) for k in range(6)]
        assert Scorer(program, target, 0.02, True, helpers=1)(batch) == Scorer(program, target, 0.02, True)(batch)

    def test_sweeps_correct_one_parameter_exactly(self, vase):
        """A start one sweep step off in one parameter: the first sweep moves it back, where
        CMA-ES alone, moving all of them at once, comes only near in as many evaluations."""
        from geocode.reconstruct.fit import fit

        program, recipe = vase
        height = next(p for p in recipe.parameters if p.name == "body_height")   # swept first
        off = dict(self.SHAPE, body_height=self.SHAPE["body_height"] + 0.15 * (height.max - height.min))
        target = self.target(vase, Placement())

        def fitted(steps: list[float]) -> float:
            tuning = CLOUD_FIT.model_copy(update={"sweep_steps": steps, "polish": 0})
            result = fit(program, recipe, [Start(off)], target, budget=90, tuning=tuning, seed=0, pose=False)
            return abs(result.values["body_height"] - self.SHAPE["body_height"])

        swept, alone = fitted([0.15]), fitted([])
        assert swept < 1e-9 and alone > 0.01

    def test_restarts_begin_at_the_best_scored_start(self, vase):
        from geocode.reconstruct.fit import fit

        program, recipe = vase
        target = self.target(vase, Placement(turn=math.pi / 2))
        starts = [Start(dict(self.SHAPE), turn=a) for a in (0.0, math.pi / 2, math.pi)]
        result = fit(program, recipe, starts, target, budget=12, tuning=CLOUD_FIT, seed=0, restarts=1)
        assert result.start == 1
        assert result.after <= result.before < 1e-3


@pytest.mark.blender
def test_the_nearest_training_shape_is_found_at_its_turn(tmp_path):
    from geocode.meshio import normalise_unit_sphere, write_obj
    from geocode.points import save_clouds
    from geocode.program import Program
    from geocode.reconstruct.fit import turn_about_z
    from geocode.reconstruct.retrieval import TrainingShapes

    program = Program.load("vase")
    split = tmp_path / "train"
    (split / "shapes").mkdir(parents=True)
    (split / "points").mkdir()
    meshes = {}
    for i, height in enumerate((0.6, 1.0, 1.4)):
        mesh = normalise_unit_sphere(program.evaluate({"body_height": height, "handle_count": 1}))
        shape_id = f"train-{i:06d}"
        write_obj(split / "shapes" / f"{shape_id}.obj", mesh)
        cloud = sample_surface(mesh, 1500, np.random.default_rng(i))
        save_clouds(split / "points" / f"{shape_id}.npz", {"fps": cloud, "random": cloud})
        meshes[shape_id] = mesh
    shapes = TrainingShapes.from_split(split)
    query = meshes["train-000001"].copy()
    query.vertices = turn_about_z(query.vertices, math.pi / 2)
    match = shapes.nearest(query)
    assert match.shape_id == "train-000001"
    assert match.turn == pytest.approx(math.pi / 2)
    assert match.chamfer < 1e-3


class Slab:
    """The smallest program `cloud_feedback` corrects: a box `width` (0.4..1.6) x 0.7 x 0.3."""

    def __init__(self):
        from geocode.recipe import Parameter

        self.parameters = [Parameter("width", "float", 0.4, 1.6, 1.0)]

    def check(self, values):
        return {"width": float(values.get("width", 1.0))}

    def satisfies(self, values):
        return True

    def evaluate(self, values):
        return trimesh.creation.box((self.check(values)["width"], 0.7, 0.3))


def test_cloud_feedback_cancels_a_reading_biased_alike_on_every_cloud():
    """A stand-in for the network that reads every slab 0.3 too wide (its clouds' spread in x
    over that in y, calibrated on two slabs): from its first reading of a 1.0-wide slab's
    cloud (about 1.3), the feedback's rounds end within 0.03 of 1.0, each round a start at
    the answer's turn; the input is seen turned back by the start's turn."""
    from types import SimpleNamespace

    from geocode.reconstruct.fit import cloud_feedback, shape_points, turn_about_z

    slab, points_cfg = Slab(), SimpleNamespace(fps=256, train_random=128)

    def spread(cloud):
        return cloud[:, 0].std() / cloud[:, 1].std()

    low, high = (spread(shape_points(slab, {"width": w})) for w in (0.6, 1.4))
    def read(clouds):
        return [{"width": 0.6 + 0.8 * (spread(c) - low) / (high - low) + 0.3} for c in clouds]

    cloud = turn_about_z(shape_points(slab, {"width": 1.0}), 0.5)   # the input, turned
    starts = cloud_feedback(read, slab, slab, cloud, Start({"width": 0.7}, {}, turn=0.5), points_cfg, seed=0,
                            rounds=4)
    assert len(starts) == 4 and all(s.turn == 0.5 for s in starts)
    assert starts[0].values["width"] == pytest.approx(1.3, abs=0.06)
    assert starts[-1].values["width"] == pytest.approx(1.0, abs=0.03)


def test_readings_apart_by_rounding_give_the_same_feedback_rounds():
    """Two readings of one input 1e-7 apart (the input turned, its canonical cloud rounded
    differently) give bit-identical rounds: each round's values are snapped to SNAP of the
    range, where the feedback would otherwise carry (and with a network, grow) the gap."""
    from geocode.reconstruct.fit import SNAP, network_feedback, shape_points, snapped

    slab = Slab()
    width = snapped(slab, {"width": 1.0123456})["width"]    # range 0.4..1.6: a grid of 0.0012
    assert width == pytest.approx(0.4 + 510 * SNAP * 1.2) and abs(width - 1.0123456) <= SNAP * 1.2 / 2

    def render(values):
        return shape_points(slab, values, 512)

    def read(clouds):
        return [{"width": 0.4 + 0.9 * float(c[:, 0].max() - c[:, 0].min())} for c in clouds]

    def rounds(gap):
        return [v for v, _ in network_feedback(read, render, slab, {"width": 1.1 + 0.123456 + gap},
                                               {"width": 0.7}, 3)]

    assert rounds(0.0) == rounds(1e-7)


def test_sweeps_spend_no_evaluation_on_what_the_shape_hides():
    """A stand-in recipe: `width` always shown, `arm_width` and `arm_count` only with arms.
    Without arms the sweeps move neither; with arms they try both."""
    from types import SimpleNamespace

    from geocode.reconstruct.fit import SearchSpace, sweep_continuous, sweep_discrete

    def param(name, kind, lo=0.0, hi=1.0):
        return SimpleNamespace(name=name, kind=kind, min=lo, max=hi)

    recipe = SimpleNamespace(
        parameters=[param("width", "float"), param("arm_width", "float"), param("arms", "bool"),
                    param("arm_count", "int")],
        shown=lambda v: {"width": True, "arm_width": v["arms"] == 1, "arms": True, "arm_count": v["arms"] == 1})
    for arms, expected in ((0.0, {"width"}), (1.0, {"width", "arm_width", "arm_count"})):
        start = Start({"width": 0.5, "arm_width": 0.5, "arms": arms, "arm_count": 2.0},
                      {"arms": [arms], "arm_count": [2.0, 3.0, 4.0]})
        space, moved = SearchSpace(recipe, start), set()
        x0 = space.x0()

        def objective(xs, space=space, x0=x0, moved=moved):
            before = space.values(x0)
            for x in xs:
                moved.update(k for k, v in space.values(x).items() if before[k] != v)
            return [1.0] * len(xs)
        sweep_discrete(objective, space, x0, 1.0, 100)
        sweep_continuous(objective, space, x0, 1.0, 100)
        assert moved == expected
