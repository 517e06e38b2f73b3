# Config and helpers common to all rules. Snakemake owns paths; Hydra owns everything else:
# each --config key=value is handed to every step as the same Hydra override.
import os
import shlex
import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError

from geocode.config import ConfigError, compose, config_hash, domains, programs_dir, variants

envvars:
    "PATH",


# Rules call the `geocode` command of the environment that runs Snakemake.
os.environ["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"


def as_overrides(key, value):
    """Hydra overrides from one --config entry. Snakemake keys cannot hold dots, so a nested
    key is given as YAML: --config train='{max_epochs: 5}' becomes train.max_epochs=5."""
    if isinstance(value, dict):
        return [o for k, v in value.items() for o in as_overrides(f"{key}.{k}", v)]
    if isinstance(value, bool):
        value = str(value).lower()
    elif isinstance(value, (list, tuple)):
        value = "[" + ",".join(str(v) for v in value) + "]"
    elif value is None:
        value = "null"
    return [f"{key}={value}"]


OVERRIDES = [o for k, v in {"profile": "mini", **config}.items() for o in as_overrides(k, v)]
try:
    CFG = compose(OVERRIDES)
except ConfigError as exc:
    raise WorkflowError(f"--config: {exc}") from None

CONFIG_HASH = config_hash(CFG)
DOMAINS = domains(CFG)
SPLITS = ["train", "val", "test"]
SHARDS = list(range(CFG.data.shards))
DATA = CFG.paths.data
RUNS = CFG.paths.runs
BUILD = CFG.paths.build
# A job logs under logs/<the folder it writes or, for tables and report, reads>: logs/data/mini/
# sketch/, logs/runs/mini/train/; an experiment with its own paths.runs keeps its own logs.
PROGRAMS = programs_dir()
# (domain, variant) of every model trained: eval.variants for each domain, plus its ablations.
RUNS_TRAINED = [(d, v) for d in DOMAINS for v in variants(CFG, d)]
# A GPU per training job where the config asks for one (accelerator=auto declares none).
GPUS = 1 if CFG.train.accelerator in ("gpu", "cuda") else 0

wildcard_constraints:
    domain="|".join(DOMAINS) or "none",
    split=r"train|val|test|test-s\d+",
    factor=r"\d+",
    variant="|".join({v for _, v in RUNS_TRAINED}) or "none",
    shard=r"\d+",


def step_args(domain):
    """The Hydra overrides every step of this domain gets, shell-quoted."""
    return " ".join(shlex.quote(o) for o in [*OVERRIDES, f"domain={domain}"])


def manifest(domain):
    return f"{BUILD}/programs/{domain}.manifest.json"


def done_files(stage, domain, splits=SPLITS):
    return [f"{DATA}/{domain}/{split}/done/{stage}-{shard}.txt" for split in splits for shard in SHARDS]


def eval_inputs(domain):
    """Sketches and clouds of the test split and of its simplified copies."""
    splits = ["test"] + [f"test-s{f}" for f in CFG.eval.simplify]
    return done_files("sketch", domain, splits) + done_files("points", domain, splits)
