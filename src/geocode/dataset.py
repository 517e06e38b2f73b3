"""The sampling step: program manifest + recipe -> recipes.parquet for every split (no bpy)."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig

from geocode.config import data_dir, repo_root
from geocode.recipe import Recipe, load_manifest
from geocode.sampling import assign_shards, sample_dataset, save_recipes

log = logging.getLogger("geocode.sample")

SPLITS = ("train", "val", "test")


def manifest_path(cfg: DictConfig, domain: str) -> Path:
    return Path(cfg.paths.build) / "programs" / f"{domain}.manifest.json"


def load_recipe(cfg: DictConfig) -> Recipe:
    """The recipe of cfg.domain (`domain.recipe`, relative to the repository), checked against
    the parameters in its program's manifest."""
    domain = cfg.domain.name
    parameters, visibility = load_manifest(manifest_path(cfg, domain))
    return Recipe.load(repo_root() / cfg.domain.recipe, parameters, visibility)


def spread_subset(frame: pd.DataFrame, keep: int | None) -> pd.DataFrame:
    """At most `keep` rows, evenly spread over the frame so every forced parameter shows up."""
    if keep is None or len(frame) <= keep:
        return frame
    rows = np.unique(np.linspace(0, len(frame) - 1, keep).round().astype(int))
    return frame.iloc[rows].reset_index(drop=True)


def sample_step(cfg: DictConfig) -> str:
    domain = cfg.domain.name
    recipe = load_recipe(cfg)
    splits = sample_dataset(recipe, dict(cfg.data.variations), seed=cfg.seed, domain=domain)
    counts = []
    for split in SPLITS:
        frame = spread_subset(splits[split], cfg.data.max_shapes[split])
        frame = assign_shards(frame, cfg.data.shards)
        save_recipes(frame, data_dir(cfg, domain, split) / "recipes.parquet")
        counts.append(f"{split} {len(frame)}")
    summary = f"{domain}: " + ", ".join(counts) + " shapes"
    log.info(summary)
    return summary
