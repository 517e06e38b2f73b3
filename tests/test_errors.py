"""Every mistake a user can make, and every fault of the environment, ends in one line on
stderr (`geocode: <file or key>: <problem>; <fix>`), a known exit code, and nothing left behind.

One table of command lines run in-process (each case: the arguments, the words the line must
hold, the paths that must not exist afterwards), one of file readers, and signals sent to
real processes.
"""

from __future__ import annotations

import logging
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from geocode.cli import main
from geocode.errors import UserError
from geocode.paths import PROGRAMS_ENV, repo_root

LOG_LINE = re.compile(r"\d\d:\d\d:\d\d ")  # progress lines of the logging module, not errors


@dataclass
class Case:
    args: list[str]              # "{tmp}" and "{build}" stand for the test's folders
    words: list[str]             # the one line must hold each of these
    absent: list[str] = field(default_factory=list)   # paths (under tmp) that must not exist after
    setup: str = ""              # the name of a function below that prepares tmp
    programs: str = ""           # a programs folder under tmp ($GEOCODE_PROGRAMS)
    code: int = 2


def override(*keys: str) -> list[str]:
    return ["config", *keys]


CONFIG_CASES = {
    "epochs negative": (override("train.max_epochs=-1"), ["train.max_epochs=-1", ">= 1"]),
    "epochs zero": (override("train.max_epochs=0"), ["train.max_epochs=0"]),
    "epochs fraction": (override("train.max_epochs=1.5"), ["train.max_epochs=1.5", "whole number"]),
    "epochs text": (override("train.max_epochs=abc"), ["train.max_epochs=abc"]),
    "batch zero": (override("train.batch_size=0"), ["train.batch_size=0"]),
    "lr zero": (override("train.lr=0"), ["train.lr=0", "> 0"]),
    "lr negative": (override("train.lr=-0.1"), ["train.lr=-0.1"]),
    "gamma zero": (override("train.gamma=0"), ["train.gamma=0"]),
    "gamma above one": (override("train.gamma=2"), ["train.gamma=2"]),
    "step size zero": (override("train.step_size=0"), ["train.step_size=0"]),
    "workers negative": (override("train.num_workers=-1"), ["train.num_workers=-1"]),
    "limit batches zero": (override("train.limit_train_batches=0"), ["train.limit_train_batches=0"]),
    "accelerator": (override("train.accelerator=tpu"), ["train.accelerator=tpu", "auto, cpu"]),
    "flip probability": (override("train.augment.flip=2"), ["train.augment.flip=2"]),
    "eval camera untrained": (override("train.eval_camera=az15"), ["train.eval_camera=az15", "training camera"]),
    "shards zero": (override("data.shards=0"), ["data.shards=0"]),
    "variations zero": (override("data.variations.train=0"), ["data.variations.train=0"]),
    "max shapes zero": (override("data.max_shapes.test=0"), ["data.max_shapes.test=0"]),
    "domain variations unknown domain": (override("+data.domain_variations.nosuch.train=3"),
                                         ["data.domain_variations.nosuch", "no such domain", "vase"]),
    "domain epochs unknown domain": (override("+train.domain_epochs.nosuch=3"),
                                     ["train.domain_epochs.nosuch", "no such domain", "vase"]),
    "domain epochs zero": (override("train.domain_epochs={vase: 0}"), ["train.domain_epochs", "whole number >= 1"]),
    "sketch fit branches unknown domain": (override("+eval.sketch_fit_branches.nosuch=3"),
                                           ["eval.sketch_fit_branches.nosuch", "no such domain", "vase"]),
    "sketch fit orders unknown domain": (override("+eval.sketch_fit_orders.nosuch=2"),
                                         ["eval.sketch_fit_orders.nosuch", "no such domain", "vase"]),
    "sketch fit orders three": (override("eval.sketch_fit_orders={vase: 3}"), ["eval.sketch_fit_orders", "1 or 2"]),
    "sketch fit budget unknown domain": (override("+eval.sketch_fit_domain_budget.nosuch=3"),
                                         ["eval.sketch_fit_domain_budget.nosuch", "no such domain", "vase"]),
    "domain variations zero": (override("data.domain_variations={vase: {train: 0}}"),
                               ["data.domain_variations", "whole number >= 1"]),
    "domain variations new key": (override("data.domain_variations.table.train=3"),
                                  ["data.domain_variations.table.train", "++data.domain_variations.<key>"]),
    "surface zero": (override("data.points.surface=0"), ["data.points.surface=0"]),
    "fps above surface": (override("data.points.fps=40000"), ["data.points", "fps <= surface"]),
    "sketch size": (override("data.sketch.size=0"), ["data.sketch.size=0"]),
    "elevation": (override("data.sketch.elevation=100"), ["data.sketch.elevation=100"]),
    "jitter negative": (override("data.sketch.jitter=-1"), ["data.sketch.jitter=-1"]),
    "camera name escapes": (override('data.sketch.cameras=[{name:"../x",azimuth:1,train:true}]'),
                            ["data.sketch.cameras[0]", "not a camera"]),
    "no training camera": (override("data.sketch.cameras=[{name:a,azimuth:1,train:false}]"),
                           ["data.sketch.cameras", "training camera"]),
    "noise negative": (override("eval.noise=[-0.1]"), ["eval.noise=[-0.1]"]),
    "decode unknown": (override("eval.decode=mode"), ["eval.decode=mode", "argmax, median or mean"]),
    "sparse zero": (override("eval.sparse=[0]"), ["eval.sparse=[0]"]),
    "simplify one": (override("eval.simplify=[1]"), ["eval.simplify=[1]"]),
    "chamfer points": (override("eval.chamfer_points=0"), ["eval.chamfer_points=0"]),
    "test shapes zero": (override("eval.max_test_shapes=0"), ["eval.max_test_shapes=0"]),
    "dropout": (override("model.dropout=1.5"), ["model.dropout=1.5"]),
    "k zero": (override("model.k=0"), ["model.k=0"]),
    "seed negative": (override("seed=-1"), ["seed=-1"]),
    "target builtin": (override("model._target_=builtins.print"), ["_target_=builtins.print", "model classes"]),
    "nested target": (override("+model.extra._target_=os.system"), ["_target_=os.system"]),
    "variant escapes": (override("model.variant=../../evil"), ["model.variant=../../evil"]),
    "eval variant": (override("eval.variants=[joint,bogus]"), ["eval.variants=bogus", "joint"]),
    "domain escapes": (override("domain.name=../../x"), ["domain.name=../../x", "a name of letters"]),
    "unknown domain": (override("domains=[nosuch]"), ["domains=nosuch", "vase"]),
    "profile name escapes": (override("profile_name=../x"), ["profile_name=../x"]),
    "unknown profile": (override("profile=huge"), ["profile", "config --keys"]),
    "unknown key": (override("data.nonsense=1"), ["nonsense", "config --keys"]),
    "broken interpolation": (override("train.max_epochs=${oops}"), ["train.max_epochs", "oops", "config --keys"]),
    "override without key": (override("=3"), ["conf/", "config --keys"]),
    "group replaced by a value": (override("train.augment=3"), ["train.augment.flip", "missing"]),
    "group replaced by null": (override("data.points=null"), ["data.points.surface", "missing"]),
    "split counts replaced": (override("data.variations=5"), ["data.variations.train", "missing"]),
}

USAGE_CASES = {
    "no command": ([], ["command"]),
    "unknown command": (["frobnicate"], ["frobnicate"]),
    "program escapes": (["program", "show", "../../x/evil"], ["invalid choice", "../../x/evil"]),
    "unknown program": (["program", "show", "nosuch"], ["nosuch", "vase"]),
    "build unknown program": (["program", "build", "nosuch", "-o", "{tmp}/x.blend"], ["nosuch"]),
    "shape unknown program": (["shape", "nosuch", "-o", "{tmp}/x.obj"], ["nosuch"]),
    "gallery n zero": (["gallery", "vase", "-o", "{tmp}/g.png", "-n", "0"], ["-n", "'0'", ">= 1"]),
    "gallery n negative": (["gallery", "vase", "-o", "{tmp}/g.png", "-n", "-3"], ["-n"]),
    "gallery n text": (["gallery", "vase", "-o", "{tmp}/g.png", "-n", "many"], ["'many'"]),
    "gallery seed negative": (["gallery", "vase", "-o", "{tmp}/g.png", "--seed", "-1"], ["--seed", ">= 0"]),
    "bench n zero": (["bench", "program", "vase", "-n", "0"], ["-n"]),
    "gallery n unbounded": (["gallery", "chair", "-o", "{tmp}/g.png", "-n", "100000000"],
                            ["-n", "at most 256 shapes", "too tall to view"]),
    "interpolate steps unbounded": (["interpolate", "vase", "{tmp}/a.yaml", "{tmp}/b.yaml", "--steps", "1000",
                                     "-o", "{tmp}/seq"], ["--steps", "at most 64 shapes", "too wide"]),
    "interpolate one step": (["interpolate", "vase", "{tmp}/a.yaml", "{tmp}/b.yaml", "--steps", "1",
                              "-o", "{tmp}/seq"], ["--steps", ">= 2"]),
    "budget unbounded": (["reconstruct", "vase", "{tmp}/x.obj", "-o", "{tmp}/r", "--budget", "99999"],
                         ["--budget", "at most 5000 program evaluations"]),
    "budget negative": (["reconstruct", "vase", "{tmp}/x.obj", "-o", "{tmp}/r", "--budget", "-1"], ["--budget"]),
    "bench n unbounded": (["bench", "program", "vase", "-n", "10001"], ["-n", "at most 10000 shapes"]),
    "bench clouds unbounded": (["bench", "epoch", "--clouds", "100001"], ["--clouds", "at most 100000 clouds"]),
    "bench sketches unbounded": (["bench", "epoch", "--sketches", "200001"], ["--sketches", "at most 200000"]),
    "bench sketches per cloud": (["bench", "epoch", "--clouds", "1", "--sketches", "100"],
                                 ["--sketches 100", "more than 10 per cloud", "at most 10"]),
    "bench points unbounded": (["bench", "epoch", "--points", "100000"], ["--points", "at most 10000 points"]),
    "bench unknown benchmark": (["bench", "everything"], ["everything"]),
    "bench unknown domain": (["bench", "program", "nosuch"], ["nosuch"]),
    "bench device": (["bench", "epoch", "--device", "gpu", "--clouds", "1", "--sketches", "1"], ["--device gpu"]),
    "shard missing": (["export", "--split", "train"], ["--shard"]),
    "shard text": (["points", "--split", "train", "--shard", "one"], ["--shard", "'one'"]),
    "factor zero": (["simplify", "--factor", "0"], ["--factor"]),
}

OUTPUT_CASES = {
    "blend is a folder": (["program", "build", "vase", "-o", "{tmp}"], ["is a folder"]),
    "blend under a file": (["program", "build", "vase", "-o", "{tmp}/file.txt/x.blend"], ["file.txt is a file"]),
    "manifest is a folder": (["program", "build", "vase", "-o", "{tmp}/x.blend", "--manifest", "{tmp}"], ["is a folder"]),  # noqa: E501  (a table row)
    "shape is a folder": (["shape", "vase", "-o", "{tmp}"], ["is a folder"]),
    "shape png is a folder": (["shape", "vase", "-o", "{tmp}/x.obj", "--png", "{tmp}"], ["--png", "is a folder"]),
    "gallery is a folder": (["gallery", "vase", "-o", "{tmp}"], ["is a folder"]),
    "predictions is a folder": (["predict", "--checkpoint", "{tmp}/a.ckpt", "-o", "{tmp}"], ["is a folder"]),
    "metrics under a file": (["metrics", "--predictions", "{tmp}/p.parquet", "-o", "{tmp}/file.txt/m.parquet"],
                             ["file.txt is a file"]),
    "tables into a file": (["tables", "--metrics", "{tmp}/m.parquet", "-o", "{tmp}/file.txt"], ["is a file"]),
    "report into a file": (["report", "--metrics", "{tmp}/m.parquet", "-o", "{tmp}/file.txt"], ["is a file"]),
    "run folder is a file": (["train", "-o", "{tmp}/file.txt"], ["is a file"]),
    # Unwritable even as root (where os.access says yes to everything): nothing may be written first.
    "shape png under /proc": (["shape", "vase", "-o", "{tmp}/c.obj", "--png", "/proc/x.png"],
                              ["--png", "/proc/x.png", "cannot be written"]),
    "shape under /sys": (["shape", "vase", "-o", "/sys/c.obj"], ["/sys/c.obj", "cannot be written"]),
    "manifest under /proc": (["program", "build", "vase", "-o", "{tmp}/x.blend", "--manifest", "/proc/m.json"],
                             ["--manifest", "/proc/m.json"]),
    "gallery under /proc": (["gallery", "vase", "-o", "/proc/g.png"], ["/proc/g.png"]),
    "mix under a file": (["mix", "vase", "{tmp}/a.yaml", "{tmp}/b.yaml", "--take", "handle",
                          "-o", "{tmp}/file.txt/m.obj"], ["file.txt is a file"]),
    "interpolate into /proc": (["interpolate", "vase", "{tmp}/a.yaml", "{tmp}/b.yaml", "-o", "/proc/seq"],
                               ["/proc/seq", "cannot be written"]),
    "interpolate into a file": (["interpolate", "vase", "{tmp}/a.yaml", "{tmp}/b.yaml", "-o", "{tmp}/file.txt"],
                                ["is a file"]),
    "reconstruct into /sys": (["reconstruct", "vase", "{tmp}/x.obj", "-o", "/sys/out"], ["/sys/out", "cannot be written"]),  # noqa: E501  (a table row)
    "reconstruct under a file": (["reconstruct", "vase", "{tmp}/x.obj", "-o", "{tmp}/file.txt/out"],
                                 ["file.txt is a file"]),
    "addon under /proc": (["addon", "build", "-o", "/proc/a.zip"], ["/proc/a.zip"]),
    "tables under /proc": (["tables", "--metrics", "{tmp}/m.parquet", "-o", "/proc/tables"], ["/proc/tables"]),
}

DATA = ["paths.data={tmp}/data", "paths.runs={tmp}/runs", "paths.build={build}", "profile=smoke"]

STEP_CASES = {
    "split escapes": Case(["export", "--split", "../../../x", "--shard", "0", *DATA],
                          ["split '../../../x'", "train, val, test"], absent=["x", "data"]),
    "unknown split": Case(["sketch", "--split", "training", "--shard", "0", *DATA], ["split 'training'"]),
    "shard out of range": Case(["export", "--split", "train", "--shard", "99", *DATA],
                               ["--shard 99", "data.shards=1"], absent=["data"]),
    "shard negative": Case(["points", "--split", "val", "--shard", "-1", *DATA], ["--shard -1"]),
    "rebuild shard out of range": Case(["rebuild", "--predictions", "{tmp}/p.parquet", "--shard", "3", *DATA],
                                       ["--shard 3"]),
    "factor not evaluated": Case(["simplify", "--factor", "7", *DATA], ["split 'test-s7'"], absent=["data"]),
    "points before export": Case(["points", "--split", "train", "--shard", "0", *DATA],
                                 ["export-0.txt", "missing", "export step"], absent=["data/vase/train/points"]),
    "points of a NaN mesh": Case(["points", "--split", "train", "--shard", "0", *DATA],
                                 ["train-000000.obj", "NaN", "rerun the export step"], setup="nan_mesh",
                                 absent=["data/vase/train/points/train-000000.npz", "data/vase/train/done/points-0.txt"]),  # noqa: E501  (a table row)
    "points of an empty mesh": Case(["points", "--split", "train", "--shard", "0", *DATA],
                                    ["train-000000.obj", "rerun the export step"], setup="empty_mesh",
                                    absent=["data/vase/train/points/train-000000.npz"]),
    "sketch of a NaN mesh": Case(["sketch", "--split", "train", "--shard", "0", *DATA],
                                 ["train-000000.obj", "NaN"], setup="nan_mesh",
                                 absent=["data/vase/train/sketches/train-000000_az35.png",
                                         "data/vase/train/done/sketch-0.txt"]),
    "sample without manifest": Case(["sample", *DATA[:2], "paths.build={tmp}/nobuild"],
                                    ["vase.manifest.json", "build the program"], absent=["data"]),
    "sample with broken manifest": Case(["sample", *DATA[:2], "paths.build={tmp}/badbuild"],
                                        ["vase.manifest.json", "not readable JSON"], setup="broken_manifest",
                                        absent=["data"]),
    "train without data": Case(["train", "-o", "{tmp}/run", *DATA], ["recipes.parquet", "sample step"],
                               absent=["run"]),
    "train with a foreign class": Case(["train", "-o", "{tmp}/run", *DATA, "model._target_=builtins.print"],
                                       ["_target_=builtins.print"], absent=["run"]),
    "train on a GPU that is not there": Case(
        ["train", "-o", "{tmp}/run", "paths.data={tmp}/data", "paths.build={tmp}/build", "domain=toy", "domains=[toy]",
         "profile=smoke", "data.points.train_random=32", "train.accelerator=cuda", "train.devices=1"],
        ["train.accelerator=cuda", "choose what this machine has"], setup="toy_dataset", programs="programs",
        absent=["run"]),
    "predict without checkpoint": Case(["predict", "--checkpoint", "{tmp}/none.ckpt", "-o", "{tmp}/p.parquet", *DATA],
                                       ["none.ckpt", "not found"], absent=["p.parquet"]),
    "predict zero-byte checkpoint": Case(["predict", "--checkpoint", "{tmp}/zero.ckpt", "-o", "{tmp}/p.parquet", *DATA],
                                         ["zero.ckpt", "not a readable checkpoint"], setup="bad_files",
                                         absent=["p.parquet"]),
    "predict text checkpoint": Case(["predict", "--checkpoint", "{tmp}/text.ckpt", "-o", "{tmp}/p.parquet", *DATA],
                                    ["text.ckpt", "not a readable checkpoint"], setup="bad_files", absent=["p.parquet"]),  # noqa: E501  (a table row)
    "predict foreign checkpoint": Case(["predict", "--checkpoint", "{tmp}/dict.ckpt", "-o", "{tmp}/p.parquet", *DATA],
                                       ["dict.ckpt", "not a geocode model checkpoint"], setup="bad_files",
                                       absent=["p.parquet"]),
    "predict on another class grid": Case(["predict", "--checkpoint", "{tmp}/other.ckpt", "-o", "{tmp}/p.parquet", *DATA],  # noqa: E501  (a table row)
                                          ["other.ckpt", "trained on another recipe"], setup="other_grid",
                                          absent=["p.parquet"]),
    "predict on other class counts": Case(["predict", "--checkpoint", "{tmp}/old.ckpt", "-o", "{tmp}/p.parquet", *DATA],
                                          ["old.ckpt", "trained on another recipe"], setup="other_heads",
                                          absent=["p.parquet"]),
    "rebuild without predictions": Case(["rebuild", "--predictions", "{tmp}/none.parquet", "--shard", "0", *DATA],
                                        ["none.parquet", "file not found", "predict step"], absent=["rebuilt"]),
    "metrics of a broken parquet": Case(["metrics", "--predictions", "{tmp}/zero.parquet", "-o", "{tmp}/m.parquet", *DATA],  # noqa: E501  (a table row)
                                        ["zero.parquet", "not a readable parquet"], setup="bad_files",
                                        absent=["m.parquet"]),
    "rebuild of a foreign parquet": Case(["rebuild", "--predictions", "{tmp}/metrics.parquet", "--shard", "0", *DATA],
                                         ["metrics.parquet", "not a predictions file"], setup="bad_files",
                                         absent=["rebuilt"]),
    "rebuild of ids that escape": Case(["rebuild", "--predictions", "{tmp}/escape.parquet", "--shard", "0", *DATA],
                                       ["escape.parquet", "'../../../escaped'", "not a plain name"], setup="bad_files",
                                       absent=["escaped.obj", "rebuilt"]),
    "tables of a broken parquet": Case(["tables", "--metrics", "{tmp}/text.parquet", "-o", "{tmp}/tables", *DATA],
                                       ["text.parquet", "not a readable parquet", "metrics step"], setup="bad_files",
                                       absent=["tables"]),
    "shape with a bad value": Case(["shape", "vase", "height=tall", "-o", "{tmp}/x.obj"],
                                   ["'height=tall'", "name=number"], absent=["x.obj"]),
    "shape with an unknown parameter": Case(["shape", "vase", "no_such_parameter=1", "-o", "{tmp}/x.obj"],
                                            ["'no_such_parameter'", "geocode program show vase"], absent=["x.obj"]),
}

RECIPE = ["sample", "paths.data={tmp}/data", "paths.build={build}"]
RECIPE_CASES = {
    "recipe not UTF-8": (b"parameters:\n  body_height: {min: 0.6}\n# \xff\xfe\n", ["not UTF-8"]),
    "recipe complex key": (b"parameters:\n  ? [a, b]\n  : 1\n", ["is not a name"]),
    "recipe YAML syntax": (b"parameters: {body_height: [1, 2\n", ["not valid YAML"]),
    "recipe duplicate key": (b"parameters: {}\nparameters: {}\n", ["given twice"]),
    "recipe not a mapping": (b"- 1\n- 2\n", ["vase.yaml"]),
}


@pytest.fixture(autouse=True)
def fresh_logging():
    """main() sets up logging to the stderr of the moment: this test's captured one."""
    logging.root.handlers.clear()
    yield
    logging.root.handlers.clear()


def cli(args: list[str], tmp: Path, build: Path, capsys) -> tuple[int, str]:
    """Run the command line in this process: its exit code and its stderr less log lines."""
    argv = [a.replace("{tmp}", str(tmp)).replace("{build}", str(build)) for a in args]
    code = main(argv)
    err = capsys.readouterr().err
    return code, "\n".join(line for line in err.splitlines() if not LOG_LINE.match(line))


def assert_one_line(code: int, err: str, expected_code: int, words: list[str]) -> None:
    assert code == expected_code, err
    assert len(err.splitlines()) == 1 and err.startswith("geocode: ") and "Traceback" not in err, err
    missing = [w for w in words if w not in err]
    assert not missing, f"{missing} not in {err!r}"


@pytest.fixture(scope="module")
def build(tmp_path_factory) -> Path:
    """A build folder with the vase program's manifest (real Blender)."""
    folder = tmp_path_factory.mktemp("build")
    assert main(["program", "build", "vase", "-o", str(folder / "vase.blend"),
                 "--manifest", str(folder / "programs" / "vase.manifest.json")]) == 0
    return folder


@pytest.fixture
def tmp(tmp_path: Path) -> Path:
    (tmp_path / "file.txt").write_text("a file, not a folder\n")
    return tmp_path


@pytest.mark.parametrize("name", sorted({**CONFIG_CASES, **USAGE_CASES, **OUTPUT_CASES}))
def test_command_line_mistakes(name, tmp, capsys):
    args, words = {**CONFIG_CASES, **USAGE_CASES, **OUTPUT_CASES}[name]
    before = sorted(tmp.rglob("*"))
    code, err = cli(args, tmp, tmp, capsys)
    assert_one_line(code, err, 2, words)
    assert sorted(tmp.rglob("*")) == before          # nothing written


@pytest.mark.parametrize("name", sorted(STEP_CASES))
def test_step_mistakes(name, tmp, build, capsys, monkeypatch):
    case = STEP_CASES[name]
    if case.setup:
        SETUPS[case.setup](tmp, build)
    if case.programs:
        monkeypatch.setenv(PROGRAMS_ENV, str(tmp / case.programs))
    code, err = cli(case.args, tmp, build, capsys)
    assert_one_line(code, err, case.code, case.words)
    left = [p for p in case.absent if (tmp / p).exists()]
    assert not left, f"left behind: {left}"
    assert not list(tmp.rglob("*.tmp")), "a temporary file was left behind"


@pytest.mark.parametrize("name", sorted(RECIPE_CASES))
def test_recipe_file_mistakes(name, tmp, build, capsys, monkeypatch):
    text, words = RECIPE_CASES[name]
    (tmp / "programs").mkdir()
    (tmp / "programs" / "vase.py").symlink_to(repo_root() / "programs" / "vase.py")
    recipe = tmp / "programs" / "vase.yaml"
    recipe.write_bytes(text)
    monkeypatch.setenv(PROGRAMS_ENV, str(tmp / "programs"))
    code, err = cli(RECIPE, tmp, build, capsys)
    assert_one_line(code, err, 2, [str(recipe), *words])
    assert not (tmp / "data").exists()


def test_a_program_outside_the_programs_folder_is_never_imported(tmp, monkeypatch, capsys):
    programs = tmp / "a" / "b" / "programs"
    programs.mkdir(parents=True)
    (tmp / "a" / "x").mkdir()
    marker = tmp / "imported"
    (tmp / "a" / "x" / "evil.py").write_text(f"open({str(marker)!r}, 'w').close()\n")
    monkeypatch.setenv("GEOCODE_PROGRAMS", str(programs))
    code, err = cli(["program", "show", "../../x/evil"], tmp, tmp, capsys)
    assert_one_line(code, err, 2, ["../../x/evil"])
    assert not marker.exists()


def test_config_keys_lists_every_group_and_key_with_its_meaning(capsys):
    from geocode.settings import documented_keys

    assert main(["config", "--keys", "profile=smoke"]) == 0
    out = capsys.readouterr().out
    for group in ("domain", "model", "profile", "train"):
        assert re.search(rf"^  {group} +\S", out, re.M), group
    for key, (meaning, valid) in documented_keys().items():   # a key the models lack is refused
        assert meaning and valid, f"give {key} a meaning in geocode.settings"
        assert re.search(rf"^  {re.escape(key)} .* {re.escape(meaning)}; {re.escape(valid)}$", out, re.M), key
    assert "train.max_epochs" in out and "a whole number >= 1" in out


# -- files, where they are read -----------------------------------------------------------------

def nan_obj() -> str:
    return "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"


def file_readers():
    from geocode.meshio import read_obj, read_parquet
    from geocode.points import load_clouds
    from geocode.recipe import load_manifest, load_recipes
    from geocode.steps.train_data import load_sketch_u8

    return {
        "obj zero-byte": ("m.obj", b"", read_obj),
        "obj NaN vertex": ("m.obj", nan_obj().encode(), read_obj),
        "obj no faces": ("m.obj", b"v 0 0 0\nv 1 0 0\n", read_obj),
        "obj missing": ("m.obj", None, read_obj),
        "parquet zero-byte": ("p.parquet", b"", lambda p: read_parquet(p, "remake it")),
        "parquet garbage": ("p.parquet", b"PAR1 not really", lambda p: read_parquet(p, "remake it")),
        "recipes missing": ("recipes.parquet", None, load_recipes),
        "sketch zero-byte": ("s.png", b"", load_sketch_u8),
        "sketch garbage": ("s.png", b"\x89PNG\r\n\x1a\n broken", load_sketch_u8),
        "sketch missing": ("s.png", None, load_sketch_u8),
        "clouds zero-byte": ("c.npz", b"", load_clouds),
        "manifest not JSON": ("m.json", b"{", load_manifest),
        "manifest missing": ("m.json", None, load_manifest),
    }


@pytest.mark.parametrize("name", sorted(file_readers()))
def test_broken_files_are_refused_with_their_path(name, tmp_path):
    filename, data, read = file_readers()[name]
    path = tmp_path / filename
    if data is not None:
        path.write_bytes(data)
    with pytest.raises(UserError) as error:
        read(path)
    message = str(error.value)
    assert message.startswith(str(path)) and "\n" not in message and ";" in message


def test_a_rerun_redoes_broken_files_it_would_otherwise_skip(tmp_path):
    from geocode.blender.export import SUFFIXES, is_complete
    from geocode.blender.sketch import is_sketch
    from geocode.points import _complete

    for suffix in SUFFIXES:
        (tmp_path / f"a{suffix}").write_bytes(b"x")
    assert is_complete(tmp_path, "a")
    (tmp_path / "a.labels.yaml").write_bytes(b"")
    assert not is_complete(tmp_path, "a")
    png = tmp_path / "a.png"
    png.write_bytes(b"")
    assert not is_sketch(png)
    from PIL import Image

    Image.new("L", (8, 8), 255).save(png)
    assert is_sketch(png)
    png.write_bytes(png.read_bytes()[:30])            # cut short: a broken file
    assert not is_sketch(png)
    (tmp_path / "a.npz").write_bytes(b"")
    assert not _complete(tmp_path / "a.npz")


@pytest.mark.parametrize("target", ["{tmp}", "{tmp}/file.txt/x.txt"])
def test_writes_to_an_impossible_place_name_it(target, tmp):
    from geocode.meshio import write_text

    path = Path(target.format(tmp=tmp))
    with pytest.raises(UserError, match=re.escape(str(path))):
        write_text(path, "x")


# -- signals ----------------------------------------------------------------------------------------

def handlers_installed(pid: int) -> bool:
    """Whether the process catches SIGTERM (Python catches SIGINT from its start; SIGTERM only
    once geocode's handlers are in)."""
    caught = re.search(r"SigCgt:\s*([0-9a-f]+)", Path(f"/proc/{pid}/status").read_text()).group(1)
    return bool(int(caught, 16) >> (signal.SIGTERM - 1) & 1)


def blender_loading(pid: int) -> bool:
    """Whether Blender's library is mapped into the process (its start-up has begun)."""
    return "/bpy/" in Path(f"/proc/{pid}/maps").read_text()  # site-packages/bpy/, not libpython


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux's /proc to time the signal")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("moment", [handlers_installed, blender_loading])
def test_a_stop_signal_at_any_moment_ends_in_one_line(sig, moment):
    process = subprocess.Popen([sys.executable, "-m", "geocode.cli", "program", "show", "vase"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while process.poll() is None and time.time() < deadline and not moment(process.pid):
        time.sleep(0.005)
    process.send_signal(sig)
    _, err = process.communicate(timeout=120)
    assert process.returncode == 128 + sig, err[-2000:]
    assert err.strip() == f"geocode: stopped by {signal.Signals(sig).name}; rerun the same command to go on"


def test_a_signal_during_a_step_leaves_no_partial_file(tmp_path):
    """SIGTERM while the points step writes clouds: the done file is absent and every
    cloud present is complete."""
    import trimesh

    from geocode.meshio import write_obj

    split = tmp_path / "data" / "vase" / "train"
    ids = [f"train-{i:06d}" for i in range(40)]
    for shape_id in ids:
        write_obj(split / "shapes" / f"{shape_id}.obj", trimesh.creation.icosphere(subdivisions=3))
    (split / "done").mkdir()
    (split / "done" / "export-0.txt").write_text("".join(f"{i}\n" for i in ids))
    process = subprocess.Popen([sys.executable, "-m", "geocode.cli", "points", "--split", "train", "--shard", "0",
                                f"paths.data={tmp_path / 'data'}", "profile=smoke", "data.points.surface=200000"],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not list((split / "points").glob("*.npz")):
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143, err[-2000:]
    assert "Traceback" not in err and not (split / "done" / "points-0.txt").exists()
    assert not list(split.rglob("*.tmp"))
    for cloud in (split / "points").glob("*.npz"):
        with np.load(cloud) as data:
            assert set(data.files) == {"fps", "random"}


# -- set-ups of the step cases ------------------------------------------------------------------

def nan_mesh(tmp: Path, build: Path) -> None:
    split = tmp / "data" / "vase" / "train"
    (split / "shapes").mkdir(parents=True)
    (split / "shapes" / "train-000000.obj").write_text(nan_obj())
    (split / "done").mkdir()
    (split / "done" / "export-0.txt").write_text("train-000000\n")


def empty_mesh(tmp: Path, build: Path) -> None:
    nan_mesh(tmp, build)
    (tmp / "data" / "vase" / "train" / "shapes" / "train-000000.obj").write_bytes(b"")


def broken_manifest(tmp: Path, build: Path) -> None:
    (tmp / "badbuild" / "programs").mkdir(parents=True)
    (tmp / "badbuild" / "programs" / "vase.manifest.json").write_text('{"parameters": [')


def bad_files(tmp: Path, build: Path) -> None:
    (tmp / "zero.ckpt").write_bytes(b"")
    (tmp / "text.ckpt").write_text("not a checkpoint\n")
    torch.save({"weights": torch.zeros(2)}, tmp / "dict.ckpt")
    (tmp / "zero.parquet").write_bytes(b"")
    (tmp / "text.parquet").write_text("id,chamfer\n1,2\n")
    pd.DataFrame({"id": ["a"], "chamfer": [0.1]}).to_parquet(tmp / "metrics.parquet")
    keys = dict(condition="pc", modality="pc", source="test", camera="", noise=0.0, sparse=0)
    pd.DataFrame([{**keys, "id": "../../../escaped"}]).to_parquet(tmp / "escape.parquet")


def checkpoint(tmp: Path, build: Path, name: str, change) -> None:
    """A real (untrained) model of the vase recipe, saved as Lightning saves one, after
    `change` edits its checkpoint dictionary."""
    from geocode.config import compose
    from geocode.recipe import load_recipe
    from geocode.steps.train import build_model, recipe_stamp

    cfg = compose(["profile=smoke", f"paths.build={build}"])
    recipe = load_recipe(cfg)
    model = build_model(cfg, recipe)
    ckpt = {"state_dict": model.state_dict(), "hyper_parameters": dict(model.hparams), "recipe": recipe_stamp(recipe)}
    change(ckpt)
    torch.save(ckpt, tmp / name)


def other_grid(tmp: Path, build: Path) -> None:
    def shift(ckpt):
        name = next(iter(ckpt["recipe"]["grid"]))
        ckpt["recipe"]["grid"][name] = [v + 0.5 for v in ckpt["recipe"]["grid"][name] if v != "hidden"]

    checkpoint(tmp, build, "other.ckpt", shift)


def other_heads(tmp: Path, build: Path) -> None:
    def older(ckpt):                                  # from before the stamp, one class fewer
        del ckpt["recipe"]
        ckpt["hyper_parameters"]["heads"][0]["n_classes"] -= 1

    checkpoint(tmp, build, "old.ckpt", older)


def toy_dataset(tmp: Path, build: Path) -> None:
    from test_training_data import make_dataset

    _, _, recipe = make_dataset(tmp)
    recipe.with_suffix(".py").write_text("")  # registers the domain; training never runs it


SETUPS = {f.__name__: f for f in (nan_mesh, empty_mesh, broken_manifest, bad_files, other_grid, other_heads,
                                  toy_dataset)}


def test_a_stop_signal_wrapped_by_compiled_code_is_still_a_stop():
    """numba hands a signal handler's exception back as a SystemError caused by it."""
    from geocode.errors import Interrupted, interruption

    try:
        try:
            raise Interrupted(signal.SIGTERM)
        except Interrupted as stop:
            raise SystemError("CPUDispatcher(...) returned a result with an exception set") from stop
    except SystemError as wrapped:
        assert interruption(wrapped).signum == signal.SIGTERM
    assert interruption(SystemError("a real one")) is None
