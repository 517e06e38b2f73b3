# Config and helpers common to all rules. Every path comes from geocode.paths, the layout the
# Python steps use too; each --config key=value is handed to every step as the same Hydra override.
import os
import re
import shlex
import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError

from geocode import paths
from geocode.config import ConfigError, compose, domains, max_epochs, training_key, variants
from geocode.errors import UserError
from geocode.reconstruct.collection import collections, real_collections

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


# Keys of the workflow alone, not of conf/: the collections and real shapes of rules/reconstruct.smk.
WORKFLOW_KEYS = ("reconstruct", "real")
OVERRIDES = [o for k, v in {"profile": "mini", **config}.items() if k not in WORKFLOW_KEYS for o in as_overrides(k, v)]
try:
    CFG = compose(OVERRIDES)
except ConfigError as exc:
    raise WorkflowError(f"--config: {exc}") from None

DOMAINS = domains(CFG)
SHARDS = list(range(CFG.data.shards))
# (domain, variant) of every model trained: eval.variants for each domain, plus its ablations.
RUNS_TRAINED = [(d, v) for d in DOMAINS for v in variants(CFG, d)]
# A GPU per training job where the config asks for one (accelerator=auto declares none).
GPUS = 1 if CFG.train.accelerator in ("gpu", "cuda") else 0
# The results of this profile: results/ for the default one, results/<profile>/ for the others.
TABLES = str(paths.tables_dir(CFG))
REPORT = str(paths.report_index(CFG))

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
    return str(paths.manifest_path(CFG, domain))


def split_folder(domain, name):
    """The folder of one split of a domain's dataset (wildcards stay wildcards)."""
    return paths.split_dir(CFG, domain, name)


def done_files(stage, domain, splits=paths.SPLITS):
    return [str(paths.done_file(split_folder(domain, s), stage, shard)) for s in splits for shard in SHARDS]


def eval_inputs(domain):
    """Sketches and clouds of the test split and of its simplified copies."""
    splits = ["test"] + [paths.simplified_split(f) for f in CFG.eval.simplify]
    return done_files("sketch", domain, splits) + done_files("points", domain, splits)


def run_folder(domain, variant):
    return paths.run_dir(CFG, domain, variant)


def best_checkpoint(domain, variant):
    return str(paths.checkpoint_file(run_folder(domain, variant)))


def predictions(domain, variant):
    return str(paths.predictions_file(run_folder(domain, variant)))


def rebuilt_done(domain, variant, shard):
    return str(paths.rebuilt_done(paths.rebuilt_dir(predictions(domain, variant)), shard))


def metrics(domain, variant):
    return str(paths.metrics_file(run_folder(domain, variant)))


def log_path(folder, rule, name=None):
    """A job logs under logs/<the folder it writes or, for tables and report, reads>:
    logs/data/mini/sketch/, logs/runs/mini/train/; an experiment with its own paths.runs keeps
    its own logs."""
    return str(paths.log_file(folder, rule, name))


def training_threads(wildcards):
    """Half the cores: two trainings side by side at one thread each finish 20% sooner than
    one after the other at two (docs/design.md#training-threads). A cluster run gives no --cores
    (each job gets its own node): there a training asks for 2."""
    try:
        return max(1, workflow.cores // 2)
    except WorkflowError:
        return 2


# Job order on a few cores (docs/design.md#job-order): a domain's data one domain after the other,
# the longest-training domain first, so that its training starts within minutes; a training as soon
# as its data is there, the joint model's before the others; evaluation fills the gaps.
DATA_ORDER = sorted(DOMAINS, key=lambda d: max_epochs(CFG, "joint", d))


def data_priority(wildcards):
    return 10 + DATA_ORDER.index(wildcards.domain)


def training_priority(wildcards):
    return 100 + (1 if wildcards.variant == "joint" else 0)


def dataset_priority(wildcards):
    """Above the trainings it unlocks: at the evaluation's priority (0) it would wait behind
    every ready evaluation job, and the domain's trainings with it (docs/design.md#job-order)."""
    return 102


def training_settings(wildcards):
    """Everything a model depends on, epochs included (`config.training_key`): a param of the
    train rule, so that Snakemake retrains when a profile's YAML changes, not only when the
    command line's overrides do (the train step then sets the old run aside)."""
    cfg = compose([*OVERRIDES, f"domain={wildcards.domain}", f"model={wildcards.variant}"])
    return training_key(cfg, epochs=True)


# -- collections of a user's own files (rules/reconstruct.smk) ------------------------------------

try:
    COLLECTIONS = collections(config.get("reconstruct"), DOMAINS, lambda name: paths.collection_dir(CFG, name),
                              lambda name: paths.collection_work(CFG, name))
    # --config real: a collection per domain, for the real-shape table (rules/reconstruct.smk)
    REAL = real_collections(config.get("real"), DOMAINS, lambda name: paths.collection_dir(CFG, name),
                            lambda name: paths.collection_work(CFG, name))
except UserError as exc:
    raise WorkflowError(f"--config {exc}") from None
COLLECTIONS.update(REAL)


def requested(path):
    """Whether the command line that started Snakemake names `path` as a target (the
    workflow's own settings do not hold the targets while the Snakefile is read)."""
    return any(Path(a) == Path(path) for a in sys.argv[1:] if not a.startswith("-"))


if not REAL and requested(paths.real_shapes_dir(CFG)):
    raise WorkflowError(f"{paths.real_shapes_dir(CFG)}: --config real names no folder; give "
                        "real='{chair: path/to/chairs, vase: path/to/vases}'")

COLLECTION_NAMES = "|".join(re.escape(name) for name in COLLECTIONS) or "none"


def collection_work(name):
    return paths.collection_work(CFG, name)


def collection_batches(name):
    """The record of each batch of a collection."""
    return [str(paths.collection_batch_file(collection_work(name), b)) for b in range(len(COLLECTIONS[name].batches()))]


def collection_args(name):
    """The arguments both steps take: the collection's domain, folder, folders and batch size."""
    c = COLLECTIONS[name]
    args = [c.domain, str(c.inputs), "-o", str(paths.collection_dir(CFG, name)), "--work", str(collection_work(name)),
            "--batch-size", str(c.batch), *(["--recursive"] if c.recursive else [])]
    return " ".join(shlex.quote(a) for a in args)


def real_shapes_records():
    """`--records <domain> <batch record>...` of each folder of --config real."""
    return " ".join(shlex.quote(a) for name, c in REAL.items()
                    for a in ["--records", c.domain, *collection_batches(name)])
