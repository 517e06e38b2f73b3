"""geocode.steps.train_data on a tiny synthetic dataset written in the design.md layout.

`make_dataset` writes a test double of a built program (manifest + recipe) and of a
generated dataset (recipes.parquet, points/*.npz, sketches/*.png): no Blender involved.
"""

import json
from contextlib import contextmanager

import numpy as np
import pandas as pd
import pytest
import torch
from PIL import Image

from geocode.points import eval_cloud
from geocode.recipe import Recipe, load_manifest
from geocode.steps.train_data import (
    GeoCodeDataModule,
    PointAugment,
    ShapeItems,
    SketchAugment,
    load_sketch,
    load_split,
)

DOMAIN = "toy"
CAMERAS = ["az35", "az55"]
N_FPS, N_RANDOM, N_PICK = 64, 48, 32
MANIFEST = {
    "domain": DOMAIN,
    "parameters": [
        {"name": "height", "kind": "float", "min": 0.5, "max": 1.5, "default": 1.0, "visible_if": None},
        {"name": "has_handle", "kind": "bool", "min": 0, "max": 1, "default": 0, "visible_if": None},
        {"name": "handle_size", "kind": "float", "min": 0.0, "max": 0.3, "default": 0.1,
         "visible_if": "has_handle"},
        {"name": "legs", "kind": "int", "min": 0, "max": 2, "default": 1, "visible_if": None},
    ],
}
RECIPE = """\
parameters:
  height: {samples: 3}
  has_handle:
  handle_size: {samples: 2}
  legs:
"""


def make_dataset(root, sizes=None, seed=0):
    """Write build/programs/toy.manifest.json, programs/toy.yaml and data/toy/<split>/...;
    return (data_root, build_root, recipe_path)."""
    sizes = sizes or {"train": 10, "val": 4}
    rng = np.random.default_rng(seed)
    build = root / "build"
    (build / "programs").mkdir(parents=True)
    manifest = build / "programs" / f"{DOMAIN}.manifest.json"
    manifest.write_text(json.dumps(MANIFEST))
    recipe_path = root / "programs" / f"{DOMAIN}.yaml"
    recipe_path.parent.mkdir()
    recipe_path.write_text(RECIPE)
    for split, n in sizes.items():
        d = root / "data" / DOMAIN / split
        for sub in ("points", "sketches"):
            (d / sub).mkdir(parents=True)
        ids = [f"{split}-{i:06d}" for i in range(n)]
        frame = pd.DataFrame({
            "id": ids, "shard": 0, "forced": "height", "forced_class": 0,
            "height": rng.choice([0.5, 1.0, 1.5], n), "has_handle": rng.integers(0, 2, n).astype(float),
            "handle_size": rng.choice([0.0, 0.3], n), "legs": rng.integers(0, 3, n).astype(float),
        })
        frame.to_parquet(d / "recipes.parquet")
        for i in ids:
            np.savez(d / "points" / f"{i}.npz", fps=rng.normal(size=(N_FPS, 3)).astype(np.float32),
                     random=rng.normal(size=(N_RANDOM, 3)).astype(np.float32))
            for cam in CAMERAS:
                img = np.full((224, 224), 255, np.uint8)
                img[rng.integers(20, 200), 10:200] = 0  # one black stroke
                Image.fromarray(img, "L").save(d / "sketches" / f"{i}_{cam}.png")
    return root / "data", build, recipe_path


@contextmanager
def toy_config(root, epochs: int, *overrides: str):
    """The composed config of a CPU training run on `make_dataset(root)`, with the toy
    domain in the program registry while the context lasts."""
    from geocode.config import compose
    from geocode.paths import PROGRAMS_ENV

    data, build, recipe_path = make_dataset(root)
    recipe_path.with_suffix(".py").write_text("")  # registers the domain; training never runs it
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PROGRAMS_ENV, str(recipe_path.parent))
        yield compose([
            "profile=smoke", f"paths.data={data}", f"paths.build={build}", f"paths.runs={root / 'runs'}",
            f"domain={DOMAIN}", f"domains=[{DOMAIN}]", f"data.points.train_random={N_PICK}",
            f"train.max_epochs={epochs}", "train.batch_size=4", "train.accelerator=cpu", "train.devices=1",
            *overrides,
        ])


@pytest.fixture
def dataset(tmp_path):
    data, build, recipe_path = make_dataset(tmp_path)
    parameters, visibility = load_manifest(build / "programs" / f"{DOMAIN}.manifest.json")
    return data / DOMAIN, Recipe.load(recipe_path, parameters, visibility)


def test_load_split_labels_and_arrays(dataset):
    root, recipe = dataset
    split = load_split(root / "train", recipe, CAMERAS)
    frame = pd.read_parquet(root / "train" / "recipes.parquet")
    assert split.fps.shape == (10, N_FPS, 3) and split.random.shape == (10, N_RANDOM, 3)
    assert split.sketches["az55"].shape == (10, 224, 224) and split.sketches["az55"].dtype == np.uint8
    assert split.labels.dtype == np.int64 and split.labels.shape == (10, 4)
    hidden = frame["has_handle"].to_numpy() == 0
    assert (split.labels[hidden, 2] == recipe["handle_size"].existence_class).all()
    assert (split.labels[~hidden, 2] < 2).all()
    np.testing.assert_array_equal(split.labels[:, 0], np.rint((frame["height"] - 0.5) / 0.5))


def test_a_split_with_fewer_sketches_than_clouds(dataset):
    """The first draws of each class have sketches; the others only clouds. A training item
    pairs each cloud with a sketch (and its labels), and a sketch-only model's epoch is the
    sketched shapes."""
    root, recipe = dataset
    for png in (root / "train" / "sketches").glob("*.png"):
        if int(png.name[6:12]) >= 3:
            png.unlink()                                     # only shapes 0-2 are ever read
    split = load_split(root / "train", recipe, CAMERAS, sketched=(3, 10))   # one class of 10 draws: 0-2
    assert split.fps.shape[0] == 10 and split.sketches["az35"].shape[0] == 3
    assert split.sketch_rows.tolist() == [0, 1, 2]
    both = ShapeItems(split, N_PICK, CAMERAS, train=True)
    assert len(both) == 10
    item = both[4]
    assert torch.equal(item["labels"], torch.from_numpy(split.labels[4]))
    assert torch.equal(item["sketch_labels"], torch.from_numpy(split.labels[1]))       # 4 mod 3
    sketches = ShapeItems(split, N_PICK, CAMERAS, train=True, modalities=["sketch"])
    assert len(sketches) == 3 and torch.equal(sketches[2]["labels"], torch.from_numpy(split.labels[2]))


def test_items_train_draws_fresh_eval_fixed(dataset):
    root, recipe = dataset
    split = load_split(root / "val", recipe, CAMERAS[:1])
    ev = ShapeItems(split, N_PICK, CAMERAS[:1], train=False)
    a, b = ev[1], ev[1]
    assert a["points"].shape == (N_FPS + N_PICK, 3) and a["sketch"].shape == (1, 224, 224)
    assert torch.equal(a["points"], b["points"]) and torch.equal(a["sketch"], b["sketch"])
    clouds = {"fps": split.fps[1], "random": split.random[1]}
    np.testing.assert_array_equal(a["points"].numpy(), eval_cloud(clouds, N_PICK, 0, split.ids[1]))
    tr = ShapeItems(load_split(root / "train", recipe, CAMERAS), N_PICK, CAMERAS, train=True,
                    augment=SketchAugment(0, 0, 0))
    torch.manual_seed(0)
    draws = [tr[0]["points"] for _ in range(3)]
    assert not torch.equal(draws[0], draws[1]) or not torch.equal(draws[1], draws[2])
    assert torch.equal(draws[0][:N_FPS], torch.from_numpy(tr.data.fps[0]))
    assert a["labels"].dtype == torch.int64


def test_sketch_augmentation():
    x = torch.ones(1, 9, 9)
    x[0, 4, 2] = 0.0  # one dark pixel
    assert SketchAugment(flip=1, dilate=0, erode=0)(x)[0, 4, 6] == 0
    thick = SketchAugment(flip=0, dilate=1, erode=0)(x)
    assert (thick[0, 3:6, 1:4] == 0).all() and thick.sum() == 81 - 9
    thin = SketchAugment(flip=0, dilate=0, erode=1)(thick)
    assert thin.sum() == 81 - 1 and thin[0, 4, 2] == 0


def test_load_sketch_and_errors(dataset, tmp_path):
    root, _ = dataset
    s = load_sketch(root / "train" / "sketches" / "train-000000_az35.png")
    assert s.shape == (1, 224, 224) and s.dtype == np.float32 and s.max() == 1.0 and s.min() == 0.0
    with pytest.raises(ValueError, match="nothere.png"):
        load_sketch(tmp_path / "nothere.png")


def test_datamodule_batches(dataset):
    root, recipe = dataset
    dm = GeoCodeDataModule(root, recipe, CAMERAS, n_random=N_PICK, batch_size=4)
    dm.setup("fit")
    batch = next(iter(dm.train_dataloader()))
    assert batch["points"].shape == (4, N_FPS + N_PICK, 3) and batch["sketch"].shape == (4, 1, 224, 224)
    assert batch["labels"].shape == (4, 4) and batch["labels"].dtype == torch.int64
    assert len(dm.train_dataloader()) == 2  # 10 items, batch 4, last partial batch dropped
    val = list(dm.val_dataloader())
    assert sum(len(b["labels"]) for b in val) == 4


def test_datamodule_carries_only_the_modalities_asked_for(dataset):
    root, recipe = dataset
    dm = GeoCodeDataModule(root, recipe, CAMERAS, n_random=N_PICK, batch_size=4, modalities=["points"])
    dm.setup("fit")
    assert dm.split("train").sketches == {}  # no sketch read from disk
    assert set(next(iter(dm.train_dataloader()))) == {"points", "labels"}
    assert set(next(iter(dm.val_dataloader()))) == {"points", "labels"}
    with pytest.raises(ValueError, match=r"train.modalities=\['pixels'\]"):
        GeoCodeDataModule(root, recipe, CAMERAS, modalities=["pixels"])


def test_point_augmentation_keeps_the_size_and_stays_near_the_surface():
    rng = np.random.default_rng(0)
    cloud = rng.normal(size=(1000, 3)).astype(np.float32)
    assert np.array_equal(PointAugment()(cloud, rng), cloud)  # all off: the cloud unchanged
    scaled = PointAugment(scale=0.1)(cloud, rng)
    factors = scaled / cloud  # one factor per axis
    assert np.allclose(factors, factors[0], atol=1e-5) and (np.abs(factors[0] - 1) <= 0.1).all()
    assert not np.allclose(factors[0], factors[0].mean())  # anisotropic
    jittered = PointAugment(jitter=0.01)(cloud, rng)
    assert 0 < np.abs(jittered - cloud).max() <= 0.03 + 1e-6
    dropped = PointAugment(dropout=0.5)(cloud, np.random.default_rng(3))
    kept = np.isin(dropped.view("V12"), cloud.view("V12")).all()  # every point is an original one
    n_unique = len(np.unique(dropped, axis=0))
    assert dropped.shape == cloud.shape and kept and 500 <= n_unique < 1000


def test_training_items_are_augmented_and_evaluation_items_not(dataset):
    root, recipe = dataset
    split = load_split(root / "train", recipe, [])
    aug = PointAugment(scale=0.2)
    torch.manual_seed(0)
    tr = ShapeItems(split, N_PICK, CAMERAS, train=True, point_augment=aug, modalities=["points"])
    assert not np.allclose(tr[0]["points"][:N_FPS].numpy(), split.fps[0])
    ev = ShapeItems(split, N_PICK, CAMERAS, train=False, point_augment=aug, modalities=["points"])
    np.testing.assert_array_equal(ev[0]["points"][:N_FPS].numpy(), split.fps[0])
