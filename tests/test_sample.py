"""Dataset sampling: counts, forced visibility, constraints, dedup across splits, determinism."""

import numpy as np
import pandas as pd
import pytest

from geocode.expr import parse
from geocode.recipe import Parameter, Recipe, load_recipes, save_recipes
from geocode.steps.dataset import (
    SamplingError,
    assign_shards,
    sample_dataset,
    shape_hashes,
    split_cameras,
    split_order,
)

PARAMETERS = [
    Parameter("height", "float", 0.5, 2.0, 1.0),
    Parameter("width", "float", 0.2, 1.0, 0.6),
    Parameter("has_handle", "bool", 0, 1, 0),
    Parameter("handle_size", "float", 0.0, 0.3, 0.1),
    Parameter("legs", "int", 0, 4, 4),
    Parameter("leg_thickness", "float", 0.01, 0.1, 0.05),
    Parameter("style", "int", 0, 2, 0),
]
VISIBILITY = {
    "height": None,
    "width": None,
    "has_handle": None,
    "handle_size": parse("has_handle"),
    "legs": None,
    "leg_thickness": parse("legs > 0 and style != 2"),
    "style": None,
}
RECIPE = {
    "parameters": {
        "height": {"min": 0.5, "max": 1.5, "samples": 3},
        "width": {"min": 0.2, "max": 1.0, "samples": 3},
        "has_handle": None,
        "handle_size": {"min": 0.0, "max": 0.3, "samples": 3},
        "legs": {"min": 0, "max": 3},
        "leg_thickness": {"min": 0.01, "max": 0.1, "samples": 2},
    },
    "constraints": ["width >= 0.3 * height"],
}
VARIATIONS = {"train": 4, "val": 1, "test": 1}


@pytest.fixture(scope="module")
def recipe():
    return Recipe.from_dict(RECIPE, PARAMETERS, VISIBILITY, source="test.yaml")


@pytest.fixture(scope="module")
def splits(recipe):
    return sample_dataset(recipe, VARIATIONS, seed=7, domain="vase")


def test_split_order():
    assert list(split_order({"train": 1, "val": 1, "test": 1, "extra": 1})) == [
        "test",
        "val",
        "train",
        "extra",
    ]


def test_counts_columns_and_ids(recipe, splits):
    assert list(splits) == ["test", "val", "train"]
    classes = sum(p.n_values for p in recipe.parameters)  # 3 + 3 + 2 + 3 + 4 + 2 = 17
    for split, frame in splits.items():
        assert len(frame) == classes * VARIATIONS[split]
        assert list(frame.columns) == ["id", "shard", "forced", "forced_class", *recipe.names]
        assert frame["id"].tolist() == [f"{split}-{i:06d}" for i in range(len(frame))]
        assert all(frame[name].dtype == np.float64 for name in recipe.names)
        assert frame["forced_class"].dtype == np.int64
        counts = frame.groupby(["forced", "forced_class"]).size()
        assert len(counts) == classes and (counts == VARIATIONS[split]).all()


def test_forced_value_is_set_and_visible(recipe, splits):
    for frame in splits.values():
        visible = recipe.visibility_matrix(frame)
        column = np.array([recipe.names.index(f) for f in frame["forced"]])
        rows = np.arange(len(frame))
        assert visible[rows, column].all()
        values = recipe.value_matrix(frame)[rows, column]
        expected = [
            recipe[f].classes[c]
            for f, c in zip(frame["forced"], frame["forced_class"], strict=True)
        ]
        assert np.array_equal(values, expected)


def test_values_are_classes_and_constraints_hold(recipe, splits):
    for frame in splits.values():
        assert recipe.constraint_mask(frame).all()
        for p in recipe.parameters:
            assert np.isin(frame[p.name], p.classes).all()


def test_no_duplicates_across_splits(recipe, splits):
    hashes = [h for frame in splits.values() for h in shape_hashes(recipe, frame)]
    assert len(hashes) == len(set(hashes))


def test_invisible_values_do_not_distinguish_shapes(recipe):
    base = {"height": 1.0, "width": 0.6, "has_handle": 0, "legs": 2, "leg_thickness": 0.1}
    frame = pd.DataFrame([{**base, "handle_size": 0.0}, {**base, "handle_size": 0.3}])
    first, second = shape_hashes(recipe, frame)
    assert first == second


def test_deterministic(recipe, splits):
    again = sample_dataset(recipe, VARIATIONS, seed=7, domain="vase")
    for split in splits:
        pd.testing.assert_frame_equal(splits[split], again[split])
    other = sample_dataset(recipe, VARIATIONS, seed=8, domain="vase")
    assert not other["train"].equals(splits["train"])


def test_test_split_independent_of_train_size(recipe, splits):
    bigger = sample_dataset(recipe, {**VARIATIONS, "train": 6}, seed=7, domain="vase")
    pd.testing.assert_frame_equal(bigger["test"], splits["test"])


def test_accept_vetoes_shapes(recipe):
    seen = []

    def accept(values):
        seen.append(values)
        return values["height"] + values["width"] < 2.2

    out = sample_dataset(recipe, {"train": 2}, seed=1, domain="vase", accept=accept)
    frame = out["train"]
    assert set(seen[0]) == set(recipe.names)
    assert ((frame["height"] + frame["width"]) < 2.2).all()


def test_impossible_class_names_parameter_and_fix(recipe):
    with pytest.raises(SamplingError) as info:
        sample_dataset(
            recipe,
            {"train": 1},
            seed=1,
            domain="vase",
            accept=lambda v: v["legs"] != 3,
            max_tries=20,
        )
    message = str(info.value)
    assert (
        "legs = 3" in message
        and "20 tries" in message
        and "validator" in message
        and "\n" not in message
    )


def test_unsatisfiable_visibility_is_reported():
    visibility = {**VISIBILITY, "leg_thickness": parse("legs > 10")}
    recipe = Recipe.from_dict(RECIPE, PARAMETERS, visibility)
    with pytest.raises(SamplingError, match=r"leg_thickness = 0.01 .*visibility rule `legs > 10`"):
        sample_dataset(recipe, {"test": 1}, seed=1, domain="vase", max_tries=10)


def test_too_few_distinct_shapes_is_reported():
    data = {"parameters": {"has_handle": None, "legs": {"min": 0, "max": 1}}}
    recipe = Recipe.from_dict(data, PARAMETERS, VISIBILITY)
    with pytest.raises(SamplingError, match="too few distinct shapes"):
        sample_dataset(recipe, {"train": 3}, seed=1, domain="vase", max_tries=50)


def test_bad_arguments(recipe):
    with pytest.raises(ValueError, match="seed"):
        sample_dataset(recipe, {"train": 1}, seed=-1, domain="vase")
    with pytest.raises(ValueError, match="variations.train"):
        sample_dataset(recipe, {"train": -2}, seed=1, domain="vase")
    assert len(sample_dataset(recipe, {"train": 0}, seed=1, domain="vase")["train"]) == 0


def test_classes_are_drawn_roughly_uniformly(recipe, splits):
    frame = splits["train"]
    others = frame[frame["forced"] != "legs"]  # legs is in no constraint
    counts = others["legs"].value_counts()
    assert len(counts) == 4 and counts.min() > 0.1 * len(others)


def test_assign_shards(splits):
    frame = assign_shards(splits["train"], 3)
    assert frame["shard"].tolist() == [i % 3 for i in range(len(frame))]
    assert (splits["train"]["shard"] == 0).all()  # the input is not modified
    with pytest.raises(ValueError):
        assign_shards(frame, 0)


def test_save_and_load_recipes(tmp_path, splits):
    path = tmp_path / "vase" / "train" / "recipes.parquet"
    save_recipes(splits["train"], path)
    pd.testing.assert_frame_equal(load_recipes(path), splits["train"])
    assert sorted(p.name for p in path.parent.iterdir()) == ["recipes.parquet"]  # no temp file left
    first = path.read_bytes()
    save_recipes(splits["train"], path)
    assert path.read_bytes() == first  # byte-identical rewrite
    with pytest.raises(ValueError, match="file not found"):
        load_recipes(tmp_path / "none.parquet")


def test_domain_variations_replace_a_domains_split_counts():
    """data.domain_variations gives one domain more shapes; the others keep data.variations."""
    from geocode.config import compose, split_variations

    cfg = compose(["data.variations={train: 2, val: 1, test: 1}", "data.domain_variations=null",
                   "data.domain_variations={ceiling_lamp: {train: 4}, vase: {test: 3}}"])
    assert split_variations(cfg, "ceiling_lamp") == {"train": 4, "val": 1, "test": 1}
    assert split_variations(cfg, "vase") == {"train": 2, "val": 1, "test": 3}
    assert split_variations(cfg, "chair") == {"train": 2, "val": 1, "test": 1}
    assert split_variations(compose(["data.domain_variations=null"]), "ceiling_lamp")["train"] == 2
    assert split_variations(compose(["++data.domain_variations.chair.train=3"]), "chair")["train"] == 3


def test_cloud_factor_grows_the_training_split_and_only_its_first_draws_are_sketched():
    from geocode.config import compose, max_epochs, sketched_draws, split_variations
    from geocode.steps.dataset import first_draws

    cfg = compose(["domain=vase", "data.variations={train: 2, val: 1, test: 1}", "data.domain_variations=null",
                   "train.domain_epochs=null",
                   "data.cloud_factor=4", "train.max_epochs=4", "train.variant_epochs={huang: 0.5, separate: 0.5}"])
    assert split_variations(cfg, "vase") == {"train": 8, "val": 1, "test": 1}
    assert split_variations(cfg, "vase", clouds=False)["train"] == 2 and sketched_draws(cfg, "vase") == (2, 8)
    assert sketched_draws(compose(["data.cloud_factor=1"]), "vase") is None
    # a sketch-only variant's epoch is a pass over the sketched shapes: cloud_factor times the epochs
    assert max_epochs(cfg, "joint") == 4 and max_epochs(cfg, "separate") == 2 and max_epochs(cfg, "huang") == 8
    # a shape's draw is its id's number modulo the draws of a class, in a subset too
    ids = [f"train-{i:06d}" for i in (0, 1, 2, 5, 7, 8, 9, 14)]
    assert first_draws(ids, (2, 4)).tolist() == [0, 1, 3, 5, 6]
    assert first_draws(ids, None).tolist() == list(range(8))


def test_domain_epochs_replace_a_domains_max_epochs():
    """train.domain_epochs gives one domain more epochs; a variant's share applies to them."""
    from geocode.config import compose, max_epochs

    cfg = compose(["domain=vase", "train.max_epochs=16", "train.domain_epochs={vase: 20}",
                   "train.variant_epochs.huang=0.375"])
    assert max_epochs(cfg, "joint") == 20 and max_epochs(cfg, "huang") == 8     # the step's own domain
    assert max_epochs(cfg, "joint", "chair") == 16 and max_epochs(cfg, "huang", "chair") == 6


def test_only_the_test_split_is_drawn_from_the_novel_camera():
    from omegaconf import OmegaConf

    cams = OmegaConf.create([{"name": "az35", "azimuth": 35, "train": True},
                             {"name": "az55", "azimuth": 55, "train": True},
                             {"name": "az15", "azimuth": 15, "train": False}])
    assert [c.name for c in split_cameras(cams, "test")] == ["az35", "az55", "az15"]
    for split in ("train", "val", "test-s10"):
        assert [c.name for c in split_cameras(cams, split)] == ["az35", "az55"]
