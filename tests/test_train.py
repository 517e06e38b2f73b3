"""train(cfg) on the synthetic dataset of test_training_data: one epoch, resume, predict, bad checkpoints."""

import json
import logging
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from test_training_data import CAMERAS, DOMAIN, N_FPS, N_PICK, toy_config

from geocode.steps.train import CheckpointError, load_model, predict, predict_classes, train


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A one-epoch run of the joint model; returns (cfg, result)."""
    with toy_config(tmp_path_factory.mktemp("train"), epochs=1) as cfg:
        assert [c.name for c in cfg.data.sketch.cameras if c.train] == CAMERAS
        yield cfg, train(cfg)


@pytest.mark.parametrize("variant", ["separate", "regression", "huang"])
def test_each_model_config_trains_a_smoke_epoch(tmp_path, variant):
    """Each experiment's config composes and trains; its share of train.max_epochs applies."""
    with toy_config(tmp_path, 2, f"model={variant}", f"train.variant_epochs.{variant}=0.5",
                    "train.limit_train_batches=1") as cfg:
        result = train(cfg)
    # the smoke profile's data.cloud_factor 2: a sketch-only variant's epoch is half the shapes, so twice the epochs
    assert result["out_dir"].endswith(f"{DOMAIN}/{variant}") and result["epochs"] == (2 if variant == "huang" else 1)
    model = load_model(result["best"])
    assert model.hparams.variant == variant
    points = any(name.startswith("branches.0.points") for name in model.state_dict())
    assert points == (variant != "huang")


def test_one_epoch_writes_checkpoints_and_logs(run):
    cfg, result = run
    out = cfg.paths.runs + f"/{DOMAIN}/joint"
    assert result["out_dir"] == out and result["resumed"] is False
    for name in ("checkpoints/best.ckpt", "checkpoints/last.ckpt", "logs/version_0/metrics.csv", "config.yaml"):
        assert (Path(result["out_dir"]) / name).exists(), name
    metrics = pd.read_csv(f"{out}/logs/version_0/metrics.csv")
    assert {"val/acc", "val/acc_points", "val/acc_sketch", "train/loss"} <= set(metrics.columns)
    assert 0.0 <= result["best_val_acc"] <= 1.0


def test_resume_from_last(run):
    cfg, first = run
    cfg.train.max_epochs = 2
    result = train(cfg)
    assert result["resumed"] is True and result["epochs"] == 2
    ckpt = torch.load(result["last"], weights_only=True)
    assert ckpt["global_step"] == 4  # 2 epochs x 2 batches
    assert (Path(result["out_dir"]) / "logs" / "version_1" / "metrics.csv").exists()  # first log kept


def test_predict_api(run):
    _, result = run
    model = load_model(result["best"])
    assert model.parameter_names == ["height", "has_handle", "handle_size", "legs"]
    rng = np.random.default_rng(0)
    points = rng.normal(size=(5, N_FPS + N_PICK, 3)).astype(np.float32)
    sketches = rng.random((3, 1, 224, 224)).astype(np.float32)
    got = predict(result["best"], points=points, sketches=sketches, batch_size=2)
    assert got["names"] == model.parameter_names
    assert got["points"].shape == (5, 4) and got["sketch"].shape == (3, 4)
    assert got["points"].dtype == np.int64 and (got["points"][:, 2] <= 2).all()
    np.testing.assert_array_equal(predict_classes(model, points=points[:, :500]), got["points"])
    other = predict_classes(model, points=rng.normal(size=(2, 1000, 3)))  # any number of points
    assert other.shape == (2, 4)


def test_bad_checkpoints_fail_in_one_line(run, tmp_path):
    _, result = run
    broken = tmp_path / "broken.ckpt"
    broken.write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="broken.ckpt") as err:
        load_model(broken)
    assert "\n" not in str(err.value)
    foreign = tmp_path / "foreign.ckpt"
    torch.save({"state_dict": {}, "hyper_parameters": {}}, foreign)
    with pytest.raises(CheckpointError, match="foreign.ckpt: not a geocode model"):
        load_model(foreign)
    ckpt = torch.load(result["best"], weights_only=True)
    ckpt["hyper_parameters"]["heads"][0]["n_classes"] = 7
    mismatched = tmp_path / "mismatched.ckpt"
    torch.save(ckpt, mismatched)
    with pytest.raises(CheckpointError, match="mismatched.ckpt: checkpoint does not fit"):
        load_model(mismatched)


def test_majority_accuracy_is_the_most_frequent_train_class_scored_on_val(run):
    from geocode.paths import recipes_file, split_dir
    from geocode.recipe import load_recipe, load_recipes
    from geocode.steps.train import majority_accuracy

    cfg, result = run
    recipe = load_recipe(cfg)
    train_c, val_c = (recipe.class_matrix(load_recipes(recipes_file(split_dir(cfg, DOMAIN, s))))
                      for s in ("train", "val"))
    per_parameter = []
    for j in range(train_c.shape[1]):
        values, counts = np.unique(train_c[:, j], return_counts=True)
        per_parameter.append(np.mean(val_c[:, j] == values[counts.argmax()]))
    assert result["majority_val_acc"] == pytest.approx(np.mean(per_parameter))
    assert majority_accuracy(cfg, recipe) == result["majority_val_acc"]


def test_loaded_network_predicts_as_the_trained_module_without_lightning(run):
    """load_model rebuilds a plain network (geocode.checkpoints imports no Lightning, so
    `geocode reconstruct` starts faster) that holds the module's tensors and predicts as it."""
    import subprocess
    import sys

    from geocode.models import GeoCodeModule, GeoCodeNet

    _, result = run
    net = load_model(result["best"])
    ckpt = torch.load(result["best"], weights_only=True)
    module = GeoCodeModule(**ckpt["hyper_parameters"])
    module.load_state_dict(ckpt["state_dict"])
    assert isinstance(net, GeoCodeNet) and not isinstance(net, GeoCodeModule)
    assert net.state_dict().keys() == module.state_dict().keys()
    points = np.random.default_rng(1).normal(size=(4, N_FPS + N_PICK, 3)).astype(np.float32)
    np.testing.assert_array_equal(predict_classes(net, points=points), predict_classes(module.eval(), points=points))
    code = "import sys, geocode.checkpoints, geocode.reconstruct.run; print('pytorch_lightning' in sys.modules)"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "False"


def test_network_defaults_are_the_training_modules_and_fill_old_checkpoints(run, tmp_path):
    """A checkpoint from before a network key existed (here `embedding_norm`) loads with the
    key's default, which is the training module's default too."""
    import inspect

    from geocode.models import GeoCodeModule
    from geocode.models.network import NETWORK_DEFAULTS

    defaults = {k: p.default for k, p in inspect.signature(GeoCodeModule).parameters.items()}
    assert {k: defaults[k] for k in NETWORK_DEFAULTS} == NETWORK_DEFAULTS
    _, result = run
    ckpt = torch.load(result["best"], weights_only=True)
    del ckpt["hyper_parameters"]["embedding_norm"]
    ckpt["state_dict"] = {k: v for k, v in ckpt["state_dict"].items() if ".norms." not in k}
    old = tmp_path / "old.ckpt"
    torch.save(ckpt, old)
    assert load_model(old).hparams.get("embedding_norm") is None and not load_model(old).branches[0].norms


def test_a_changed_program_trains_afresh_and_sets_the_old_run_aside(tmp_path, caplog):
    """The run folder is keyed to the program's manifest: after the program changes (here its
    `legs` range widens, which also changes a head), training starts afresh instead of
    refusing the old last.ckpt, and the old run moves into stale-<its key>/ with one log line."""
    with toy_config(tmp_path, 1, "train.limit_train_batches=1") as cfg:
        first = train(cfg)
        manifest = Path(cfg.paths.build) / "programs" / f"{DOMAIN}.manifest.json"
        changed = json.loads(manifest.read_text())
        changed["parameters"][3]["max"] = 3
        changed["geometry"] = "another fingerprint"
        manifest.write_text(json.dumps(changed))
        with caplog.at_level(logging.WARNING, logger="geocode.train"):
            second = train(cfg)
    out, stale = Path(second["out_dir"]), Path(second["out_dir"]) / f"stale-{first['program']}"
    assert second["resumed"] is False and second["program"] != first["program"]
    assert (stale / "checkpoints" / "last.ckpt").exists() and (stale / "logs" / "version_0").exists()
    assert (out / "logs" / "version_0").exists() and not (out / "logs" / "version_1").exists()
    assert [r.levelname for r in caplog.records if "another version of the program" in r.getMessage()] == ["WARNING"]
    assert torch.load(second["last"], weights_only=True)["program"] == second["program"]
    assert load_model(second["best"]).hparams.heads[3]["n_classes"] == 4


def test_other_training_settings_train_afresh_but_more_epochs_carry_on(tmp_path, caplog):
    """A run folder is keyed to its settings too (`config.training_key`): a changed learning
    rate sets the old run aside and starts again, where more epochs resume it."""
    from geocode.config import training_key

    with toy_config(tmp_path, 1, "train.limit_train_batches=1") as cfg:
        first = train(cfg)
        old_key = training_key(cfg)
        cfg.train.max_epochs = 2
        assert training_key(cfg) == old_key and train(cfg)["resumed"] is True
        cfg.train.lr = cfg.train.lr / 2
        with caplog.at_level(logging.WARNING, logger="geocode.train"):
            second = train(cfg)
    out = Path(second["out_dir"])
    assert second["resumed"] is False and out == Path(first["out_dir"])
    assert (out / f"stale-{old_key}" / "checkpoints" / "last.ckpt").exists()
    assert [r.levelname for r in caplog.records if "other settings" in r.getMessage()] == ["WARNING"]
    assert torch.load(second["last"], weights_only=True)["settings"] == training_key(cfg) != old_key
