"""Hydra configuration: compose `conf/` with command-line overrides (no bpy, no torch)."""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Sequence

from omegaconf import DictConfig, ListConfig, OmegaConf

from geocode.paths import programs_dir, repo_root
from geocode.settings import MAPPINGS, NAME, ConfigError, Settings, check, documented_keys  # noqa: F401 (NAME re-exported)
from geocode.variants import variant_modalities

KEYS_HINT = "see `geocode config --keys`"


def registry() -> list[str]:
    """The domains, sorted: every program `<domain>.py` with its recipe `<domain>.yaml` beside it
    (names starting with `_` are helpers, not programs)."""
    return sorted(p.stem for p in programs_dir().glob("*.py")
                  if not p.stem.startswith("_") and p.with_suffix(".yaml").exists())


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
    from omegaconf.errors import OmegaConfBaseException

    GlobalHydra.instance().clear()
    _register_domains()
    try:
        with initialize_config_dir(str(repo_root() / "conf"), version_base="1.3"):
            cfg = hydra_compose("config", overrides=list(overrides))
    except (HydraException, ValueError) as exc:  # Hydra's override parser raises ValueError too
        first = str(exc).strip().splitlines()[0]
        if unknown := re.search(r"Could not find 'domain/([^']*)'", first):
            raise ConfigError(
                f"domain={unknown[1]}: no such domain; use one of {', '.join(registry()) or 'none'}, "
                f"or add programs/{unknown[1]}.py with its recipe programs/{unknown[1]}.yaml "
                f"(in {programs_dir()})") from None
        mapping = next((m for m in MAPPINGS if f"'{m}" in first), None)  # a new entry needs ++
        hint = f" Add an entry with ++{mapping}.<key>=<value>" if mapping else ""
        raise ConfigError(f"conf/: {first}{hint}; {KEYS_HINT} for the groups and keys") from None
    try:
        validate(cfg)
    except OmegaConfBaseException as exc:       # e.g. an interpolation ${...} that resolves to nothing
        raise ConfigError(exc.full_key or "conf/", str(exc).strip().splitlines()[0], KEYS_HINT) from None
    return cfg


# -- validation: the models of geocode.settings, then the names that must come from known sets ----

def validate(cfg: DictConfig) -> None:
    """Fail before any work, naming the key, on a value that cannot be right."""
    _check_targets(cfg)                     # first: the classes Hydra would import and call
    settings(cfg)
    _check_known(cfg)


def settings(cfg: DictConfig) -> Settings:
    """The composed config as validated settings (typed values, every key present)."""
    return check(OmegaConf.to_container(cfg, resolve=True))


def _check_targets(cfg: DictConfig) -> None:
    variants = group_options("model")
    targets = {t for name in variants
               for t in _targets(OmegaConf.load(repo_root() / "conf" / "model" / f"{name}.yaml"))}
    for target in _targets(cfg):
        if target not in targets:
            raise ConfigError(f"_target_={target}", "not one of the project's model classes",
                              f"use {', '.join(sorted(targets))} (choose the variant with model=<name>)")


def _check_known(cfg: DictConfig) -> None:
    """Names that become folders or imports come from a known set (domain.name is only a
    name: a step may work from a manifest and a recipe without the program)."""
    known = registry()
    for name in cfg.domains or []:
        if name not in known:
            raise ConfigError(f"domains={name}", f"no such domain in {programs_dir()}",
                              f"use one of {', '.join(known) or 'none (add a program and its recipe)'}")
    # the profiles name the project's domains; a programs folder of one's own may lack them
    shipped = {p.stem for p in (repo_root() / "programs").glob("*.yaml")}
    for key in ("data.domain_variations", "train.domain_epochs", "eval.sketch_fit_branches",
                "eval.sketch_fit_orders", "eval.sketch_fit_domain_budget"):
        for name in OmegaConf.select(cfg, key) or {}:
            if name not in {*known, *shipped}:
                raise ConfigError(f"{key}.{name}", "no such domain", f"use one of {', '.join(known) or 'none'}")
    variants = group_options("model")
    for key, names in (("model.variant", [cfg.model.variant]), ("eval.variants", cfg.eval.variants),
                       ("eval.ablations", cfg.eval.ablations), ("train.variant_epochs", cfg.train.variant_epochs)):
        for name in names:
            if name not in variants:
                raise ConfigError(f"{key}={name}", "unknown model variant", f"use one of {', '.join(variants)}")
    _check_fit(cfg)


def _check_fit(cfg: DictConfig) -> None:
    from geocode.conditions import conditions

    names = [c["condition"] for c in conditions(cfg) if c["modality"] in ("pc", "sketch")]
    for name in cfg.eval.fit:
        if name not in names:
            raise ConfigError(f"eval.fit={name}", "not a test condition", f"use some of {', '.join(names)}")


def _targets(node) -> list[str]:
    """Every `_target_` in a config (the classes Hydra would import and call)."""
    if isinstance(node, DictConfig):
        found = [str(node["_target_"])] if "_target_" in node else []
        return found + [t for key, value in node.items() if key != "_target_" for t in _targets(value)]
    if isinstance(node, ListConfig):
        return [t for item in node for t in _targets(item)]
    return []


def group_options(group: str) -> list[str]:
    """The choices of a config group (`conf/<group>/*.yaml`)."""
    return sorted(p.stem for p in (repo_root() / "conf" / group).glob("*.yaml"))


def config_groups() -> dict[str, list[str]]:
    """Each config group (`conf/<group>/`, and `domain` from the registry) with its choices."""
    groups = {p.name: group_options(p.name) for p in (repo_root() / "conf").iterdir() if p.is_dir()}
    groups["domain"] = registry()
    return dict(sorted(groups.items()))


def key_rows(cfg: DictConfig) -> list[tuple[str, str, str, str]]:
    """(key, its value in `cfg` as JSON text, meaning, valid values) for every key of the
    settings models, in their order."""
    rows = []
    for key, (meaning, valid) in documented_keys().items():
        value = OmegaConf.select(cfg, key)
        shown = json.dumps(OmegaConf.to_container(value) if isinstance(value, ListConfig | DictConfig) else value)
        rows.append((key, shown.strip(chr(34)), meaning, valid))
    return rows


def describe_keys(cfg: DictConfig) -> str:
    """`geocode config --keys`: the groups with their choices, then every key of the settings
    models with its value in `cfg` (the defaults, or with the overrides given), its meaning
    and its valid values."""
    lines = ["groups (choose with <group>=<choice>):"]
    lines += [f"  {g:<10} {', '.join(options)}" for g, options in config_groups().items()]
    lines.append("keys (set with key=value):")
    lines += [f"  {key:<26} {shown:<10} {meaning}; {valid}" for key, shown, meaning, valid in key_rows(cfg)]
    return "\n".join(lines)


def config_hash(cfg: DictConfig) -> str:
    """A short hash of the resolved config, written beside outputs it made."""
    text = OmegaConf.to_yaml(cfg, resolve=True, sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:10]


EPOCH_KEYS = ("max_epochs", "domain_epochs", "variant_epochs")   # a run given more epochs carries on
RUN_ONLY_KEYS = ("accelerator", "devices", "num_workers", "progress_bar", "log_every_n_steps", "out_dir")


def training_key(cfg: DictConfig, epochs: bool = False) -> str:
    """A short hash of what a trained model depends on: data.*, model.*, train.* but for how
    the run is carried out (RUN_ONLY_KEYS), and the seed; the epochs (EPOCH_KEYS) only with
    `epochs`, since a finished run given more epochs resumes and carries on. A run folder
    whose checkpoint has another key trains afresh (`steps.train`), and the workflow's train
    rule reruns when the key with epochs changes (a profile's YAML edited, not only the
    command line's overrides)."""
    train = OmegaConf.to_container(cfg.train, resolve=True)
    for key in RUN_ONLY_KEYS + (() if epochs else EPOCH_KEYS):
        train.pop(key, None)
    payload = {"data": OmegaConf.to_container(cfg.data, resolve=True), "train": train, "seed": cfg.seed,
               "model": OmegaConf.to_container(cfg.model, resolve=True) if "model" in cfg else None}
    return hashlib.sha1(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()[:10]


def domains(cfg: DictConfig) -> list[str]:
    """The domains the workflow runs: `domains` from config, or every domain in the registry."""
    return list(cfg.domains) if cfg.domains else registry()


def variants(cfg: DictConfig, domain: str) -> list[str]:
    """The model variants trained for a domain: eval.variants, and eval.ablations where the
    domain is one of eval.ablation_domains."""
    ablations = cfg.eval.ablations if domain in cfg.eval.ablation_domains else []
    return list(dict.fromkeys([*cfg.eval.variants, *ablations]))


def split_variations(cfg: DictConfig, domain: str, clouds: bool = True) -> dict[str, int]:
    """Shapes per parameter class of each split: data.variations, with the domain's entries
    in data.domain_variations in their place (null: none); the training split's times
    data.cloud_factor unless `clouds` is false (the shapes drawn as sketches, `sketched_draws`)."""
    counts = {**cfg.data.variations, **(cfg.data.domain_variations or {}).get(domain, {})}
    return {**counts, "train": counts["train"] * (int(cfg.data.cloud_factor) if clouds else 1)}


def sketched_draws(cfg: DictConfig, domain: str) -> tuple[int, int] | None:
    """(the first draws of each parameter class of the training split that are drawn as
    sketches, the draws of each class): None where all of them are (data.cloud_factor 1)."""
    if int(cfg.data.cloud_factor) == 1:
        return None
    return split_variations(cfg, domain, clouds=False)["train"], split_variations(cfg, domain)["train"]


def sketch_fit_budget(cfg: DictConfig, domain: str) -> int:
    """The domain's evaluations of a drawing's fit (eval.sketch_fit_domain_budget, else
    eval.sketch_fit_budget)."""
    return int((cfg.eval.sketch_fit_domain_budget or {}).get(domain, cfg.eval.sketch_fit_budget))


def sketch_fit_searches(cfg: DictConfig, domain: str) -> dict[str, int]:
    """The domain's searches of a drawing's fit, as `sketchfit.fit_drawing` takes them:
    {"branches": eval.sketch_fit_branches', "orders": eval.sketch_fit_orders'} (1 where not given)."""
    return {k: int((cfg.eval[f"sketch_fit_{k}"] or {}).get(domain, 1)) for k in ("branches", "orders")}


def max_epochs(cfg: DictConfig, variant: str, domain: str | None = None) -> int:
    """The domain's epochs (train.max_epochs, or its entry in train.domain_epochs) times the
    variant's share in train.variant_epochs (baselines and ablations trained beside the joint
    model on a smaller budget). domain: cfg.domain.name unless given."""
    epochs = (cfg.train.domain_epochs or {}).get(cfg.domain.name if domain is None else domain, cfg.train.max_epochs)
    share = float(cfg.train.variant_epochs.get(variant, 1.0))
    if "points" not in variant_modalities(variant):  # its epoch: the sketched shapes, cloud_factor times fewer
        share *= int(cfg.data.cloud_factor)
    return max(1, round(int(epochs) * share))
