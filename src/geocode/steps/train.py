"""Training (docs/paper-numbers.md#training); loading and prediction come from
`geocode.checkpoints` (also importable from here).

    train(cfg, out_dir=None) -> dict        # Lightning fit; resumes from <out>/checkpoints/last.ckpt
"""

from __future__ import annotations

import json
import logging
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytorch_lightning as pl
from omegaconf import DictConfig, OmegaConf

from geocode import paths
from geocode import settings as schema
from geocode.card import write_card
from geocode.checkpoints import (  # noqa: F401  (load_model, predict, predict_classes: this module's API too)
    CheckpointError,
    check_recipe,
    load_model,
    predict,
    predict_classes,
    read_checkpoint,
    recipe_stamp,
)
from geocode.config import max_epochs, settings, sketched_draws, training_key
from geocode.errors import UserError, one_line
from geocode.meshio import write_text
from geocode.models.module import MODALITIES, GeoCodeModule
from geocode.recipe import load_recipe

log = logging.getLogger(__name__)

__all__ = ["CheckpointError", "load_model", "predict", "predict_classes", "train"]


# ---------------------------------------------------------------- config helpers


def camera_names(cfg: DictConfig) -> list[str]:
    """Training cameras: cfg.data.sketch.cameras entries with train: true."""
    return [c.name for c in settings(cfg).data.sketch.cameras if c.train]


def variant(cfg: DictConfig) -> str:
    return str(cfg.model.variant)


def run_dir(cfg: DictConfig, out_dir: str | Path | None) -> Path:
    if out_dir is not None:
        return Path(out_dir)
    if cfg.train.out_dir:
        return Path(cfg.train.out_dir)
    return paths.run_dir(cfg, cfg.domain.name, variant(cfg))


def build_model(cfg: DictConfig, recipe) -> GeoCodeModule:
    """cfg.model instantiated with the recipe's heads and the optimiser settings of cfg.train."""
    from hydra.errors import InstantiationException
    from hydra.utils import instantiate

    from geocode.config import KEYS_HINT, ConfigError
    from geocode.models.heads import head_specs

    t = settings(cfg).train
    try:
        return instantiate(
            cfg.model, heads=head_specs(recipe), lr=t.lr, step_size=t.step_size, gamma=t.gamma,
            schedule=t.schedule, warmup_epochs=t.warmup_epochs, modalities=t.modalities, _convert_="all",
        )
    except InstantiationException as exc:
        raise ConfigError("model", f"cannot be built ({one_line(exc.__cause__ or exc)})", KEYS_HINT) from None


class RunStamp(pl.Callback):
    """Writes into every checkpoint what it was trained on: `recipe_stamp(recipe)` as "recipe",
    the program's manifest key as "program" and `config.training_key` as "settings"."""

    def __init__(self, recipe, program: str, settings: str):
        self.recipe, self.program, self.settings = recipe_stamp(recipe), program, settings

    def on_save_checkpoint(self, trainer, pl_module, checkpoint):
        checkpoint["recipe"] = self.recipe
        checkpoint["program"] = self.program
        checkpoint["settings"] = self.settings


def build_datamodule(cfg: DictConfig, recipe, modalities=MODALITIES):
    from geocode.steps.train_data import GeoCodeDataModule, PointAugment, SketchAugment

    s = settings(cfg)
    return GeoCodeDataModule(
        root=paths.domain_dir(cfg, cfg.domain.name),
        recipe=recipe,
        cameras=camera_names(cfg),
        n_random=s.data.points.train_random,
        batch_size=s.train.batch_size,
        num_workers=s.train.num_workers,
        augment=SketchAugment(**s.train.augment.model_dump()),
        eval_camera=s.train.eval_camera,
        point_augment=PointAugment(**s.train.augment_points.model_dump()),
        modalities=list(modalities),
        seed=s.seed,
        sketched=sketched_draws(cfg, cfg.domain.name),
    )


# ---------------------------------------------------------------- training


class EpochLog(pl.Callback):
    """A one-line summary per validation epoch, for non-interactive logs."""

    def on_validation_epoch_end(self, trainer, pl_module):
        if trainer.sanity_checking:
            return
        m = trainer.callback_metrics
        keys = ("train/loss", "val/loss", "val/acc", "val/acc_points", "val/acc_sketch")
        text = " ".join(f"{k}={float(m[k]):.4f}" for k in keys if k in m)
        log.info("epoch %d: %s", trainer.current_epoch, text)


def train(cfg: DictConfig, out_dir: str | Path | None = None) -> dict:
    """Fit cfg.model on cfg.domain's train split, validate on val; checkpoints in
    <out>/checkpoints (best.ckpt by val/acc, last.ckpt), CSV and TensorBoard logs in <out>,
    the best scores beside the majority bar in <out>/summary.json. Resumes from last.ckpt
    when it is there."""
    from pytorch_lightning.callbacks import ModelCheckpoint
    from pytorch_lightning.loggers import CSVLogger, TensorBoardLogger

    out = run_dir(cfg, out_dir)
    ckpt_dir = paths.checkpoint_dir(out)
    pl.seed_everything(int(cfg.seed), workers=True)
    recipe = load_recipe(cfg)
    program, key = paths.program_key(cfg, cfg.domain.name), training_key(cfg)
    model = build_model(cfg, recipe)
    data = build_datamodule(cfg, recipe, model.modalities)   # huang reads no clouds
    data.setup("fit")  # read (and check) the data before the run folder is made; kept for fit
    last = paths.checkpoint_file(out, "last")
    best_cb = ModelCheckpoint(dirpath=ckpt_dir, filename="best", monitor="val/acc", mode="max",
                              save_last=True, enable_version_counter=False)
    trainer = trainer_for(settings(cfg).train, max_epochs=max_epochs(cfg, variant(cfg)), default_root_dir=out,
                          callbacks=[best_cb, EpochLog(), RunStamp(recipe, program, key)])
    set_aside_if_stale(out, program, key)      # once the Trainer is sure to start
    resume = last if last.exists() else None
    if resume is not None:
        check_compatible(resume, model)
    trainer.loggers = [CSVLogger(out, name="logs"), TensorBoardLogger(out, name="tb")]  # version_<n> per (re)start
    write_text(paths.run_config_file(out), OmegaConf.to_yaml(cfg, resolve=True))  # the run folder's first file
    trainer.fit(model, datamodule=data, ckpt_path=resume, weights_only=True)
    score = best_cb.best_model_score
    curves = epoch_metrics(out)
    majority = majority_per_parameter(cfg, recipe)
    best_row = curves.loc[curves["val/acc"].idxmax()] if "val/acc" in curves else {}
    result = {
        "out_dir": str(out),
        "best": str(paths.checkpoint_file(out)),
        "last": str(last),
        "best_val_acc": None if score is None else float(score),
        **{f"best_val_acc_{m}": float(best_row[f"val/acc_{m}"]) for m in MODALITIES if f"val/acc_{m}" in curves},
        "majority_val_acc": float(np.mean(list(majority.values()))),
        "majority_per_parameter": majority,
        "epochs": int(trainer.current_epoch),
        "resumed": resume is not None,
        "program": program,
    }
    write_text(paths.summary_file(out), json.dumps(result, indent=1) + "\n")
    write_card(out)
    log.info("trained %s: %s", cfg.domain.name, result)
    return result


def epoch_metrics(run: str | Path) -> pd.DataFrame:
    """Per-epoch metrics of a run folder, from the CSV logs of every (re)start: one row per
    epoch (the last logged value of each column), indexed by epoch."""
    files = paths.csv_log_files(run)
    if not files:
        raise FileNotFoundError(f"{run}: no logs/version_*/metrics.csv; train first")
    rows = pd.concat([pd.read_csv(f) for f in files], ignore_index=True)
    return rows.drop(columns=["step"], errors="ignore").groupby("epoch").last()


def trainer_for(t: schema.Train, **wiring) -> pl.Trainer:
    """A Lightning Trainer: its settings from train.* (limit_*: null is Lightning's all), its
    run folder, epochs and callbacks from `wiring`, its loggers set by the caller. An
    accelerator or device count this machine lacks is the user's config to fix."""
    from lightning_fabric.utilities.exceptions import MisconfigurationException

    try:
        return pl.Trainer(
            accelerator=t.accelerator, devices=t.devices, deterministic=t.deterministic,
            limit_train_batches=t.limit_train_batches, limit_val_batches=t.limit_val_batches,
            log_every_n_steps=t.log_every_n_steps,
            enable_progress_bar=sys.stderr.isatty() if t.progress_bar is None else t.progress_bar,
            enable_model_summary=False, num_sanity_val_steps=0, logger=False, **wiring,
        )
    except MisconfigurationException as exc:
        raise UserError(f"train.accelerator={t.accelerator}, train.devices={t.devices}", one_line(exc),
                        "choose what this machine has (auto finds it)") from None


def majority_accuracy(cfg: DictConfig, recipe) -> float:
    """The bar a model must clear: mean top-1 accuracy over parameters on the val split of
    always predicting each parameter's most frequent class in the train split."""
    return float(np.mean(list(majority_per_parameter(cfg, recipe).values())))


def majority_per_parameter(cfg: DictConfig, recipe) -> dict[str, float]:
    """{parameter: val accuracy of its most frequent train class}, in recipe order."""
    from geocode.recipe import load_recipes

    classes = {split: recipe.class_matrix(
                   load_recipes(paths.recipes_file(paths.split_dir(cfg, cfg.domain.name, split))))
               for split in ("train", "val")}
    common = np.array([np.bincount(column).argmax() for column in classes["train"].T])  # (P,)
    hits = (classes["val"] == common).mean(axis=0)  # (P,)
    return {p.name: float(h) for p, h in zip(recipe.parameters, hits, strict=True)}


# ---------------------------------------------------------------- checkpoints


def set_aside_if_stale(out: Path, program: str, settings: str) -> None:
    """A run folder whose last checkpoint was trained on another version of the program
    (another manifest key) or with other settings (another `config.training_key`: data,
    model, learning rate, ...; more epochs are not another setting) is moved into
    <out>/stale-<its key>/, so that training starts afresh; a checkpoint from before the keys
    is resumed as before."""
    last = out / "checkpoints" / "last.ckpt"
    stamp = read_checkpoint(last) if last.exists() else {}
    changed = [(what, stamp[name], mine) for what, name, mine in
               (("another version of the program (manifest key", "program", program),
                ("other settings (training key", "settings", settings))
               if stamp.get(name) not in (None, mine)]
    if not changed:
        return
    what, theirs, mine = changed[0]
    aside = out / f"stale-{theirs}"
    for n in range(2, 1000):
        if not aside.exists():
            break
        aside = out / f"stale-{theirs}-{n}"
    aside.mkdir()
    for entry in sorted(out.iterdir()):
        if entry != aside and not entry.name.startswith("stale-"):
            entry.rename(aside / entry.name)
    log.warning("%s: trained on %s %s, now %s); moved to %s, training afresh", out, what, theirs, mine, aside)


def check_compatible(path: Path, model: GeoCodeModule) -> None:
    """Resume only from a checkpoint of the same network (variant, heads, tensor shapes)."""
    ckpt = read_checkpoint(path)
    mine = model.state_dict()
    theirs = ckpt["state_dict"]
    bad = sorted(set(mine) ^ set(theirs)) or [k for k in mine if mine[k].shape != theirs[k].shape]
    if bad or ckpt["hyper_parameters"].get("heads") != model.hparams.heads:
        what = bad[0] if bad else "heads"
        raise CheckpointError(path, f"checkpoint of a different model ({what})",
                              "delete it or train into another folder (-o)")


