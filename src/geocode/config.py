"""Hydra configuration: compose `conf/` with command-line overrides (no bpy, no torch)."""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from omegaconf import DictConfig, ListConfig, OmegaConf

from geocode.errors import UserError
from geocode.paths import SPLITS, programs_dir, repo_root

KEYS_HINT = "see `geocode config --keys`"


class ConfigError(UserError):
    """A bad override or config value; the message is one line naming the key and the fix."""


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


# -- every setting: what it means and which values it takes --------------------------------------

@dataclass(frozen=True)
class Setting:
    meaning: str
    expect: str                         # the valid values, in words: "a whole number >= 1"
    ok: Callable[[object], bool]


Rule = tuple[str, Callable[[object], bool]]    # (expect, ok) of a Setting


def _whole(low: int) -> Rule:
    return f"a whole number >= {low}", lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= low


def _number(low: float, high: float = math.inf, above: bool = False) -> Rule:
    words = f"a number {'>' if above else '>='} {low:g}" + (f" and <= {high:g}" if high < math.inf else "")
    return words, lambda v: (isinstance(v, (int, float)) and not isinstance(v, bool)
                             and (v > low if above else v >= low) and v <= high)


def _optional(rule: Rule) -> Rule:
    return f"null or {rule[0]}", lambda v: v is None or rule[1](v)


def _each(rule: Rule) -> Rule:
    return f"a list, each {rule[0]}", lambda v: isinstance(v, ListConfig | list) and all(rule[1](x) for x in v)


NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]*")  # stays one path component: no /, not . or ..
_NAME = ("a name of letters, digits, _, - and .", lambda v: isinstance(v, str) and NAME.fullmatch(v) is not None)
_TEXT = ("a text", lambda v: isinstance(v, str) and v != "")
_FLAG = ("true or false", lambda v: isinstance(v, bool))
_FRACTION = _number(0, 1)
_SHAPES = _optional(_whole(1))
_DOMAIN_VARIATIONS = ("null or a mapping {<domain>: {train|val|test: a whole number >= 1}}",
                      lambda v: v is None or isinstance(v, DictConfig) and all(
                          isinstance(splits, DictConfig) and all(s in SPLITS and _whole(1)[1](n) for s, n in splits.items())
                          for splits in v.values()))
_DOMAIN_EPOCHS = ("null or a mapping {<domain>: a whole number >= 1}",
                  lambda v: v is None or isinstance(v, DictConfig) and all(_whole(1)[1](n) for n in v.values()))
_CHANNELS = ("a list of whole numbers >= 1 and M (2x2 max-pool)",
             lambda v: isinstance(v, ListConfig) and all(x == "M" or _whole(1)[1](x) for x in v))

SETTINGS = {key: Setting(meaning, *rule) for key, (meaning, rule) in {
    "seed": ("seed of every random draw: sampling, clouds, sketch jitter, training", _whole(0)),
    "profile_name": ("the profile in use; names the data and runs folders", _NAME),
    "domains": ("domains the workflow fans out over; null: every program with a recipe",
                ("null or a list of domains", lambda v: v is None or _each(_NAME)[1](v))),
    "domain.name": ("the domain a step works on (choose it with domain=<name>)", _NAME),
    "paths.data": ("datasets: <data>/<domain>/<split>/", _TEXT),
    "paths.runs": ("trained models and evaluations: <runs>/<domain>/<variant>/", _TEXT),
    "paths.build": ("built programs (.blend) and their manifests", _TEXT),
    "paths.results": ("tables and the report: <results>/tables/, <results>/report/", _TEXT),
    **{f"data.variations.{split}": (f"{split} shapes per parameter class", _whole(1)) for split in SPLITS},
    "data.domain_variations": ("per-domain replacements of data.variations, {<domain>: {<split>: N}}: "
                               "more shapes for the domains that need them", _DOMAIN_VARIATIONS),
    **{f"data.max_shapes.{split}": (f"keep at most this many {split} shapes (an even spread)", _SHAPES)
       for split in SPLITS},
    "data.shards": ("shards per split: the export, sketch and points jobs of each split", _whole(1)),
    "data.points.surface": ("area-weighted surface samples before farthest point sampling", _whole(1)),
    "data.points.fps": ("farthest-point-sampled points per cloud (<= surface)", _whole(1)),
    "data.points.random": ("uniform random points per cloud", _whole(1)),
    "data.points.train_random": ("random points added to the FPS points of a training item (<= random)", _whole(0)),
    "data.sketch.size": ("sketch width and height in pixels", _whole(8)),
    "data.sketch.elevation": ("camera elevation, degrees above the horizon", _number(-90, 90)),
    "data.sketch.jitter": ("+- degrees of seeded camera jitter", _number(0, 45)),
    "data.sketch.cameras": ("cameras: {name, azimuth in degrees, train: true for the training views}",
                            ("a list of {name, azimuth, train}", lambda v: isinstance(v, ListConfig))),
    "model._target_": ("the LightningModule class to build", ("one of the project's model classes", _TEXT[1])),
    "model.variant": ("decoders: joint, separate, regression or huang (choose it with model=<variant>)", _NAME),
    "model.k": ("DGCNN neighbours per point", _whole(1)),
    "model.edge_channels": ("channels of the EdgeConv layers", _each(_whole(1))),
    "model.point_channels": ("DGCNN head width (embedding = 2 x this)", _whole(1)),
    "model.sketch_channels": ("reduced VGG11 layers", _CHANNELS),
    "model.sketch_pool": ("adaptive average pooling grid before the sketch encoder's linear layer", _whole(1)),
    "model.hidden": ("widths of each decoder's hidden layers", _each(_whole(1))),
    "model.dropout": ("decoder dropout probability", _number(0, 1)),
    "model.embedding_norm": ("a BatchNorm per modality on the encoders' embeddings", _FLAG),
    "model.fast": ("the fast exact EdgeConv (false: the reference implementation)", _FLAG),
    "train.max_epochs": ("training epochs", _whole(1)),
    "train.domain_epochs": ("per-domain replacements of train.max_epochs, {<domain>: N}: "
                            "more epochs for the domains that need them", _DOMAIN_EPOCHS),
    "train.batch_size": ("items per batch", _whole(1)),
    "train.lr": ("Adam learning rate", _number(0, above=True)),
    "train.step_size": ("StepLR period, in epochs", _whole(1)),
    "train.gamma": ("StepLR factor", _number(0, 1, above=True)),
    "train.accelerator": ("Lightning accelerator: auto, cpu, gpu, cuda or mps",
                          ("auto, cpu, gpu, cuda or mps", lambda v: v in ("auto", "cpu", "gpu", "cuda", "mps"))),
    "train.devices": ("Lightning devices: auto or a count",
                      ("auto or a whole number >= 1", lambda v: v == "auto" or _whole(1)[1](v))),
    "train.deterministic": ("deterministic torch algorithms (slower)", _FLAG),
    "train.num_workers": ("data loader worker processes", _whole(0)),
    "train.limit_train_batches": ("null: all; a fraction (<= 1.0) or a count of batches per epoch",
                                  _optional(_number(0, above=True))),
    "train.schedule": ("learning-rate schedule: step (StepLR, the paper's) or cosine (warmup, then cosine decay)",
                       ("step or cosine", lambda v: v in ("step", "cosine"))),
    "train.warmup_epochs": ("epochs of linear warmup before the cosine decay", _whole(0)),
    **{f"train.variant_epochs.{v}": (f"{v}'s share of max_epochs", _number(0, 1, above=True))
       for v in ("joint", "separate", "regression", "huang")},
    "train.modalities": ("the inputs trained on: points, sketch or both",
                         ("a list of points and/or sketch", lambda v: isinstance(v, ListConfig | list) and len(v) > 0
                          and all(m in ("points", "sketch") for m in v))),
    "train.augment_points.jitter": ("Gaussian jitter of training clouds (std, unit-sphere units)", _number(0, 0.1)),
    "train.augment_points.scale": ("per-axis scaling of training clouds: factors in [1-s, 1+s]", _number(0, 0.5)),
    "train.augment_points.dropout": ("share of a training cloud's points replaced by copies", _number(0, 0.9)),
    "train.limit_val_batches": ("null: all; a fraction (<= 1.0) or a count of validation batches",
                                _optional(_number(0, above=True))),
    "train.log_every_n_steps": ("steps between logged training losses", _whole(1)),
    "train.progress_bar": ("null: only on an interactive terminal", ("null, true or false", lambda v: v is None or _FLAG[1](v))),
    "train.out_dir": ("run folder; null: <paths.runs>/<domain>/<model.variant>", _optional(_TEXT)),
    "train.eval_camera": ("validation camera; null: the first training camera", _optional(_NAME)),
    "train.augment.flip": ("probability of a horizontal flip of a training sketch", _FRACTION),
    "train.augment.dilate": ("probability of stroke dilation", _FRACTION),
    "train.augment.erode": ("probability of stroke erosion", _FRACTION),
    "train.augment.kernel": ("dilation / erosion kernel size in pixels", _whole(1)),
    "eval.chamfer_points": ("surface points per mesh for the Chamfer distance", _whole(1)),
    "eval.simplify": ("decimation factors of the test meshes (keep 1/f of the faces)", _each(_whole(2))),
    "eval.noise": ("Gaussian noise sigmas on the unit-sphere clouds", _each(_number(0))),
    "eval.sparse": ("point counts of the sparse random clouds", _each(_whole(1))),
    "eval.decode": ("how a continuous parameter's class is read from its classification head: argmax "
                    "(the paper's) or median (of the predicted distribution)",
                    ("argmax or median", lambda v: v in ("argmax", "median"))),
    "eval.max_test_shapes": ("evaluate on at most this many test shapes; null: all", _SHAPES),
    "eval.variants": ("model variants the workflow trains and evaluates", _each(_NAME)),
    "eval.ablations": ("decoder ablations trained for the ablation domains", _each(_NAME)),
    "eval.ablation_domains": ("domains whose ablations are trained (the paper: the chair)", _each(_NAME)),
    "eval.fit_budget": ("program evaluations of a fit (`geocode reconstruct --refine`, eval.fit)", _whole(0)),
    "eval.fit": ("point-cloud test conditions (pc, pc-noise0.02, ...) whose predictions are also fitted: "
                 "a '+ fit' row or column", _each(_NAME)),
}.items()}


MAPPINGS = {"data.domain_variations", "train.domain_epochs"}  # settings whose value is a whole mapping (its keys are domains)


def flat(cfg: DictConfig, prefix: str = "") -> dict[str, object]:
    """Every setting by its dotted key; lists, null groups and MAPPINGS are values."""
    out = {}
    for key, value in cfg.items():
        path = f"{prefix}{key}"
        if isinstance(value, DictConfig) and path not in MAPPINGS:
            out.update(flat(value, f"{path}."))
        else:
            out[path] = value
    return out


def validate(cfg: DictConfig) -> None:
    """Fail before any work, naming the key, on a value that cannot be right."""
    values = flat(cfg)
    for key, setting in SETTINGS.items():
        if key not in values and key.startswith("model."):
            continue    # a model config sets only what its network takes (huang: no point keys)
        if key not in values:
            raise ConfigError(key, "missing (a group above it was replaced by a value)", f"give {setting.expect}")
        if not setting.ok(values[key]):
            raise ConfigError(f"{key}={values[key]}", "out of range", f"give {setting.expect}")
    pts = cfg.data.points
    if not pts.fps <= pts.surface or not pts.train_random <= pts.random:
        raise ConfigError("data.points", "need fps <= surface and train_random <= random", "lower fps or train_random")
    _check_cameras(cfg.data.sketch.cameras)
    _check_known(cfg)


def _check_cameras(cameras) -> None:
    for i, camera in enumerate(cameras):
        ok = (isinstance(camera, DictConfig) and _NAME[1](camera.get("name"))
              and _number(-360, 360)[1](camera.get("azimuth")) and isinstance(camera.get("train", False), bool))
        if not ok:
            raise ConfigError(f"data.sketch.cameras[{i}]={camera}", "not a camera",
                              "give {name: <a plain name>, azimuth: <degrees>, train: true|false}")
    names = [c.name for c in cameras]
    if len(set(names)) != len(names) or not any(c.get("train", False) for c in cameras):
        raise ConfigError("data.sketch.cameras", "camera names repeat or none has train: true",
                          "give unique names and at least one training camera")


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
    for key in ("data.domain_variations", "train.domain_epochs"):
        for name in OmegaConf.select(cfg, key) or {}:
            if name not in {*known, *shipped}:
                raise ConfigError(f"{key}.{name}", "no such domain", f"use one of {', '.join(known) or 'none'}")
    variants = group_options("model")
    for key, names in (("model.variant", [cfg.model.variant]), ("eval.variants", cfg.eval.variants),
                       ("eval.ablations", cfg.eval.ablations)):
        for name in names:
            if name not in variants:
                raise ConfigError(f"{key}={name}", "unknown model variant", f"use one of {', '.join(variants)}")
    targets = {t for name in variants for t in _targets(OmegaConf.load(repo_root() / "conf" / "model" / f"{name}.yaml"))}
    for target in _targets(cfg):
        if target not in targets:
            raise ConfigError(f"_target_={target}", "not one of the project's model classes",
                              f"use {', '.join(sorted(targets))} (choose the variant with model=<name>)")
    _check_fit(cfg)
    camera = cfg.train.eval_camera
    if camera is not None and camera not in [c.name for c in cfg.data.sketch.cameras if c.get("train", False)]:
        raise ConfigError(f"train.eval_camera={camera}", "not a training camera", "name one with train: true, or null")


def _check_fit(cfg: DictConfig) -> None:
    from geocode.conditions import conditions

    clouds = [c["condition"] for c in conditions(cfg) if c["modality"] == "pc"]
    for name in cfg.eval.fit:
        if name not in clouds:
            raise ConfigError(f"eval.fit={name}", "not a point-cloud test condition", f"use some of {', '.join(clouds)}")


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


def describe_keys(cfg: DictConfig) -> str:
    """`geocode config --keys`: the groups with their choices, then every key with its value
    in `cfg` (the defaults, or with the overrides given) and its meaning."""
    groups = {p.name: group_options(p.name) for p in (repo_root() / "conf").iterdir() if p.is_dir()}
    groups["domain"] = registry()
    lines = ["groups (choose with <group>=<choice>):"]
    lines += [f"  {g:<10} {', '.join(options)}" for g, options in sorted(groups.items())]
    lines.append("keys (set with key=value):")
    for key, value in flat(cfg).items():
        setting = SETTINGS.get(key)
        about = f"{setting.meaning}; {setting.expect}" if setting else "(not documented)"
        shown = json.dumps(OmegaConf.to_container(value) if isinstance(value, ListConfig | DictConfig) else value)
        lines.append(f"  {key:<26} {shown.strip(chr(34)):<10} {about}")
    return "\n".join(lines)


def config_hash(cfg: DictConfig) -> str:
    """A short hash of the resolved config, written beside outputs it made."""
    text = OmegaConf.to_yaml(cfg, resolve=True, sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:10]


def domains(cfg: DictConfig) -> list[str]:
    """The domains the workflow runs: `domains` from config, or every domain in the registry."""
    return list(cfg.domains) if cfg.domains else registry()


def variants(cfg: DictConfig, domain: str) -> list[str]:
    """The model variants trained for a domain: eval.variants, and eval.ablations where the
    domain is one of eval.ablation_domains."""
    ablations = cfg.eval.ablations if domain in cfg.eval.ablation_domains else []
    return list(dict.fromkeys([*cfg.eval.variants, *ablations]))


def split_variations(cfg: DictConfig, domain: str) -> dict[str, int]:
    """Shapes per parameter class of each split: data.variations, with the domain's entries
    in data.domain_variations in their place (null: none)."""
    return {**cfg.data.variations, **(cfg.data.domain_variations or {}).get(domain, {})}


def max_epochs(cfg: DictConfig, variant: str, domain: str | None = None) -> int:
    """The domain's epochs (train.max_epochs, or its entry in train.domain_epochs) times the
    variant's share in train.variant_epochs (baselines and ablations trained beside the joint
    model on a smaller budget). domain: cfg.domain.name unless given."""
    epochs = (cfg.train.domain_epochs or {}).get(cfg.domain.name if domain is None else domain, cfg.train.max_epochs)
    share = float(cfg.train.variant_epochs.get(variant, 1.0))
    return max(1, round(int(epochs) * share))
