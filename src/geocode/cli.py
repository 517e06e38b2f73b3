"""`geocode <command> ...`: the product's command line, and each workflow rule's entry point.

Pipeline steps take Hydra overrides (`key=value`) after their options, so that
`geocode train profile=smoke train.max_epochs=2` and the Snakefile compose the same config.
A user's mistake ends in one line on stderr, `<file or key>: <problem>; <fix>`, and exit code
2, never a traceback (set GEOCODE_DEBUG=1 to see one); Ctrl-C and SIGTERM end in one line and
exit code 130 / 143.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import signal
import sys
import textwrap
from pathlib import Path

from geocode.errors import Interrupted, UserError, import_blender, interruption, stop_signals_raise


def main(argv: list[str] | None = None) -> int:
    # Handlers first: a stop signal that arrives while Blender starts up must wait for it.
    with stop_signals_raise():
        try:
            args = parse(argv)
            logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s: %(message)s",
                                datefmt="%H:%M:%S", stream=sys.stderr)
            if args.run in BLENDER:
                import_blender()
            result = args.run(args)
            if result is not None:
                print(json.dumps(result) if getattr(args, "json", False) else format_result(result))
        except (UserError, Interrupted, KeyboardInterrupt) as exc:
            if os.environ.get("GEOCODE_DEBUG"):
                raise
            return report(exc)
        except SystemError as exc:   # a stop signal inside compiled code comes back wrapped
            if (stop := interruption(exc)) is None or os.environ.get("GEOCODE_DEBUG"):
                raise
            return report(stop)
        except BrokenPipeError:  # the reader left (`geocode config --keys | head`): not an error
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


def report(exc: UserError | Interrupted | KeyboardInterrupt) -> int:
    """One line on stderr for a user's mistake (exit 2) or a stop signal (exit 128 + signal)."""
    if isinstance(exc, UserError):
        print(f"geocode: {exc}", file=sys.stderr)
        return 2
    signum = exc.signum if isinstance(exc, Interrupted) else signal.SIGINT
    print(f"geocode: stopped by {signal.Signals(signum).name}; rerun the same command to go on", file=sys.stderr)
    return 128 + signum


class Parser(argparse.ArgumentParser):
    """argparse, with a usage mistake on one line like every other mistake."""

    def error(self, message):
        raise usage_error(self.prog, message)


def usage_error(prog: str, message: str) -> UserError:
    """A mistake in the use of the command `prog` ("geocode bench fit")."""
    return UserError(prog.partition(" ")[2] or "command line", message, f"see {prog} --help")


def parse(argv: list[str] | None) -> argparse.Namespace:
    """The command line; a step's `key=value` overrides may also stand after its options."""
    args, extra = parser().parse_known_args(argv)
    if extra and hasattr(args, "overrides") and all("=" in e and not e.startswith("-") for e in extra):
        args.overrides = [*args.overrides, *extra]
    elif extra:
        raise usage_error(args.prog, f"unrecognized arguments: {' '.join(extra)}")
    return args


def format_result(result) -> str:
    if isinstance(result, dict):
        return "\n".join(f"{k}: {v}" for k, v in result.items())
    return str(result)


def at_least(low: int):
    """An argument type: a whole number >= low."""
    def whole(text: str) -> int:
        if not text.isdigit() or int(text) < low:
            raise argparse.ArgumentTypeError(f"{text!r}: give a whole number >= {low}")
        return int(text)
    return whole


SKETCHES_PER_CLOUD = 10   # bench epoch: a step holds batch * sketches / clouds sketches on the device


def at_most(high: int, unit: str, why: str, low: int = 1):
    """An argument type: a whole number in low .. high; above it, the line says why."""
    whole = at_least(low)

    def bounded(text: str) -> int:
        if whole(text) > high:
            raise argparse.ArgumentTypeError(f"{text!r}: at most {high} {unit}; {why}")
        return int(text)
    return bounded


def output_file(text: str) -> Path:
    """An argument type: a file that can be written, tried for real before any work is done."""
    return writable(text, folder=False)


def output_folder(text: str) -> Path:
    return writable(text, folder=True)


def writable(text: str, folder: bool) -> Path:
    from geocode.outputs import check_writable

    try:
        return check_writable(text, folder)
    except UserError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


class Renamed(argparse.Action):
    """An option's old spelling: it still works, with a one-line notice on stderr, and is hidden
    from --help."""

    def __init__(self, option_strings, dest, new: str, **kwargs):
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"geocode: {option_string} is now {self.new}; the old name goes in the next release",
              file=sys.stderr)
        setattr(namespace, self.dest, values)


def renamed(c: argparse.ArgumentParser, old: str, new: argparse.Action) -> None:
    """`old` as a hidden spelling of the option `new` (the action add_argument returned)."""
    c.add_argument(old, dest=new.dest, type=new.type, action=Renamed, new="/".join(new.option_strings),
                   default=argparse.SUPPRESS)


def command(sub, name: str, help: str, *examples: str) -> argparse.ArgumentParser:
    """A subcommand, its --help closed by examples of its use."""
    c = sub.add_parser(name, help=help, description=textwrap.fill(help, 80),
                       epilog="examples:\n" + "".join(f"  {e}\n" for e in examples),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    c.set_defaults(prog=c.prog)    # whose --help a mistake points to
    return c


# The options every command spells the same way.
BUDGET = "program evaluations of the fit"


def budget_option(c, help: str) -> argparse.Action:
    return c.add_argument("--budget", metavar="N", type=at_most(5000, "program evaluations", "the fit's curve flattens "
                                                   "well before (docs/design.md#fit)", low=0), help=help)


def shapes_option(c, high: int, why: str, help: str, default: int | None = None) -> None:
    """-n/--shapes: how many shapes (the old --n still works)."""
    renamed(c, "--n", c.add_argument("-n", "--shapes", metavar="N", type=at_most(high, "shapes", why), default=default,
                                     help=help))


SPLIT_HELP = ("the shapes measured: val (the validation split, where defaults are chosen) or test "
              "(the shapes whose numbers the tables report; measure there only to report)")


def parser() -> argparse.ArgumentParser:
    from geocode.config import registry

    domains = registry()
    p = Parser(prog="geocode", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(required=True, metavar="command")

    c = command(sub, "programs", "list the programs with their parameter counts", "geocode programs")
    c.set_defaults(run=cmd_programs)

    program = command(sub, "program", "show or build one program",
                      "geocode program show vase", "geocode program build vase -o vase.blend")
    program = program.add_subparsers(required=True, metavar="action")
    c = command(program, "show", "parameters, ranges, classes and visibility rules",
                "geocode program show vase", "geocode program show chair --json")
    c.add_argument("domain", choices=domains)
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_program_show)
    c = command(program, "build", "write the program as a .blend (and its manifest)",
                "geocode program build vase -o vase.blend --manifest vase.manifest.json")
    c.add_argument("domain", choices=domains)
    c.add_argument("-o", "--output", required=True, type=output_file, help="the .blend to write")
    c.add_argument("--manifest", type=output_file, help="also write the parameter manifest (JSON)")
    c.set_defaults(run=cmd_program_build)

    c = command(sub, "shape", "evaluate a program at given values and write an OBJ",
                "geocode shape vase body_height=1.2 handle_count=2 -o vase.obj --png vase.png")
    c.add_argument("domain", choices=domains)
    c.add_argument("values", nargs="*", metavar="name=value")
    c.add_argument("-o", "--output", required=True, type=output_file)
    c.add_argument("--png", type=output_file, help="also render a picture of it")
    c.set_defaults(run=cmd_shape)

    c = command(sub, "gallery", "render random shapes (16 unless -n) into one PNG",
                "geocode gallery vase -o gallery.png", "geocode gallery chair -n 32 --seed 1 -o chairs.png")
    c.add_argument("domain", choices=domains)
    c.add_argument("-o", "--output", required=True, type=output_file)
    shapes_option(c, 256, "a sheet of more (4 to a row) is too tall to view", "shapes (default 16)", default=16)
    c.add_argument("--seed", type=at_least(0), default=0)
    c.set_defaults(run=cmd_gallery)

    c = command(sub, "reconstruct", "meshes, scans, point clouds or drawings -> parameters, meshes, .blend, "
                "a page", "geocode reconstruct chair scan.ply -o out/",
                "geocode reconstruct vase drawings/ -o out/ --budget 2000 --candidates 3 -j 2")
    c.add_argument("domain", choices=domains)
    c.add_argument("input", type=Path, help="a file or a folder of them: mesh (.obj .ply .stl .off .glb "
                                            ".gltf), cloud (.xyz .txt .pts .csv .npy .npz, .ply) or drawing "
                                            "(.png .jpg)")
    c.add_argument("-o", "--output", required=True, type=output_folder,
                   help="folder for <input>.yaml|obj|in-place.obj|png|blend, index.html and summary.csv; an "
                        "input keeps its suffix in its names (scan.obj -> scan-obj.*) where they would be another "
                        "input's or replace a file reconstruct did not write; a rerun replaces only its own files")
    c.add_argument("--recursive", action="store_true", help="a folder's subfolders too")
    c.add_argument("--checkpoint", type=Path, help="default: the domain's joint model of the run (paths.runs)")
    renamed(c, "--refine", budget_option(c, f"{BUDGET} (default eval.reconstruct_budget; a drawing's: "
                                            "the domain's eval.sketch_fit_budget; 0: the network's answer)"))
    c.add_argument("--up", default="auto", help="the input's up axis: auto (found), or x, y, z, -x, -y, -z")
    c.add_argument("--candidates", type=at_most(8, "answers", "more are rarely distinct", low=1), default=1,
                   help="write the K best distinct fitted programs (ranked on the page)")
    c.add_argument("-j", "--workers", metavar="N", type=at_most(64, "processes", "one per core is enough", low=1),
                   help="processes (default: one per core, at most 8): a file's fit shares its candidates "
                        "between them; a folder's files are spread over them, each reconstructing whole files")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_reconstruct)

    c = command(sub, "mix", "shape a with some parameters taken from shape b",
                "geocode mix vase a.yaml b.yaml --take handle lid -o mixed.obj")
    c.add_argument("domain", choices=domains)
    c.add_argument("a", type=Path, help="YAML of parameter values (e.g. a dataset shape)")
    c.add_argument("b", type=Path)
    c.add_argument("--take", required=True, nargs="+", metavar="NAME",
                   help="parameters to take from b: names, or the first word of a group (handle)")
    c.add_argument("-o", "--output", required=True, type=output_file, help="the OBJ (its YAML beside it)")
    c.set_defaults(run=cmd_mix)

    c = command(sub, "interpolate", "a sequence of shapes from a to b, and a strip PNG",
                "geocode interpolate chair a.yaml b.yaml --steps 6 -o morph/")
    c.add_argument("domain", choices=domains)
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    c.add_argument("--steps", type=at_most(64, "shapes", "a strip of more is too wide to view", low=2), default=6,
                   help="shapes from a to b, both included (2 .. 64)")
    c.add_argument("-o", "--output", required=True, type=output_folder, help="folder for step-NN.obj|yaml, strip.png")
    c.set_defaults(run=cmd_interpolate)

    addon = command(sub, "addon", "the building blocks as a Blender extension",
                    "geocode addon build -o geocode_nodes.zip").add_subparsers(required=True, metavar="action")
    c = command(addon, "build", "write the extension zip (install it in Blender from disk)",
                "geocode addon build -o geocode_nodes.zip")
    c.add_argument("-o", "--output", type=output_file, default="geocode_nodes.zip")
    c.set_defaults(run=cmd_addon_build)

    bench = command(sub, "bench", "measure a stage's speed or the fit's quality (`geocode bench <benchmark> "
                    "--help`: each one's options)", "geocode bench program vase --json",
                    "geocode bench fit chair -n 20")
    benchmarks = bench.add_subparsers(required=True, metavar="benchmark")
    add_benchmarks(benchmarks, domains)

    c = command(sub, "timings", "where the last workflow run of a profile spent its time, per stage and domain",
                "geocode timings", "geocode timings profile=smoke --json")
    c.add_argument("--metadata", type=Path, default=Path(".snakemake/metadata"),
                   help="Snakemake's records of the outputs (in the folder the run started from)")
    c.add_argument("--json", action="store_true")
    c.add_argument("--profile", action=Renamed, new="profile=<name>", default=None)
    c.set_defaults(run=cmd_timings)

    step = "pipeline step; takes Hydra overrides key=value"
    shard = (("--shard",), dict(required=True, type=int, help="0 .. data.shards - 1"))
    predictions = (("--predictions",), dict(required=True, type=Path))
    metrics = (("--metrics",), dict(required=True, nargs="+", type=Path))
    to_file = (("-o", "--output"), dict(required=True, type=output_file))
    to_folder = (("-o", "--output"), dict(required=True, type=output_folder))
    run = "runs/mini/vase/joint"
    collection = ((("domain",), dict(choices=domains)), (("input",), dict(type=Path, help="the collection's folder")),
                  (("-o", "--output"), dict(required=True, type=Path, help="the collection's folder of results")),
                  (("--work",), dict(required=True, type=Path, help="the folder of its batches")),
                  (("--batch-size",), dict(required=True, type=at_least(1))),
                  (("--recursive",), dict(action="store_true")))
    scans = "geocode {} chair scans/ -o results/reconstruct/scans --work runs/mini/reconstruct/scans --batch-size 8"
    for name, help, run_step, arguments, example in (
        ("sample", "sample the recipes of every split", cmd_sample, (), "geocode sample domain=vase profile=smoke"),
        *((name, f"one shard of the {name} stage", fn, ((("--split",), dict(required=True)), shard),
           f"geocode {name} --split train --shard 0 domain=vase profile=smoke")
          for name, fn in (("export", cmd_export), ("sketch", cmd_sketch), ("points", cmd_points))),
        ("train", "train a model", cmd_train,
         ((("-o", "--output"),
           dict(type=output_folder, help="run folder (default: <paths.runs>/<domain>/<variant>)")),),
         "geocode train domain=chair model=separate -o runs/exp/chair-separate"),
        ("simplify", "decimate the test meshes into split test-s<factor>", cmd_simplify,
         ((("--factor",), dict(required=True, type=at_least(1), help="one of eval.simplify")),),
         "geocode simplify --factor 10 domain=vase"),
        ("predict", "predict every test condition with a checkpoint", cmd_predict,
         ((("--checkpoint",), dict(required=True, type=Path)), to_file),
         f"geocode predict --checkpoint {run}/checkpoints/best.ckpt -o predictions.parquet domain=vase"),
        ("rebuild", "rebuild one shard of predictions with the program", cmd_rebuild, (predictions, shard),
         f"geocode rebuild --predictions {run}/eval/predictions.parquet --shard 0 domain=vase"),
        ("metrics", "Chamfer distances and drop tests of a variant's rebuilt predictions (model=<variant>)",
         cmd_metrics, (predictions, to_file),
         f"geocode metrics --predictions {run}/eval/predictions.parquet -o metrics.parquet domain=vase model=joint"),
        ("tables", "metrics files -> the paper's tables", cmd_tables, (metrics, to_folder),
         f"geocode tables --metrics {run}/eval/metrics.parquet -o tables/ domains=[vase]"),
        ("report", "an HTML page of inputs, ground truth and predictions", cmd_report, (metrics, to_folder),
         f"geocode report --metrics {run}/eval/metrics.parquet -o report/ domains=[vase]"),
        ("reconstruct-batch", "reconstruct one batch of a workflow collection (geocode.reconstruct.collection)",
         cmd_reconstruct_batch,
         (*collection, (("--batch",), dict(required=True, type=at_least(0))),
          (("--checkpoint",), dict(type=Path)), (("--budget",), dict(type=at_least(0))),
          (("-j", "--workers"), dict(type=at_least(1), default=1))),
         scans.format("reconstruct-batch") + " --batch 0"),
    ):
        c = command(sub, name, f"{help} ({step})", example)
        added = [c.add_argument(*flags, **options) for flags, options in arguments]
        if name == "train":
            renamed(c, "--out", added[0])
        c.set_defaults(run=run_step)
    c = command(sub, "real-shapes", "the real-shape table of workflow collections' batch records (pipeline "
                "step; takes Hydra overrides key=value)",
                "geocode real-shapes -o results/real_shapes --records chair runs/mini/reconstruct/"
                "real_shapes-chair/batch-0.json")
    c.add_argument("--records", required=True, nargs="+", action="append", metavar=("DOMAIN", "RECORD"),
                   help="a domain and its batch records; once per domain")
    c.add_argument(*to_folder[0], **to_folder[1])
    c.set_defaults(run=cmd_real_shapes)
    c = command(sub, "reconstruct-page", "a workflow collection's batches gathered: its folder, page and "
                "summary.csv (pipeline step)", scans.format("reconstruct-page"))
    for flags, options in collection:
        c.add_argument(*flags, **options)
    c.set_defaults(run=cmd_reconstruct_page)
    c = command(sub, "config", "print the composed config for these overrides",
                "geocode config profile=paper domain=chair", "geocode config --keys   # every group and key, "
                "with its meaning")
    c.add_argument("--keys", action="store_true", help="list the groups, and every key with its value and meaning")
    c.set_defaults(run=cmd_config)
    c = command(sub, "reference", "write the reference pages: every command's --help and every config key",
                "geocode reference -o docs/reference")
    c.add_argument("-o", "--output", type=output_folder, default=Path("docs/reference"),
                   help="folder for commands.md and config.md (default docs/reference)")
    c.set_defaults(run=cmd_reference)

    for c in [*sub.choices.values(), *benchmarks.choices.values()]:
        if c.get_default("run") in OVERRIDES:
            c.add_argument("overrides", nargs="*", metavar="key=value",
                           help="the config's settings, e.g. profile=smoke (`geocode config --keys` lists them)")
    return p


def add_benchmarks(sub, domains: list[str]) -> None:
    """`geocode bench <benchmark>`: each with its own options."""
    c = command(sub, "program", "random shapes/s of a program (evaluation + OBJ), faces, loose parts",
                "geocode bench program vase --json", "geocode bench program table -n 1000 --stability")
    c.add_argument("domain", choices=domains)
    shapes_option(c, 10000, "a rate settles within a few hundred", "shapes (default 200)", default=200)
    c.add_argument("--stability", action="store_true", help="also the share of shapes that pass the drop test")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_program)

    c = command(sub, "dataset", "export shapes/s, sketch views/s (one render thread), clouds/s and MB per 1000 "
                "shapes of each, on training shapes of a domain at a profile's settings; the domain's whole "
                "dataset there: shapes, disk, job-hours and wall hours",
                "geocode bench dataset vase", "geocode bench dataset chair -n 24 -j 8 profile=paper")
    c.add_argument("domain", choices=domains)
    shapes_option(c, 1000, "a rate settles within a few dozen", "shapes measured (default 24)", default=24)
    c.add_argument("-j", "--jobs", metavar="N", default=1,
                   type=at_most(512, "jobs", "a domain's dataset is a few hundred shard jobs"),
                   help="jobs at once for the projected wall hours (default 1)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_dataset)

    c = command(sub, "train", "DGCNN samples/s, reference against fast; one-sample inference latency",
                "geocode bench train --json")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_train)

    c = command(sub, "epoch", "one training epoch at a dataset size (default: the paper-scale vase), "
                "on random tensors on the device", "geocode bench epoch --device cuda",
                "geocode bench epoch --clouds 330 --sketches 330 --points 1536 --variant huang",
                "geocode bench epoch --device cpu --steps 5 --sketch-bfloat16")
    c.add_argument("--clouds", type=at_most(100000, "clouds", "ten paper-scale epochs; the time grows with it"),
                   default=9330, help="clouds per epoch (default: the paper-scale vase's 9330)")
    c.add_argument("--sketches", type=at_most(200000, "sketches", "ten paper-scale epochs; the time grows with it"),
                   default=18660, help=f"sketches per epoch (at most {SKETCHES_PER_CLOUD} per cloud)")
    c.add_argument("--device", default="auto", help="auto (a GPU where there is one), cpu or cuda")
    c.add_argument("--variant", default="joint", help="the model variant (joint, separate, regression, huang)")
    c.add_argument("--points", type=at_most(10000, "points", "the neighbour search grows with their square "
                                            "(19 times the memory of 2300)"), default=2300, help="points per cloud")
    c.add_argument("--steps", metavar="N", type=at_least(1), help="time only the first N steps and scale their "
                   "mean to the epoch's (a paper-scale epoch on a CPU takes a long time)")
    c.add_argument("--sketch-bfloat16", action="store_true",
                   help="the sketch encoder autocast to bfloat16 (model.sketch_bfloat16, the mini profile's)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_epoch)

    c = command(sub, "eval", "rebuilt shapes/s, Chamfer ms (10k against 10k points), drop-test s a shape",
                "geocode bench eval vase")
    c.add_argument("domain", choices=domains)
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_eval)

    c = command(sub, "fit", "the fit of a run's predictions to clean clouds (as \"pc + fit\") or to sketches "
                "(\"sketch + fit\"): Chamfer distance to the truth before and after, seconds a shape",
                "geocode bench fit chair -n 20", "geocode bench fit vase --modality sketch --camera novel -n 10",
                "geocode bench fit chair -n 20 paths.runs=/data/runs/mini paths.data=/data/data/mini")
    c.add_argument("domain", choices=domains)
    shapes_option(c, 10000, "a mean settles within a few hundred", "shapes (default 20; --modality sketch: 10)")
    c.add_argument("--modality", choices=["points", "sketch"], default="points",
                   help="fit to the clean clouds (points) or to the sketches")
    c.add_argument("--camera", choices=["trained", "novel"], default="trained",
                   help="--modality sketch: the trained cameras' sketches or the novel one's")
    c.add_argument("--split", choices=["val", "test"], default="val", help=SPLIT_HELP + "; default val")
    budget_option(c, f"{BUDGET} (default eval.fit_budget; --modality sketch: the domain's eval.sketch_fit_budget)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_fit)

    c = command(sub, "turns", "reconstruct a split's shapes turned 0, 90, 180, 270 and 137 degrees: "
                "the largest over the smallest fitted distance a shape", "geocode bench turns chair -n 10")
    c.add_argument("domain", choices=domains)
    shapes_option(c, 10000, "each is five reconstructions", "shapes (default 10)", default=10)
    c.add_argument("--split", choices=["val", "test"], default="val", help=SPLIT_HELP + "; default val")
    budget_option(c, f"{BUDGET} (default eval.reconstruct_budget)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_turns)

    c = command(sub, "real", "reconstruct folders of real shapes (one subfolder per domain) against the "
                "network alone, the program's defaults and the nearest training shape",
                "geocode bench real shapes/ --up-truth up.yaml -o pages/   # shapes/chair/*.obj, shapes/vase/...")
    c.add_argument("folder", type=Path, help="the folder of <domain>/ subfolders of meshes, scans or clouds")
    c.add_argument("-o", "--output", type=output_folder,
                   help="the folder of each domain's page and each file's outputs (timed with the rest)")
    c.add_argument("--up-truth", type=Path, help="YAML {file pattern: up axis} for the baselines and the "
                                                 "up axis agreement")
    budget_option(c, f"{BUDGET} (default eval.reconstruct_budget)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_real)

    c = command(sub, "curve", "the scaling curve: a points-only network's and the nearest training shape's "
                "distance on validation shapes against training shapes and against epochs, with a power law "
                "extrapolated to the paper profile's size: curve.json, .csv, .md, .svg in the -o folder",
                "geocode bench curve table -o curves/table",
                "geocode bench curve chair --factors 1 2 4 --epochs 16 48 -n 60 -o curves/chair",
                "geocode bench curve vase --factors 1 2 --epochs 1 -n 4 -o /tmp/curve profile=smoke")
    c.add_argument("domain", choices=domains)
    c.add_argument("--factors", nargs="+", metavar="F", default=[1, 2, 4, 8],
                   type=at_most(64, "times", "each factor is a dataset and a training that much larger"),
                   help="training-set sizes, as multiples of the profile's training variations, smallest first "
                        "(default 1 2 4 8)")
    c.add_argument("--epochs", nargs="+", metavar="E", default=[16, 48],
                   type=at_most(1000, "epochs", "the paper's scale is 600"),
                   help="the epochs axis, on the profile's training set, smallest first (default 16 48)")
    shapes_option(c, 10000, "a mean settles within a few hundred",
                  "validation shapes scored (default: the profile's validation split)")
    c.add_argument("-o", "--output", required=True, type=output_folder,
                   help="the folder of its data, trainings and results; a rerun goes on with them")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_curve)

    c = command(sub, "span", "how near a program comes to real shapes at all: a long fit from its "
                "defaults and their one-switch forms, no network", "geocode bench span chair chairs/ -o span/")
    c.add_argument("domain", choices=domains)
    c.add_argument("folder", type=Path, help="a folder of real meshes, scans or clouds of the domain")
    c.add_argument("-o", "--output", type=output_folder, help="the folder of its page")
    c.add_argument("--up-truth", type=Path, help="YAML {file pattern: up axis}")
    budget_option(c, f"{BUDGET} (default 2000)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(run=cmd_bench_span)


# -- programs ---------------------------------------------------------------------------------

def cmd_programs(args):
    from geocode.program import Program, registry

    return "\n".join(f"{d}: {len(Program.load(d).parameters)} parameters" for d in registry())


def cmd_program_show(args):
    from geocode.program import Program

    shown = {"domain": args.domain, "parameters": Program.load(args.domain).recipe().describe()}
    if args.json:
        return shown
    return "\n".join(
        f"{p['name']:<32} {p['kind']:<5} [{p['min']:g}, {p['max']:g}] default {p['default']:g}"
        f" classes {p['classes']}" + (f"  visible if {p['visible_if']}" if p["visible_if"] else "")
        for p in shown["parameters"])


def cmd_program_build(args):
    from geocode.meshio import write_text
    from geocode.outputs import Outputs
    from geocode.program import Program

    with Outputs() as out:
        blend = out.reserve(args.output)
        manifest = args.manifest and out.reserve(args.manifest)
        program = Program.load(args.domain)
        program.save_blend(blend)
        if manifest:
            write_text(manifest, json.dumps(program.manifest(), indent=1))
    return f"wrote {args.output}"


def cmd_shape(args):
    from geocode.meshio import write_obj
    from geocode.outputs import Outputs
    from geocode.program import Program

    with Outputs() as out:
        obj = out.reserve(args.output)
        png = args.png and out.reserve(args.png)
        mesh = Program.load(args.domain).evaluate(parse_values(args.values))
        write_obj(obj, mesh)
        if png:
            from geocode.blender.gallery import render_mesh_png

            render_mesh_png(mesh, png)
    return f"wrote {args.output} ({len(mesh.faces)} faces)"


def parse_values(tokens: list[str]) -> dict[str, float]:
    values = {}
    for token in tokens:
        name, sep, text = token.partition("=")
        try:
            values[name] = float({"true": 1, "false": 0}.get(text.lower(), text))
        except ValueError:
            sep = ""
        if not sep or not name:
            raise UserError(repr(token), "not a parameter value", "write name=number, e.g. body_height=1.2")
    return values


def cmd_reconstruct(args):
    from geocode.reconstruct.run import reconstruct

    cfg = step_config(args, f"domain={args.domain}")
    return reconstruct(cfg, args.domain, args.input, args.output, checkpoint=args.checkpoint,
                       refine=args.budget, up=args.up, candidates=args.candidates,
                       recursive=args.recursive, workers=args.workers)


def cmd_reconstruct_batch(args):
    from geocode.reconstruct.collection import batch_step

    return batch_step(step_config(args, f"domain={args.domain}"), args.domain, args.input, args.output, args.work,
                      args.batch, args.batch_size, checkpoint=args.checkpoint, budget=args.budget,
                      recursive=args.recursive, workers=args.workers)


def cmd_real_shapes(args):
    from geocode.steps.real_shapes import real_shapes_step

    return real_shapes_step(step_config(args), args.records, args.output)


def cmd_reconstruct_page(args):
    from geocode.reconstruct.collection import page_step

    return page_step(args.domain, args.input, args.output, args.work, args.batch_size, recursive=args.recursive)


def cmd_mix(args):
    from geocode.blender.export import write_shape
    from geocode.outputs import Outputs
    from geocode.program import Program
    from geocode.tools import editing

    with Outputs() as out:
        obj, shape_file = (out.reserve(args.output.with_suffix(s)) for s in (".obj", ".yaml"))
        program = Program.load(args.domain)
        a, b = (editing.read_values(path, program) for path in (args.a, args.b))
        take = editing.select(program, args.take)
        write_shape(obj, shape_file, program, editing.mix(a, b, take))
    return f"wrote {args.output} ({len(take)} parameters from {args.b.name}: {', '.join(take)})"


def cmd_interpolate(args):
    from geocode.blender.export import write_shape
    from geocode.blender.gallery import render_strip
    from geocode.outputs import Outputs
    from geocode.program import Program
    from geocode.tools import editing

    with Outputs() as out:
        files = [[out.reserve(args.output / f"step-{i:02d}{s}") for s in (".obj", ".yaml")]
                 for i in range(args.steps)]
        strip = out.reserve(args.output / "strip.png")
        program = Program.load(args.domain)
        a, b = (editing.read_values(path, program) for path in (args.a, args.b))
        sequence = editing.interpolate(program, a, b, args.steps)
        meshes = [write_shape(obj, yaml, program, values)
                  for (obj, yaml), values in zip(files, sequence, strict=True)]
        render_strip(meshes, strip)
    return f"wrote {len(meshes)} shapes and strip.png to {args.output}"


def cmd_addon_build(args):
    from geocode.blender.addon import build_addon
    from geocode.outputs import Outputs

    with Outputs() as out:
        counts = build_addon(out.reserve(args.output))
    return f"wrote {args.output}: {sum(counts.values())} blocks (" + ", ".join(
        f"{category} {n}" for category, n in counts.items()) + ")"


def cmd_gallery(args):
    from geocode.blender.gallery import render_gallery
    from geocode.outputs import Outputs

    with Outputs() as out:
        render_gallery(args.domain, out.reserve(args.output), n=args.shapes, seed=args.seed)
    return f"wrote {args.output}"


def cmd_bench_program(args):
    from geocode.bench.program import bench_program

    return bench_program(args.domain, n=args.shapes, stability=args.stability)


def cmd_bench_dataset(args):
    from geocode.bench.dataset import bench_dataset
    from geocode.config import compose

    return bench_dataset(compose([f"domain={args.domain}", *args.overrides]), n=args.shapes, jobs=args.jobs)


def cmd_bench_train(args):
    from geocode.bench.train import bench_train

    return bench_train()


def cmd_bench_epoch(args):
    from geocode.bench.train import bench_epoch

    if args.sketches > SKETCHES_PER_CLOUD * args.clouds:
        raise UserError(f"--sketches {args.sketches}", f"more than {SKETCHES_PER_CLOUD} per cloud "
                        f"(--clouds {args.clouds}): a step would hold them all on the device",
                        f"give at most {SKETCHES_PER_CLOUD * args.clouds}")
    return bench_epoch(args.clouds, args.sketches, device=args.device, n_points=args.points, variant=args.variant,
                       max_steps=args.steps, sketch_bfloat16=args.sketch_bfloat16)


def cmd_bench_eval(args):
    from geocode.bench.evaluate import bench_eval

    return bench_eval(args.domain)


def cmd_bench_fit(args):
    from geocode.config import compose

    cfg = compose([f"domain={args.domain}", *args.overrides])
    if args.modality == "sketch":
        from geocode.bench.sketch_fit import bench_sketch_fit

        return bench_sketch_fit(cfg, args.domain, n=args.shapes or 10, camera=args.camera, split=args.split,
                                budget=args.budget)
    from geocode.bench.fit import bench_fit

    return bench_fit(cfg, args.domain, n=args.shapes or 20, split=args.split, budget=args.budget)


def cmd_bench_turns(args):
    from geocode.bench.real import bench_turns

    return bench_turns(args.overrides, args.domain, n=args.shapes, budget=args.budget, split=args.split)


def cmd_bench_real(args):
    from geocode.bench.real import bench_real, real_table

    result = bench_real(args.overrides, args.folder, args.up_truth, args.budget, args.output)
    return result if args.json else real_table(result)


def cmd_bench_curve(args):
    from geocode.bench.curve import bench_curve, markdown

    result = bench_curve(args.overrides, args.domain, args.factors, args.epochs, args.shapes, args.output)
    return result if args.json else markdown(result)


def cmd_bench_span(args):
    from geocode.bench.span import bench_span

    return bench_span(args.overrides, args.domain, args.folder, args.budget, args.up_truth, args.output)


def cmd_timings(args):
    from geocode.config import group_options, registry
    from geocode.timing import run_summary, run_times

    cfg = step_config(args, *([f"profile={args.profile}"] if args.profile else []))
    if not args.metadata.is_dir():
        raise UserError(args.metadata, "no Snakemake records here", "run it in the folder the workflow ran from")
    jobs = run_times(args.metadata, cfg.profile_name, list(registry()), group_options("model"))
    if not args.json:
        return run_summary(jobs)
    minutes = jobs.pivot_table(index="rule", columns="domain", values="seconds", aggfunc="sum") / 60
    return {"wall_min": round((jobs.end.max() - jobs.start.min()) / 60, 2) if len(jobs) else 0.0, "jobs": len(jobs),
            "minutes": {r: {d: round(v, 2) for d, v in row.dropna().items()} for r, row in minutes.iterrows()},
            "variant_minutes": {v: round(m / 60, 2) for v, m in jobs.groupby("variant").seconds.sum().items()}}


# -- pipeline steps -------------------------------------------------------------------------

def step_config(args, *fixed: str):
    """The composed config; a --shard outside 0 .. data.shards - 1 is refused."""
    from geocode.config import ConfigError, compose

    cfg = compose([*fixed, *args.overrides])
    shard = getattr(args, "shard", None)
    if shard is not None and not 0 <= shard < cfg.data.shards:
        raise ConfigError(f"--shard {shard}", f"out of range for data.shards={cfg.data.shards}",
                          f"give 0 .. {cfg.data.shards - 1}")
    return cfg


def cmd_config(args):
    from omegaconf import OmegaConf

    from geocode.config import describe_keys

    cfg = step_config(args)
    return describe_keys(cfg) if args.keys else OmegaConf.to_yaml(cfg, resolve=True)


def cmd_reference(args):
    from geocode.tools.reference import write_reference

    return "wrote " + ", ".join(str(path) for path in write_reference(parser(), args.output))


def cmd_sample(args):
    from geocode.steps.dataset import sample_step

    return sample_step(step_config(args))


def cmd_export(args):
    from geocode.steps.dataset import export_step

    export_step(step_config(args), args.split, args.shard)


def cmd_sketch(args):
    from geocode.steps.dataset import sketch_step

    sketch_step(step_config(args), args.split, args.shard)


def cmd_points(args):
    from geocode.steps.dataset import points_step

    points_step(step_config(args), args.split, args.shard)


def cmd_train(args):
    from geocode.steps.train import train

    cfg = step_config(args)
    return train(cfg, out_dir=args.output)


def cmd_simplify(args):
    from geocode.steps.evaluate import simplify_step

    cfg = step_config(args)
    return simplify_step(cfg, cfg.domain.name, args.factor)


def cmd_predict(args):
    from geocode.steps.evaluate import predict_step

    cfg = step_config(args)
    return predict_step(cfg, cfg.domain.name, args.checkpoint, args.output)


def cmd_rebuild(args):
    from geocode.steps.evaluate import rebuild_step

    cfg = step_config(args)
    return rebuild_step(cfg, cfg.domain.name, args.predictions, args.shard)


def cmd_metrics(args):
    from geocode.steps.evaluate import metrics_step

    cfg = step_config(args)
    return metrics_step(cfg, cfg.domain.name, cfg.model.variant, args.predictions, args.output)


def cmd_tables(args):
    from geocode.steps.tables import tables_step

    return tables_step(step_config(args), args.metrics, args.output)


def cmd_report(args):
    from geocode.steps.report import report_step

    return report_step(step_config(args), args.metrics, args.output)


# Commands that start Blender: it is imported first, with stop signals held until it is up.
BLENDER = {cmd_programs, cmd_program_show, cmd_program_build, cmd_shape, cmd_gallery, cmd_export,
           cmd_sketch, cmd_rebuild, cmd_reconstruct, cmd_reconstruct_batch, cmd_mix, cmd_interpolate, cmd_addon_build,
           cmd_bench_curve}
# Commands that take Hydra overrides (key=value) after their options.
OVERRIDES = {cmd_reconstruct, cmd_reconstruct_batch, cmd_real_shapes,
             cmd_report, cmd_sample, cmd_export, cmd_sketch, cmd_points, cmd_train, cmd_config,
             cmd_simplify, cmd_predict, cmd_rebuild, cmd_metrics, cmd_tables, cmd_timings, cmd_bench_dataset,
             cmd_bench_fit, cmd_bench_turns, cmd_bench_real, cmd_bench_span, cmd_bench_curve}


if __name__ == "__main__":
    sys.exit(main())
