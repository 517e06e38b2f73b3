"""The config's `seed` reaches every draw: the dataset's shapes, the training order and the
validation clouds; the same seed gives the same draws."""

import numpy as np
import pandas as pd
import pytest
import torch
from test_sample import PARAMETERS, RECIPE, VARIATIONS, VISIBILITY
from test_training_data import CAMERAS, DOMAIN, N_PICK, make_dataset

from geocode.config import compose
from geocode.paths import PROGRAMS_ENV
from geocode.recipe import Recipe, load_recipe
from geocode.seeds import generator
from geocode.steps.dataset import sample_dataset
from geocode.steps.train import build_datamodule


def test_generator_depends_on_seed_and_keys():
    draw = generator(0, "points", "train-000001").random(4)
    assert np.array_equal(draw, generator(0, "points", "train-000001").random(4))
    assert not np.array_equal(draw, generator(1, "points", "train-000001").random(4))
    assert not np.array_equal(draw, generator(0, "points", "train-000002").random(4))


def test_seed_changes_the_dataset():
    recipe = Recipe.from_dict(RECIPE, PARAMETERS, VISIBILITY)
    first, again, other = (sample_dataset(recipe, VARIATIONS, seed=s, domain="vase")
                           for s in (0, 0, 1))
    for split in VARIATIONS:
        pd.testing.assert_frame_equal(first[split], again[split])
        assert not first[split][recipe.names].equals(other[split][recipe.names])


@pytest.fixture(scope="module")
def toy(tmp_path_factory):
    """The synthetic toy dataset, registered as a domain."""
    root = tmp_path_factory.mktemp("seeds")
    data, build, recipe_path = make_dataset(root, sizes={"train": 12, "val": 4})
    recipe_path.with_suffix(".py").write_text("")  # registers the domain; never run here
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PROGRAMS_ENV, str(recipe_path.parent))
        yield data, build


def _batches(toy, seed: int):
    """The first training batch and the validation clouds of the datamodule that `train` builds."""
    data, build = toy
    cfg = compose(["profile=smoke", f"paths.data={data}", f"paths.build={build}", f"domain={DOMAIN}",
                   f"domains=[{DOMAIN}]", f"data.points.train_random={N_PICK}", "train.batch_size=4", f"seed={seed}"])
    assert [c.name for c in cfg.data.sketch.cameras if c.train] == CAMERAS
    dm = build_datamodule(cfg, load_recipe(cfg))
    dm.setup("fit")
    torch.manual_seed(0)  # the item draws' generator is the same: only the loader's order may differ
    train = next(iter(dm.train_dataloader()))
    val = torch.cat([b["points"] for b in dm.val_dataloader()])
    return train["labels"], train["points"], val


def test_seed_changes_the_training_draw(toy):
    labels, points, val = _batches(toy, 0)
    labels_again, points_again, val_again = _batches(toy, 0)
    assert torch.equal(points, points_again) and torch.equal(val, val_again)
    assert torch.equal(labels, labels_again)
    _, points_other, val_other = _batches(toy, 1)
    assert not torch.equal(points, points_other)  # another order of the training shapes
    assert not torch.equal(val, val_other)        # another fixed draw of validation points
