"""`geocode bench span <domain> <folder>`: how near a program can come to real shapes at all.

No network: for each mesh of the folder, a long fit (`geocode.fit`, default SPAN_BUDGET
evaluations) from the program's defaults at the four quarter-turns about the up axis, every
discrete parameter searched over all its values, CMA-ES restarted from the best starts; the
pose (up axis, then turn, scale and offset) found as `geocode reconstruct` finds it. What
distance remains (plain symmetric Chamfer, as `geocode bench real` scores it) is the part of
the real shapes the program cannot make. Writes a page of each mesh beside the best shape.
"""

from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np

from geocode.errors import UserError
from geocode.fit import Start, fit

SPAN_BUDGET = 2000
RESTARTS = 4


def all_options(recipe) -> dict[str, list[float]]:
    """Every value of every discrete recipe parameter (its classes, in order)."""
    return {p.name: [float(c) for c in p.classes] for p in recipe.parameters if p.kind != "float"}


def bench_span(overrides: list[str], domain: str, folder: Path, budget: int | None = None,
               up_truth: Path | None = None, out: Path | None = None) -> dict:
    from geocode import page
    from geocode.bench.real import read_up_truth, true_up
    from geocode.config import compose
    from geocode.inputs import read_geometry
    from geocode.tools.reconstruct import (
        SUFFIXES,
        Answer,
        Reconstruction,
        Reconstructor,
        input_shape,
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
        starts = [Start(run.program.check({}), all_options(run.recipe), turn=k * math.pi / 2)
                  for k in range(4)]
        result = fit(run.program, run.recipe, starts, frame.samples[:4096], budget,
                     seed=run.cfg.seed, restarts=RESTARTS)
        answer = Answer(result.values, result.pose, run.score(frame, result.values, result.pose))
        seconds = time.perf_counter() - started
        rows.append({"file": path.name, "chamfer": round(answer.chamfer, 6), "seconds": round(seconds, 1),
                     "up": frame.pose.up, "evaluations": result.evaluations})
        if out is not None:
            shown = Reconstruction(path, geometry.kind, [answer], frame, geometry=geometry)
            entries.append(page.Entry(name=path.name, kind=geometry.kind, input=input_shape(shown),
                                      result=run.mesh(answer), after=answer.chamfer, seconds=seconds,
                                      pose={"up": frame.pose.up, **answer.where.to_dict()},
                                      parameters=answer.values))
    if out is not None:
        page.write_page(entries, out, f"geocode bench span {domain}",
                        note=f"a fit of {budget} evaluations from the program's defaults; "
                             "Chamfer distance: unit sphere, squared, mean of both directions / 2")
    return {"domain": domain, "shapes": len(rows), "budget": budget,
            "median_chamfer": round(statistics.median(r["chamfer"] for r in rows), 6),
            "seconds_median": round(float(np.median([r["seconds"] for r in rows])), 1), "files": rows}
