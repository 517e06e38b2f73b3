"""`geocode bench dataset`: the projection of a domain's dataset from measured rates, and disk
figures read from the files the shard jobs wrote (no timings asserted)."""

import numpy as np
import pytest

from geocode.bench import dataset as bench
from geocode.blender.export import load_program
from geocode.config import compose
from geocode.steps.dataset import sample_dataset, spread_subset

SHAPES = {"train": 100, "val": 10, "test": 10}
VIEWS = {"train": 200, "val": 20, "test": 30}
RATES = {"export_shapes_per_s": 10.0, "sketch_views_per_s": 5.0, "clouds_per_s": 20.0}


def test_projected_hours_add_every_stage_and_share_them_among_the_jobs():
    # 120 shapes / 10 + 250 views / 5 + 120 clouds / 20 + 4 s of sampling = 72 job-seconds
    one = bench.projected_hours(SHAPES, VIEWS, RATES, sample_s=4.0, jobs=1, shards=4)
    assert one["job"] == pytest.approx(72 / 3600) and one["wall"] == pytest.approx(72 / 3600)
    assert bench.projected_hours(SHAPES, VIEWS, RATES, 4.0, jobs=4, shards=4)["wall"] == pytest.approx(18 / 3600)
    # never below one training shard's chain: 4 s sampling + 25 shapes exported + their 50 views drawn
    many = bench.projected_hours(SHAPES, VIEWS, RATES, 4.0, jobs=100, shards=4)
    assert many["job"] == pytest.approx(72 / 3600) and many["wall"] == pytest.approx((4 + 2.5 + 10) / 3600)


def test_disk_counts_sketches_per_view_and_the_rest_per_shape():
    mb = {"meshes": 200.0, "sketches": 10.0, "clouds": 40.0}     # per 1000 shapes; sketches at 2 views a shape
    # 120 shapes * 0.24 MB + 250 views * 0.005 MB = 30.05 MB
    assert bench.disk_gb(SHAPES, VIEWS, mb, views_per_shape=2) == pytest.approx(30.05 / 1000)


def test_a_slice_goes_through_the_shard_jobs_and_its_disk_is_what_they_wrote(tmp_path):
    cfg = compose(["domain=vase", "profile=smoke"])
    program = load_program("vase")
    recipe = program.recipe()
    train = sample_dataset(recipe, {"train": 1}, seed=0, domain="vase")["train"]
    split = tmp_path / "train"
    out = bench.measure_slice(cfg, program, recipe, spread_subset(train, 2), split)

    assert out["shapes"] == 2 and out["views_per_shape"] == 2        # the smoke profile's two training cameras
    assert len(list((split / "shapes").glob("*.obj"))) == 2
    assert len(list((split / "sketches").glob("*.png"))) == 4
    assert len(list((split / "points").glob("*.npz"))) == 2
    for stage, folder in bench.STAGE_FOLDERS.items():
        written = sum(f.stat().st_size for f in (split / folder).iterdir())
        assert out["mb_per_1000_shapes"][stage] == pytest.approx(written / 2 / 1000), stage
    floats = sum(cfg.data.points[k] for k in ("fps", "random")) * 3 * 4    # two float32 clouds a shape
    assert floats < out["mb_per_1000_shapes"]["clouds"] * 1000 < 1.1 * floats
    assert all(np.isfinite(r) and r > 0 for r in out["rates"].values())


def test_bench_dataset_sizes_the_domain_as_the_sample_step_does(monkeypatch):
    slow = dict.fromkeys(RATES, 0.01)
    measured = {"shapes": 24, "rates": slow, "views_per_shape": 2,
                "mb_per_1000_shapes": {"meshes": 200.0, "sketches": 10.0, "clouds": 40.0}}
    monkeypatch.setattr(bench, "measure_slice", lambda *args: measured)
    out = bench.bench_dataset(compose(["domain=vase", "profile=smoke"]), n=24, jobs=2)
    # smoke: 12 / 4 / 4 shapes in one shard; the test split drawn from all three cameras
    assert out["domain_split_shapes"] == {"train": 12, "val": 4, "test": 4}
    assert out["domain_shapes"] == 20 and out["domain_views"] == 12 * 2 + 4 * 2 + 4 * 3
    assert out["epoch_size"] == "--clouds 12 --sketches 24"
    assert out["clouds_mb_per_1000_shapes"] == 40.0
    assert out["domain_disk_gb"] == round((20 * 0.24 + 44 * 0.005) / 1000, 2)
    # (20 + 44 + 20) / 0.01 job-seconds (sampling takes milliseconds), half of it a job at -j 2
    assert out["job_hours"] == round(8400 / 3600, 2) and out["wall_hours"] == round(4200 / 3600, 2)
