"""Hydra configuration: compose `conf/` with command-line overrides (no bpy, no torch)."""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Sequence
from pathlib import Path

from omegaconf import DictConfig, OmegaConf


class ConfigError(ValueError):
    """A bad override or config value; the message is one line naming the key and the fix."""


def repo_root() -> Path:
    """The project folder holding conf/, programs/ and workflow/ (GEOCODE_ROOT overrides)."""
    if root := os.environ.get("GEOCODE_ROOT"):
        return Path(root).resolve()
    return Path(__file__).resolve().parents[2]


PROGRAMS_ENV = "GEOCODE_PROGRAMS"


def programs_dir() -> Path:
    """The shape programs: `$GEOCODE_PROGRAMS`, else `programs/` at the repository root."""
    if override := os.environ.get(PROGRAMS_ENV):
        return Path(override)
    return repo_root() / "programs"


def registry() -> list[str]:
    """The domains, sorted: every program `<domain>.py` with its recipe `<domain>.yaml` beside it
    (names starting with `_` are helpers, not programs)."""
    return sorted(p.stem for p in programs_dir().glob("*.py")
                  if not p.stem.startswith("_") and p.with_suffix(".yaml").exists())


def recipe_path(domain: str) -> Path:
    return programs_dir() / f"{domain}.yaml"


def _register_domains() -> None:
    """The `domain` config group, one option per registry domain (`domain=chair` sets
    domain.name), so that a new domain needs its program and recipe and nothing in conf/."""
    from hydra.core.config_store import ConfigStore

    store = ConfigStore.instance()
    store.repo.pop("domain", None)  # the registry may have changed since the last compose
    for domain in registry():
        store.store(group="domain", name=domain, node={"name": domain})


def compose(overrides: Sequence[str] = ()) -> DictConfig:
    """The composed config, as `geocode <step> key=value ...` and the Snakefile both see it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.errors import HydraException

    GlobalHydra.instance().clear()
    _register_domains()
    try:
        with initialize_config_dir(str(repo_root() / "conf"), version_base="1.3"):
            cfg = hydra_compose("config", overrides=list(overrides))
    except HydraException as exc:
        first = str(exc).strip().splitlines()[0]
        if unknown := re.search(r"Could not find 'domain/([^']*)'", first):
            raise ConfigError(
                f"domain={unknown[1]}: no such domain; use one of {', '.join(registry()) or 'none'}, "
                f"or add programs/{unknown[1]}.py with its recipe programs/{unknown[1]}.yaml "
                f"(in {programs_dir()})") from None
        raise ConfigError(f"conf/: {first} (see `geocode config --help` for the groups and keys)") from None
    validate(cfg)
    return cfg


def validate(cfg: DictConfig) -> None:
    """Fail before any work on values that cannot be right."""
    for split, n in cfg.data.variations.items():
        if not isinstance(n, int) or n < 1:
            raise ConfigError(f"data.variations.{split}={n}: give a whole number >= 1")
    if not isinstance(cfg.data.shards, int) or cfg.data.shards < 1:
        raise ConfigError(f"data.shards={cfg.data.shards}: give a whole number >= 1")
    pts = cfg.data.points
    if not pts.fps <= pts.surface or not pts.train_random <= pts.random:
        raise ConfigError("data.points: need fps <= surface and train_random <= random")
    names = [c.name for c in cfg.data.sketch.cameras]
    if len(set(names)) != len(names) or not any(c.train for c in cfg.data.sketch.cameras):
        raise ConfigError("data.sketch.cameras: give unique names and at least one with train: true")


def config_hash(cfg: DictConfig) -> str:
    """A short hash of the resolved config, written beside outputs it made."""
    text = OmegaConf.to_yaml(cfg, resolve=True, sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:10]


def domains(cfg: DictConfig) -> list[str]:
    """The domains the workflow runs: `domains` from config, or every domain in the registry."""
    return list(cfg.domains) if cfg.domains else registry()


def data_dir(cfg: DictConfig, domain: str, split: str) -> Path:
    return Path(cfg.paths.data) / domain / split
