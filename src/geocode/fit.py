"""Fit a program to a point cloud, starting from the network's prediction.

The network gives a good first guess but is brittle on inputs unlike its training data; a
short derivative-free search in the program's own parameter space then looks for the shape
whose Chamfer distance to the input is smallest. CMA-ES (the `cma` package) searches a unit
box: one coordinate per continuous recipe parameter over its whole range, and one per
discrete parameter whose unit interval is split evenly among the network's most probable
classes. The first candidate is the prediction itself, and the best shape seen is returned,
so fitting never makes the distance worse.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from geocode.meshio import normalise_unit_sphere
from geocode.points import sample_surface

FIT_POINTS = 2048   # points sampled on each candidate (fixed seed: a deterministic objective)
SIGMA = 0.15        # CMA-ES's initial step, in units of each parameter's range


@dataclass
class FitResult:
    values: dict[str, float]   # every program parameter, raw
    before: float              # Chamfer distance of the prediction to the target cloud
    after: float               # ... of the fitted shape (<= before)
    evaluations: int
    seconds: float


class CloudDistance:
    """Chamfer distance (as `geocode.metrics.chamfer`) from a shape to one fixed target cloud;
    the target's k-d tree is built once."""

    def __init__(self, target: np.ndarray):
        self.target = np.asarray(target, dtype=np.float64)
        self.tree = cKDTree(self.target)

    def __call__(self, mesh) -> float:
        points = sample_surface(normalise_unit_sphere(mesh), FIT_POINTS, np.random.default_rng(0))
        to_target = self.tree.query(points)[0]
        to_shape = cKDTree(points).query(self.target)[0]
        return float((np.mean(to_target**2) + np.mean(to_shape**2)) / 2)


class SearchSpace:
    """Unit-box coordinates <-> raw values of the recipe parameters.

    `options[name]` lists the candidate raw values of a discrete parameter (most probable
    first); a continuous parameter spans [min, max] of the recipe."""

    def __init__(self, recipe, start: Mapping[str, float], options: Mapping[str, Sequence[float]]):
        self.recipe = recipe
        self.start = dict(start)
        self.continuous = [p for p in recipe.parameters if p.kind == "float"]
        self.discrete = [(p, list(options.get(p.name, [start[p.name]])))
                         for p in recipe.parameters if p.kind != "float"]

    def x0(self) -> np.ndarray:
        """The start's coordinates (discrete: the middle of its first option's interval)."""
        cont = [(self.start[p.name] - p.min) / (p.max - p.min) for p in self.continuous]
        disc = [0.5 / len(values) for _, values in self.discrete]
        return np.clip(np.array(cont + disc, dtype=np.float64), 0.0, 1.0)

    def values(self, x: np.ndarray) -> dict[str, float]:
        x = np.clip(x, 0.0, 1.0)
        out = dict(self.start)
        for p, xi in zip(self.continuous, x, strict=False):
            out[p.name] = float(p.min + xi * (p.max - p.min))
        for (p, values), xi in zip(self.discrete, x[len(self.continuous):], strict=True):
            out[p.name] = float(values[min(int(xi * len(values)), len(values) - 1)])
        return out


def fit(program, recipe, start: Mapping[str, float], options: Mapping[str, Sequence[float]],
        target: np.ndarray, budget: int, seed: int = 0) -> FitResult:
    """Search at most `budget` program evaluations for the shape nearest `target` (N, 3),
    a cloud on the unit sphere. `start` holds raw values (the prediction); `options` the
    candidate values of the discrete parameters."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # cma warns that matplotlib (plots only) is missing
        import cma

    started = time.perf_counter()
    distance = CloudDistance(target)
    space = SearchSpace(recipe, program.check(start), options)

    def objective(x) -> float:
        values = space.values(np.asarray(x))
        if not recipe.satisfies(values):
            return np.inf
        try:
            return distance(program.evaluate(values))
        except ValueError:   # a combination the program refuses
            return np.inf

    x0 = space.x0()
    best_x, best = x0, objective(x0)
    before, evaluations = best, 1
    if budget > 1 and len(x0) > 0:
        options_ = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9,
                    "maxfevals": budget - 1, "tolfun": 0.0, "tolx": 1e-6}
        es = cma.CMAEvolutionStrategy(x0, SIGMA, options_)
        while evaluations < budget and not es.stop():
            xs = es.ask()
            fs = []
            for x in xs[: budget - evaluations]:
                fs.append(objective(x))
                if fs[-1] < best:
                    best, best_x = fs[-1], np.asarray(x)
            evaluations += len(fs)
            if len(fs) < len(xs):   # the budget ends inside this generation
                break
            es.tell(xs, [f if np.isfinite(f) else 1e9 for f in fs])
    return FitResult(values=space.values(best_x), before=before, after=best,
                     evaluations=evaluations, seconds=time.perf_counter() - started)
