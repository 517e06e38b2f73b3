"""`geocode bench span <domain> <folder>`: how near a program can come to real shapes at all.

No network: for each mesh of the folder, a long fit (`geocode.reconstruct.fit`, default SPAN_BUDGET
evaluations) from the program's defaults and from the defaults with one discrete parameter
switched to each of its other values (a sled base, side panels, an open row: a form one switch
away is a start of its own, not a long step of the search), each at the turns about the up
axis at which `geocode reconstruct` reads a 3D input (every 45 degrees: a shape whose level
turn ends on its diagonals stands half a quarter-turn off); then, at the turn of the best of
them, also from POOL random shapes of the program's own sampler (an office chair is three
switches from the defaults: a column, tent legs, a back on a post). The starts are judged by
short fits (HALVING: the best of them fitted briefly, the best of those again), and CMA-ES runs
from the FINALISTS with the rest of the budget, every discrete parameter searched over all its
values; the up axis, scale and offset found as `geocode reconstruct` finds them. What
distance remains (plain symmetric Chamfer, as `geocode bench real` scores it) is the part of
the real shapes the program cannot make. Writes a page of each mesh beside the best shape.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from geocode.errors import UserError
from geocode.reconstruct.fit import Start, fit

SPAN_BUDGET = 2000
POOL = 200   # random shapes of the program, each a start (one evaluation)
# rounds of short fits that judge the starts: (starts kept, evaluations each); a start's first
# evaluation ranks forms by chance, where its first sweeps (the discrete ones switch its form)
# tell them apart (docs/design.md#span)
HALVING = ((16, 40), (6, 100))
FINALISTS = 2   # the long fit's CMA-ES runs, from the best of the last round


def all_options(recipe) -> dict[str, list[float]]:
    """Every value of every discrete recipe parameter (its classes, in order)."""
    return {p.name: [float(c) for c in p.classes] for p in recipe.parameters if p.kind != "float"}


def start_at(values: dict[str, float], options: dict[str, list[float]], turn: float) -> Start:
    """A start at `values`, each discrete parameter's own value first among its options
    (where CMA-ES starts) and the others after it."""
    ordered = {name: [values[name], *(v for v in vals if v != values[name])] for name, vals in options.items()}
    return Start(values, ordered, turn=turn)


def switch_starts(defaults: dict[str, float], options: dict[str, list[float]], turn: float) -> list[Start]:
    """The defaults with one discrete parameter switched to each of its other values."""
    return [start_at({**defaults, name: v}, options, turn)
            for name, vals in options.items() for v in vals if v != defaults[name]]


def span_fit(program, recipe, target: np.ndarray, budget: int, tuning, seed: int):
    """The fit from the defaults and their one-switch forms at each of reconstruct's TURNS
    turns (one evaluation each), then, at the turn of the best of them, from the other forms
    and POOL random shapes, judged by short fits (`judged_by_short_fits`), and a long one from
    the best: `budget` evaluations in all, each fit as `tuning` (fit.cloud) says. A turn judged
    by the defaults alone can be lost to a form they lack: a long coffee table's turn went to a
    diagonal, from which its fit never came back (docs/design.md#span)."""
    from geocode.reconstruct.run import TURNS

    defaults, options = program.check({}), all_options(recipe)
    forms = [start_at(defaults, options, 0.0), *switch_starts(defaults, options, 0.0)]
    judged = [replace(s, turn=k * 2 * math.pi / TURNS) for k in range(TURNS) for s in forms]
    first = fit(program, recipe, judged, target, min(len(judged), max(1, budget - 1)), tuning, seed=seed,
                restarts=0)
    chosen = judged[first.start]
    rng = np.random.default_rng(seed)
    pool = [start_at(program.random_values(rng), options, chosen.turn) for _ in range(POOL)]
    starts = [chosen, *(s for s in judged if s.turn == chosen.turn and s is not chosen), *pool]
    left = budget - first.evaluations
    ranked, used = judged_by_short_fits(program, recipe, starts, target, left - 1, tuning, seed)
    # a budget under the number of starts scores the first ones only (`fit`)
    result = fit(program, recipe, ranked[:FINALISTS], target, max(1, left - used), tuning, seed=seed,
                 restarts=FINALISTS)
    result.evaluations += first.evaluations + used
    return result


def judged_by_short_fits(program, recipe, starts: list[Start], target: np.ndarray, budget: int, tuning,
                         seed: int) -> tuple[list[Start], int]:
    """The starts ranked by their first evaluation, then each round of HALVING: the best `kept`
    fitted for `each` evaluations, ranked by where they end and started again from there; at
    most `budget` evaluations. Returns the ranking and the evaluations spent."""
    if budget < 1:
        return starts, 0
    scored = fit(program, recipe, starts, target, min(len(starts), budget), tuning, seed=seed, restarts=0)
    used = scored.evaluations
    ranked = [starts[i] for i in np.argsort(scored.scores, kind="stable")]
    options = all_options(recipe)
    for kept, each in HALVING:
        ends = []
        for start in ranked[:kept]:
            if used >= budget:
                break
            short = fit(program, recipe, [start], target, min(each, budget - used), tuning, seed=seed,
                        restarts=1)
            used += short.evaluations
            ends.append((short.after, start_at(short.values, options, short.pose.turn)))
        if ends:
            ranked = [s for _, s in sorted(ends, key=lambda e: e[0])]
    return ranked, used


def bench_span(overrides: list[str], domain: str, folder: Path, budget: int | None = None,
               up_truth: Path | None = None, out: Path | None = None) -> dict:
    from geocode.bench.real import read_up_truth, true_up
    from geocode.config import compose
    from geocode.reconstruct import page
    from geocode.reconstruct.inputs import SUFFIXES, read_geometry
    from geocode.reconstruct.run import (
        Answer,
        Reconstruction,
        Reconstructor,
        input_shape,
        placement,
    )

    folder = Path(folder)
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in SUFFIXES) if folder.is_dir() else []
    if not files:
        raise UserError(folder, "no meshes or clouds in the folder", "give a folder of real shapes")
    run = Reconstructor(compose([*overrides, f"domain={domain}"]), domain, model=False)
    table, budget = read_up_truth(up_truth), budget or SPAN_BUDGET
    rows, entries = [], []
    for path in files:
        started = time.perf_counter()
        geometry = read_geometry(path)
        run.up = true_up(path.name, table) or "auto"
        frame = run.frames(geometry)[0]
        result = span_fit(run.program, run.recipe, frame.samples[:4096], budget, run.tuning.cloud, run.cfg.seed)
        answer = Answer(result.values, result.pose, run.score(frame, result.values, result.pose))
        seconds = time.perf_counter() - started
        rows.append({"file": path.name, "chamfer": round(answer.chamfer, 6), "seconds": round(seconds, 1),
                     "up": frame.pose.up, "evaluations": result.evaluations})
        if out is not None:
            shown = Reconstruction(path, geometry.kind, [answer], frame, geometry=geometry)
            entries.append(page.Entry(name=path.name, kind=geometry.kind, input=input_shape(shown),
                                      result=run.mesh(answer), after=answer.chamfer, seconds=seconds,
                                      pose={"up": frame.pose.up, **placement(frame, answer.where)},
                                      parameters=answer.values))
    if out is not None:
        page.write_page(entries, out, f"geocode bench span {domain}",
                        note=f"a fit of {budget} evaluations from the program's defaults; "
                             "Chamfer distance: unit sphere, squared, mean of both directions / 2")
    return {"domain": domain, "shapes": len(rows), "budget": budget,
            "median_chamfer": round(statistics.median(r["chamfer"] for r in rows), 6),
            "seconds_median": round(float(np.median([r["seconds"] for r in rows])), 1), "files": rows}
