"""`geocode bench real <folder>`: `geocode reconstruct` on real shapes, against its baselines.

The folder holds one subfolder per domain (`chair/`, `table/`, ...) of meshes, scans or clouds
that no program made. For each file it runs the reconstruction as `geocode reconstruct` does
(its pose found: `--up auto`, the front searched) and scores, by the plain symmetric Chamfer
distance (10,000 surface points each on the input's unit sphere, squared, mean of both
directions / 2):

    network    the network alone: its answer at the turn nearest the input, corrected by its own
               feedback (the nearest of its rounds), in the pose the tool found; no search
    fit        network + fit, in the pose the tool found
    defaults   the program's default shape, at the best of four quarter-turns
    nearest    the nearest training shape (`geocode.reconstruct.retrieval`), at the best of four quarter-turns

With `out`, each file's outputs are written as `geocode reconstruct -o` writes them (result
.yaml/.obj/.blend, pictures), with a page per domain (`<out>/<domain>/index.html`), and the
seconds include them.

The two baselines are given the true up axis where `up_truth` names it (a YAML mapping of file
name patterns to axes, first match wins, e.g. `{"*.off": z, "*": y}`); else they are the
reconstruction's own, in the pose it found (`Reconstructor.baselines`, as the real-shape table's).
"""

from __future__ import annotations

import fnmatch
import json
import math
import statistics
import time
from pathlib import Path

import yaml

from geocode.errors import UserError
from geocode.reconstruct.fit import Placement

QUARTER_TURNS = [Placement(turn=k * math.pi / 2) for k in range(4)]


def read_up_truth(path: Path | None) -> list[tuple[str, str]]:
    if path is None:
        return []
    try:
        table = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError) as exc:
        raise UserError(path, f"not a readable YAML file ({exc})", "give {pattern: axis, ...}") from None
    if not isinstance(table, dict):
        raise UserError(path, "not a mapping", "give {pattern: axis, ...}, e.g. {'*.off': z, '*': y}")
    return [(str(k), str(v)) for k, v in table.items()]


def true_up(name: str, table: list[tuple[str, str]]) -> str | None:
    axis = next((axis for pattern, axis in table if fnmatch.fnmatch(name, pattern)), None)
    return None if axis is None else (axis if axis[:1] in "+-" else "+" + axis)


def bench_real(overrides: list[str], folder: Path, up_truth: Path | None = None,
               budget: int | None = None, out: Path | None = None) -> dict:
    """Per domain subfolder: the medians of the four distances, their ratios to the nearest
    training shape, seconds per shape and how often the up axis found is the true one."""
    from geocode.config import compose, registry
    from geocode.reconstruct import page
    from geocode.reconstruct.plan import Job, inputs_of, plan_run
    from geocode.reconstruct.run import PAGE_NOTE, Reconstructor

    folder, table = Path(folder), read_up_truth(up_truth)
    domains = [d for d in registry() if (folder / d).is_dir()]
    if not domains:
        raise UserError(folder, "no subfolder named after a domain", f"make {', '.join(registry())} subfolders")
    result = {}
    for domain in domains:
        pages = None if out is None else Path(out) / domain
        # outputs named as `geocode reconstruct` names them: scan.obj, scan.ply -> scan-obj.*, scan-ply.*
        plan = None if pages is None else plan_run(folder / domain, pages, recursive=False)
        jobs = plan.jobs if plan else [Job(p, p.name, p) for p in inputs_of(folder / domain, recursive=False)]
        run = Reconstructor(compose([*overrides, f"domain={domain}"]), domain, refine=budget)
        if plan:
            plan.write_record()
        scored = [score_file(run, job, true_up(job.path.name, table), pages) for job in jobs]
        if pages is not None:
            page.write_page([entry for _, entry in scored], pages, f"geocode bench real: {domain}",
                            note=PAGE_NOTE)
        result[domain] = summarise([row for row, _ in scored])
        record(run.checkpoint, result[domain])
    return result


def record(checkpoint: Path, numbers: dict) -> None:
    """Keep the numbers beside the model, for its card."""
    from geocode import paths
    from geocode.card import write_card
    from geocode.meshio import write_text

    run = paths.run_of(checkpoint)
    write_text(paths.real_bench_file(run), json.dumps(numbers, indent=1) + "\n")
    write_card(run)


def score_file(run, job, truth: str | None, out: Path | None = None) -> tuple[dict, object]:
    """One file's scores (`job`: a `plan.Job`), and its page entry where its outputs are written
    to `out`."""
    from geocode.reconstruct.run import write_outputs

    path = job.path
    started = time.perf_counter()
    result = run(path)
    entry = None if out is None else write_outputs(run, result, job.stem, out, job.name)
    seconds = time.perf_counter() - started
    baselines = result.summary                   # in the pose found, or with the true up axis where known
    if truth is not None:
        up, run.up = run.up, truth
        frame = run.frames(result.geometry)[0]
        run.up = up
        baselines = run.baselines(frame, [] if run.training is None else run.training.matches(frame.samples, 1))
    if entry is not None:
        entry.seconds = round(seconds, 2)
    return {"file": path.name, "network": result.network, "fit": result.answers[0].chamfer,
            "defaults": baselines["chamfer_defaults"], "nearest": baselines.get("chamfer_nearest", math.nan),
            "seconds": seconds,
            "up": result.frame.pose.up, "up_true": truth}, entry


def summarise(rows: list[dict]) -> dict:
    median = {k: statistics.median(r[k] for r in rows) for k in ("network", "fit", "defaults", "nearest")}
    seconds = [r["seconds"] for r in rows]
    known = [r for r in rows if r["up_true"] is not None]
    return {
        "shapes": len(rows),
        **{f"median_{k}": round(v, 6) for k, v in median.items()},
        "fit_vs_nearest": round(median["fit"] / median["nearest"], 3),
        "network_vs_nearest": round(median["network"] / median["nearest"], 3),
        "seconds_median": round(statistics.median(seconds), 1),
        "seconds_range": [round(min(seconds), 1), round(max(seconds), 1)],
        "up_agrees": f"{sum(r['up'] == r['up_true'] for r in known)}/{len(known)}",
        "files": [{k: (round(v, 6) if isinstance(v, float) else v) for k, v in r.items()} for r in rows],
    }


def real_table(result: dict) -> str:
    """The medians per domain as a Markdown table (the files stay in --json)."""
    head = ("| domain | shapes | network | network + fit | defaults | nearest training shape | "
            "fit / nearest | network / nearest | s per shape (range) | up found |")
    lines = [head, "|" + "---|" * 10]
    for domain, r in result.items():
        lines.append(f"| {domain} | {r['shapes']} | {r['median_network']:.4f} | {r['median_fit']:.4f} | "
                     f"{r['median_defaults']:.4f} | {r['median_nearest']:.4f} | {r['fit_vs_nearest']} | "
                     f"{r['network_vs_nearest']} | {r['seconds_median']} ({r['seconds_range'][0]}-"
                     f"{r['seconds_range'][1]}) | {r['up_agrees']} |")
    return "\n".join(lines)


TURNS_DEGREES = (0.0, 90.0, 180.0, 270.0, 137.0)   # the quarter-turns and one arbitrary angle


def bench_turns(overrides: list[str], domain: str, n: int = 10, budget: int | None = None,
                split: str = "val") -> dict:
    """`geocode reconstruct` (up axis and front found, fit of `budget` evaluations) on each of
    the first `n` shapes of a split of the run (the validation split unless told otherwise)
    turned by TURNS_DEGREES about the up axis: per shape the fitted distances (plain Chamfer,
    in the input's pose) and the largest over the smallest; a tool that finds the pose gives
    every turn the same program."""
    import tempfile

    import numpy as np
    import trimesh

    from geocode import paths
    from geocode.config import compose
    from geocode.meshio import read_obj
    from geocode.reconstruct.run import Reconstructor
    from geocode.steps.evaluate import split_ids

    cfg = compose([*overrides, f"domain={domain}"])
    run = Reconstructor(cfg, domain, refine=budget)
    shapes = paths.shapes_dir(paths.split_dir(cfg, domain, split))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for shape_id in split_ids(cfg, domain, split)[:n]:
            mesh = read_obj(paths.shape_file(shapes, shape_id))
            distances = []
            for degrees in TURNS_DEGREES:
                turned = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
                turned.apply_transform(trimesh.transformations.rotation_matrix(np.radians(degrees), [0, 0, 1]))
                path = Path(tmp) / f"{shape_id}-{degrees:g}.obj"
                turned.export(path)
                distances.append(run(path).answers[0].chamfer)
            rows.append({"shape": shape_id, "distances": [round(d, 6) for d in distances],
                         "ratio": round(max(distances) / min(distances), 3)})
    ratios = [r["ratio"] for r in rows]
    return {"domain": domain, "split": split, "shapes": len(rows), "turns": list(TURNS_DEGREES),
            "median_ratio": round(statistics.median(ratios), 3), "worst_ratio": max(ratios),
            "within_1.2x": f"{sum(r <= 1.2 for r in ratios)}/{len(rows)}",
            "median_distance": round(statistics.median(d for r in rows for d in r["distances"]), 6),
            "files": rows}
