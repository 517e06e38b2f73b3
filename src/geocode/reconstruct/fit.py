"""Fit a program to a point cloud, starting from the network's guesses.

The network gives a good first guess but is brittle on inputs unlike its training data; a
derivative-free search in the program's own parameter space then looks for the shape nearest
the input. CMA-ES (the `cma` package) searches a unit box: one coordinate per continuous
recipe parameter over its whole range, one per discrete parameter whose unit interval is
split evenly among its candidate values, and four for the pose of the shape against the input
(scale, offset; a turn about the up axis within half the spacing of the starts' turns), since
centring on the bounding box is biased where a scan misses a side.

From the best start, coordinate sweeps come first (`sweep_discrete`, `sweep_continuous`: each
discrete parameter's other choices, then each continuous parameter +-a step, one at a time,
kept where they help; none spent on a part the shape lacks), then CMA-ES runs from the best
few starts (the network's answer at several turns of the input, its feedback rounds, the
nearest training shapes), and last
sweeps of smaller steps from the best shape found. How it searches (CMA-ES's step, the trim,
the restarts, the sweeps' steps, the feedback's rounds) is the config's fit.cloud
(`settings.CloudFit`, conf/fit/default.yaml); what stays here fixes the objective and the
pose's limits. The sweeps make the fit end near the same
shape from nearby starts: on the first 10 test chairs, each fitted as given and turned by 137
degrees (whose starts differ a little), CMA-ES alone ended within 1.2x of itself on 5 of 10
and with the sweeps on 10 of 10, at a lower median distance (docs/design.md#pose-and-sampling). The fit
returns the best shape seen, so it never makes the distance worse than the best start. The
distance it minimises tolerates partial scans and outliers (`CloudDistance`, docs/design.md#fit).
"""

from __future__ import annotations

import math
import time
import uuid
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

from geocode.meshio import unit_sphere_vertices
from geocode.metrics import Cells, bucket, cell_side, nearest
from geocode.points import surface_samples
from geocode.reconstruct.pose import turn_z
from geocode.settings import CloudFit

# Not settings: these fix the objective (what a distance means) and keep the pose sane.
FIT_POINTS = 2048    # points sampled on each candidate (fixed seed: a deterministic objective,
                     # its distances comparable between fits)
ALIGN_STEPS = 3      # closed-form pose steps per evaluation (`align`) ...
ALIGN_POINTS = 1024  # ... each pairing this many points of either cloud (a pose of five numbers
                     # needs few; the distance it returns uses them all)
MAX_TURN = math.pi / 6   # how far `align` may turn a shape from its start's turn: the starts'
                         # turns lie 45 degrees apart (reconstruct's TURNS), the guard against a
                         # pose that runs off to a degenerate fit
SCALE_RANGE = 1.3        # ... and scale it (a factor in [1/1.3, 1.3]), for the same reason
FEEDBACK_POINTS = 4096   # surface points of each feedback round's shape, as the dataset samples them
SNAP = 1e-3              # starts' continuous values are rounded to this share of each range, so
                         # that readings 1e-7 apart give the same fit (`snapped`)


@dataclass(frozen=True)
class Placement:
    """Where the program's unit-sphere shape sits against the input (in the input's canonical
    frame, `pose.Pose`'s output): turned by `turn` radians about +Z, scaled, then offset."""

    turn: float = 0.0
    scale: float = 1.0
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        """The 4x4 transform, program frame -> the input's (normalised) frame."""
        m = np.eye(4)
        m[:3, :3] = self.scale * turn_z(math.degrees(self.turn))
        m[:3, 3] = self.offset
        return m

    def apply(self, points: np.ndarray) -> np.ndarray:
        m = self.matrix()
        return np.asarray(points, dtype=np.float64) @ m[:3, :3].T + m[:3, 3]

    def then(self, other: Placement) -> Placement:
        """This placement followed by `other`."""
        offset = other.scale * turn_z(math.degrees(other.turn)) @ np.asarray(self.offset) + np.asarray(other.offset)
        return Placement(turn=self.turn + other.turn, scale=self.scale * other.scale,
                         offset=tuple(float(o) for o in offset))

    def to_dict(self) -> dict:
        return {"turn_deg": round(math.degrees(self.turn) % 360, 2), "scale": round(self.scale, 4),
                "offset": [round(float(o), 4) for o in self.offset]}


@dataclass
class Start:
    """A point the search may start from: raw values (every program parameter), the candidate
    values of each discrete parameter (most probable first; the parameters the network is
    least sure of first), and the input's turn."""

    values: dict[str, float]
    options: dict[str, list[float]] = field(default_factory=dict)
    turn: float = 0.0


@dataclass
class FitResult:
    values: dict[str, float]   # every program parameter, raw
    pose: Placement            # where the shape sits against the input
    before: float              # the best start's distance to the target (the fit's objective)
    after: float               # ... the fitted shape's (<= before)
    evaluations: int
    seconds: float
    start: int = 0             # index of the start the best shape came from
    curve: list[float] = field(default_factory=list)   # best distance after each evaluation
    found: list[tuple[dict[str, float], Placement]] = field(default_factory=list)  # each run's best
    scores: list[float] = field(default_factory=list)   # each start's own distance, in order


def trimmed_mean(squared: np.ndarray, trim: float) -> float:
    """Mean of the smallest (1 - trim) share of the values."""
    keep = max(1, int(round(len(squared) * (1.0 - trim))))
    return float(np.mean(np.partition(squared, keep - 1)[:keep]))


class CloudDistance:
    """A Chamfer distance from a shape's points to one fixed target cloud, built once: the
    target's cells (`metrics.Cells`) and `align`'s coarse subset with its own. The nearest
    neighbours are those of scipy's tree, to the bit, and summed in the same order: the
    same distances as a tree built afresh for every shape.

    `trim` = 0 is the plain symmetric Chamfer distance of `geocode.metrics.chamfer`. With
    `trim` > 0 each direction ignores its largest `trim` share of squared distances: target
    points far from every shape point (outliers, clutter, a neighbouring object) no longer
    pull the shape, and neither do the shape's points where the scan has no surface (a
    missing underside or back), as long as they are under that share of the shape.
    """

    def __init__(self, target: np.ndarray, trim: float):
        self.target = np.asarray(target, dtype=np.float64)
        self.cells = Cells(self.target)
        self.coarse = self.target[:ALIGN_POINTS]       # what `align` pairs (random order)
        self.coarse_cells = Cells(self.coarse)
        self.trim = trim

    def __call__(self, points: np.ndarray) -> float:
        shape = Cells(points)
        to_target, to_shape = np.empty(len(shape.order)), np.empty(len(self.target))
        # each cloud's points asked in cell order (sooner), the answers kept in its own
        to_target[shape.order] = self.cells.query(shape.points)[0] ** 2
        to_shape[self.cells.order] = shape.query(self.cells.points)[0] ** 2
        if self.trim == 0:
            return float((np.mean(to_target) + np.mean(to_shape)) / 2)
        return (trimmed_mean(to_target, self.trim) + trimmed_mean(to_shape, self.trim)) / 2


def shape_points(program, values: Mapping[str, float], n: int = FIT_POINTS) -> np.ndarray:
    """n surface points of the program's shape on the unit sphere (fixed seed), float32
    values (as `points.sample_surface` gives) in float64."""
    mesh = program.evaluate(values)
    points = surface_samples(unit_sphere_vertices(mesh.vertices), mesh.faces, n, np.random.default_rng(0))
    return points.astype(np.float32).astype(np.float64)


class SearchSpace:
    """Unit-box coordinates <-> raw values of the recipe parameters.

    `start.options[name]` lists the candidate raw values of a discrete parameter (most
    probable first); a continuous parameter spans [min, max] of the recipe."""

    def __init__(self, recipe, start: Start):
        self.recipe, self.start = recipe, start
        self.continuous = [p for p in recipe.parameters if p.kind == "float"]
        self.discrete = [(p, list(start.options.get(p.name, [start.values[p.name]])))
                         for p in recipe.parameters if p.kind != "float"]

    def x0(self) -> np.ndarray:
        """The start's coordinates (discrete: the middle of its first option's interval)."""
        cont = [(self.start.values[p.name] - p.min) / (p.max - p.min) for p in self.continuous]
        disc = [0.5 / len(values) for _, values in self.discrete]
        return np.clip(np.array(cont + disc, dtype=np.float64), 0.0, 1.0)

    def values(self, x: np.ndarray) -> dict[str, float]:
        x = np.clip(x, 0.0, 1.0)
        out = dict(self.start.values)
        for p, xi in zip(self.continuous, x, strict=False):
            out[p.name] = float(p.min + xi * (p.max - p.min))
        for (p, values), xi in zip(self.discrete, x[len(self.continuous):], strict=True):
            out[p.name] = float(values[min(int(xi * len(values)), len(values) - 1)])
        return out

    def shown(self, x: np.ndarray) -> dict[str, bool]:
        """`recipe.shown` at x (coordinates after the parameters', a drawing's camera, ignored)."""
        return self.recipe.shown(self.values(x[:len(self.continuous) + len(self.discrete)]))


def align(points: np.ndarray, distance: CloudDistance, pose: Placement,
          steps: int = ALIGN_STEPS) -> Placement:
    """`pose` refined so that the posed `points` lie on the distance's target: each step pairs
    each of ALIGN_POINTS points of either cloud (random samples) with its nearest in the other
    (the `trim` share of farthest pairs dropped) and solves for the best turn about +Z, scale
    and offset in closed form (least squares; `_align_steps`). The turn moves at most MAX_TURN
    and the scale stays within SCALE_RANGE of the start, so that the pose cannot run off to a
    degenerate fit."""
    points = np.ascontiguousarray(points[:ALIGN_POINTS], dtype=np.float64)
    turn, scale, offset = _align_steps(points, cell_side(len(points)), distance.coarse, distance.coarse_cells.grid,
                                       pose.turn, pose.scale, np.array(pose.offset, dtype=np.float64),
                                       steps, distance.trim)
    turn = pose.turn + float(np.clip(turn - pose.turn, -MAX_TURN, MAX_TURN))
    scale = float(np.clip(scale / pose.scale, 1 / SCALE_RANGE, SCALE_RANGE)) * pose.scale
    return Placement(turn=turn, scale=scale, offset=tuple(float(o) for o in offset))


@numba.njit(cache=True, nogil=True)
def _align_steps(points, side, target, target_grid, turn, scale, offset, steps, trim):
    """`align`'s steps, compiled: (turn, scale, offset) after them. `target_grid`: the
    target's `metrics.bucket`. The same pairs as numpy's steps, summed in another order: the
    pose agrees to 1e-14, and the fits of the development set's chairs and tables end on the
    same shapes."""
    n, m = len(points), len(target)
    posed, p, q, d = np.empty((n, 3)), np.empty((n + m, 3)), np.empty((n + m, 3)), np.empty(n + m)
    for _ in range(steps):
        c, s = math.cos(turn), math.sin(turn)
        for i in range(n):
            x, y = points[i, 0], points[i, 1]
            posed[i, 0] = scale * (c * x - s * y) + offset[0]
            posed[i, 1] = scale * (s * x + c * y) + offset[1]
            posed[i, 2] = scale * points[i, 2] + offset[2]
        grid = bucket(posed, side)      # each cloud asked in its cells' order (sooner), answered in its own
        d_to, i_to = np.empty(n), np.empty(n, np.int64)
        d_to[grid[4]], i_to[grid[4]] = nearest(*target_grid, grid[5])
        d_from, i_from = np.empty(m), np.empty(m, np.int64)
        d_from[target_grid[4]], i_from[target_grid[4]] = nearest(*grid, target_grid[5])
        p[:n], q[:n], d[:n] = posed, target[i_to], d_to
        p[n:], q[n:], d[n:] = posed[i_from], target, d_from
        keep = d <= (np.quantile(d, 1.0 - trim) if trim > 0 else np.inf)
        mp, mq = np.zeros(3), np.zeros(3)
        for k in range(3):
            mp[k], mq[k] = p[keep, k].mean(), q[keep, k].mean()
        a, b = p[keep] - mp, q[keep] - mq
        t = math.atan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
        ct, st = math.cos(t), math.sin(t)
        turned = np.sum((ct * a[:, 0] - st * a[:, 1]) * b[:, 0] + (st * a[:, 0] + ct * a[:, 1]) * b[:, 1]
                        + a[:, 2] * b[:, 2])
        g = turned / max(np.sum(a * a), 1e-12)
        # the step: x -> g R(t) x + mq - g R(t) mp, after the pose so far
        step = np.array([mq[0] - g * (ct * mp[0] - st * mp[1]), mq[1] - g * (st * mp[0] + ct * mp[1]),
                         mq[2] - g * mp[2]])
        offset = np.array([g * (ct * offset[0] - st * offset[1]), g * (st * offset[0] + ct * offset[1]),
                           g * offset[2]]) + step
        turn, scale = turn + t, scale * g
    return turn, scale, offset


def score(program, distance: CloudDistance, pose: bool, values: Mapping[str, float],
          turn: float) -> tuple[float, Placement]:
    """One candidate's distance to the target and where it sits: sampled, aligned (with
    `pose`, else at its start's turn) and measured; inf for a combination the program refuses."""
    where = Placement(turn=turn)
    try:
        points = shape_points(program, values)
    except ValueError:
        return math.inf, where
    where = align(points, distance, where) if pose else where
    return distance(where.apply(points)), where


class Scorer:
    """Scores batches of candidates (values, turn) against one target. With `helpers` > 0 a
    batch is shared out between this process and as many helper processes (`helper_pool`),
    each with its own Blender and program: the same numbers, in the same order, sooner."""

    def __init__(self, program, target: np.ndarray, trim: float, pose: bool, helpers: int = 0):
        self.program, self.target, self.trim, self.pose = program, target, trim, pose
        self.distance = CloudDistance(target, trim)   # (the helpers build theirs from the same target)
        self.helpers = helpers
        self.pool = helper_pool(program.domain, helpers) if helpers > 0 else None
        self.token = uuid.uuid4().hex     # which target the helpers' cached distance is for

    def __call__(self, batch: list[tuple[dict, float]]) -> list[tuple[float, Placement]]:
        return share_out(self.pool, self.helpers, batch,
                         lambda item: score(self.program, self.distance, self.pose, *item),
                         _helper_score, self.token, self.target, self.trim, self.pose)


def share_out(pool, helpers: int, batch: list, here, there, *args) -> list:
    """[here(item) for item in batch], the first of `helpers` + 1 equal shares done here and the
    others by `there(*args, share)` in the pool's helper processes at the same time; in order."""
    if pool is None or len(batch) < 2:
        return [here(item) for item in batch]
    parts = np.array_split(np.arange(len(batch)), helpers + 1)
    futures = [pool.submit(there, *args, [batch[k] for k in part]) for part in parts[1:] if len(part)]
    mine = [here(batch[k]) for k in parts[0]]
    return mine + [r for f in futures for r in f.result()]


_POOLS: dict[tuple[str, int], object] = {}
_HELPER: dict = {}    # in a helper process: its program, and what it keeps for the last target


def helper_pool(domain: str, helpers: int):
    """`helpers` processes that score candidates of the domain's program, kept for the rest of
    this process. They start at the first call, in the background (Blender and the program
    load in a few seconds): call it early."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    key = (domain, helpers)
    if key not in _POOLS:   # spawn: a fork would copy this process's Blender and its threads
        pool = ProcessPoolExecutor(helpers, mp_context=get_context("spawn"),
                                   initializer=_helper_start, initargs=(domain,))
        for _ in range(helpers):
            pool.submit(int)   # starts each process now, not at the first batch
        _POOLS[key] = pool
    return _POOLS[key]


def _helper_start(domain: str) -> None:
    import sys
    from pathlib import Path

    from geocode.program import Program

    # A spawned process gets the sys.path of its parent, where Blender, once imported, put
    # its scripts/modules: their Python-side `bpy` package would shadow the module itself.
    sys.path[:] = [p for p in sys.path if not (Path(p) / "bpy" / "__init__.py").exists()]
    _HELPER["program"] = Program.load(domain)


def helper_state(token: str, make):
    """In a helper process: (its program, `make(program)`), made once per `token` (a fit's
    target: a helper serves one fit at a time, so one is kept)."""
    if _HELPER.get("token") != token:
        _HELPER["token"], _HELPER["state"] = token, make(_HELPER["program"])
    return _HELPER["program"], _HELPER["state"]


def _helper_score(token: str, target: np.ndarray, trim: float, pose: bool,
                  batch: list[tuple[dict, float]]) -> list[tuple[float, Placement]]:
    program, distance = helper_state(token, lambda _: CloudDistance(target, trim))
    return [score(program, distance, pose, v, t) for v, t in batch]


def fit(program, recipe, starts: Sequence[Start], target: np.ndarray, budget: int, tuning: CloudFit,
        seed: int = 0, restarts: int | None = None, pose: bool = True, helpers: int = 0) -> FitResult:
    """Search at most `budget` program evaluations for the shape nearest `target` (N, 3), a
    cloud on the unit sphere with +Z up, as `tuning` (the config's fit.cloud) says; with
    `pose`, each candidate is first aligned to the target (`align`), else it keeps its start's
    turn. Every start is scored first; CMA-ES then runs from the best `restarts` of them
    (default tuning.restarts), sharing what is left of the budget. `helpers`: processes that
    score candidates beside this one (`Scorer`)."""
    started = time.perf_counter()
    restarts = tuning.restarts if restarts is None else restarts
    scorer = Scorer(program, target, tuning.trim, pose, helpers)
    spaces = [SearchSpace(recipe, Start(program.check(snapped(recipe, s.values)), s.options, s.turn))
              for s in starts[:max(1, budget)]]
    curve: list[float] = []
    found: dict[int, tuple[float, np.ndarray, Placement]] = {}   # start -> its best (f, x, pose)

    def evaluate(candidates: Sequence[tuple[int, np.ndarray]]) -> list[float]:
        """The distances of candidates (start i, x), scored in one batch (inf where the
        recipe's rules fail)."""
        values = [spaces[i].values(np.asarray(x)) for i, x in candidates]
        valid = [k for k, v in enumerate(values) if recipe.satisfies(v)]
        batch = [(values[k], spaces[candidates[k][0]].start.turn) for k in valid]
        scored = dict(zip(valid, scorer(batch), strict=True))
        out = []
        for k, (i, x) in enumerate(candidates):
            value, where = scored.get(k, (math.inf, Placement(turn=spaces[i].start.turn)))
            if value < found.get(i, (np.inf,))[0]:
                found[i] = (value, np.asarray(x), where)
            curve.append(min(value, curve[-1]) if curve else value)
            out.append(value)
        return out

    scores = evaluate([(i, space.x0()) for i, space in enumerate(spaces)])
    order = np.argsort(scores, kind="stable")
    best_i, best_x = int(order[0]), spaces[order[0]].x0()
    before = best = float(scores[best_i])
    runs = order[:max(1, min(restarts, len(order)))]
    for r, i in enumerate(runs):
        x, f = spaces[i].x0(), float(scores[i])
        def batch(xs: Sequence[np.ndarray], i: int = int(i)) -> list[float]:
            return evaluate([(i, x) for x in xs])

        for step in tuning.sweep_steps if r == 0 else ():
            x, f = sweep_discrete(batch, spaces[i], x, f, budget - len(curve))
            x, f = sweep_continuous(batch, spaces[i], x, f, budget - len(curve), step)
        share = (budget - tuning.polish - len(curve)) // (len(runs) - r)
        y, g = cma_search(batch, x, share, seed + r, tuning.sigma)
        x, f = (y, g) if g < f else (x, f)
        if f < best:
            best, best_x, best_i = f, x, int(i)

    def polish(xs: Sequence[np.ndarray]) -> list[float]:
        return evaluate([(best_i, x) for x in xs])

    for step in tuning.polish_steps if tuning.polish else ():
        best_x, best = sweep_discrete(polish, spaces[best_i], best_x, best, budget - len(curve))
        best_x, best = sweep_continuous(polish, spaces[best_i], best_x, best, budget - len(curve), step)
    runs_found = [(spaces[i].values(found[i][1]), found[i][2]) for i in runs if i in found]
    return FitResult(values=spaces[best_i].values(best_x), pose=found[best_i][2], before=before,
                     after=best, evaluations=len(curve), start=best_i,
                     seconds=time.perf_counter() - started, curve=curve, found=runs_found,
                     scores=[float(x) for x in scores])


def snapped(recipe, values: Mapping[str, float]) -> dict[str, float]:
    """`values` with each continuous recipe parameter rounded to SNAP of its range. Readings
    of one input that differ by rounding (the input turned, its canonical cloud 1e-7 away)
    then give the same starts, where the feedback's rounds would grow a 1e-7 difference
    100-fold a round and the fit end elsewhere (docs/design.md#pose-and-sampling)."""
    out = dict(values)
    for p in recipe.parameters:
        if p.kind == "float" and p.name in out and p.max > p.min:
            steps = round((out[p.name] - p.min) / (p.max - p.min) / SNAP)
            out[p.name] = min(p.max, p.min + steps * SNAP * (p.max - p.min))
    return out


def network_feedback(read, render, recipe, wanted: Mapping[str, float], values: Mapping[str, float],
                     rounds: int) -> list[tuple[dict, np.ndarray]]:
    """The network's answer corrected by its own misreading, `rounds` times: each round moves
    every continuous parameter that the network reads by the difference between its reading
    of the input (`wanted`) and of the current shape rendered as its input (`render`: values
    -> a cloud or a drawing, None for a shape the program refuses),

        v <- clip(v + r(input) - r(render(v)))     (r = `read`: `checkpoints.reader`),

    the first round from r(render) = v itself (the input's reading). What the network misreads
    alike in both cancels: the fixed point is the shape that it reads as it reads the input.
    [(values, rendered)] of each round; it stops early where the recipe's rules fail or the
    program refuses."""
    ranges = {p.name: (p.min, p.max) for p in recipe.parameters}
    values, seen, found = dict(values), {}, []
    for _ in range(rounds):
        moved = {k: float(np.clip(values[k] + v - seen.get(k, values[k]), *ranges[k])) for k, v in wanted.items()}
        values.update(snapped(recipe, moved))
        rendered = render(values) if recipe.satisfies(values) else None
        if rendered is None:
            break
        found.append((dict(values), rendered))
        seen = read(rendered[None])[0]
    return found


def cloud_feedback(read, program, recipe, cloud: np.ndarray, start: Start, points_cfg, seed: int,
                   rounds: int) -> list[Start]:
    """`network_feedback` on a cloud, as starts of the fit: the network reads the input `cloud`
    (its canonical cloud, as it saw it) turned to `start`'s turn beside each of `rounds` rounds'
    shapes (the config's fit.cloud.feedback),
    sampled as its clouds are (FEEDBACK_POINTS surface points, then `points.network_cloud`).
    On the eight development cabinets these starts took the fit 0-7% nearer on every file
    (median 0.706x -> 0.679x the nearest training shape; docs/design.md#network-feedback)."""
    from geocode.points import network_cloud

    rng = np.random.default_rng(seed)

    def render(values: Mapping[str, float]) -> np.ndarray | None:
        try:
            return network_cloud(shape_points(program, values, FEEDBACK_POINTS), points_cfg, rng)
        except ValueError:   # a combination the program refuses
            return None

    wanted = read(turn_about_z(cloud, -start.turn)[None].astype(np.float32))[0]
    rounds_found = network_feedback(read, render, recipe, wanted, program.check(start.values), rounds)
    return [Start(values, start.options, start.turn) for values, _ in rounds_found]


def cma_search(objective, x0: np.ndarray, budget: int, seed: int, sigma: float,
               stds: Sequence[float] | None = None) -> tuple[np.ndarray, float]:
    """The best (x, f) CMA-ES finds within `budget` evaluations from x0 in the unit box;
    `objective` takes a generation's candidates and gives their values (inf for an invalid
    shape). Initial step `sigma`, times `stds` per coordinate where given."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # cma warns that matplotlib (plots only) is missing
        import cma

    best_x, best, used = x0, np.inf, 0
    if budget < 2:
        return best_x, best
    options = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "maxfevals": budget,
               "tolfun": 0.0, "tolx": 1e-6}
    if stds is not None:
        options["CMA_stds"] = list(stds)
    es = cma.CMAEvolutionStrategy(x0, sigma, options)
    while used < budget and not es.stop():
        xs = es.ask()
        fs = objective(xs[: budget - used])   # the budget may end inside a generation
        used += len(fs)
        k = int(np.argmin(fs))
        if fs[k] < best:
            best, best_x = fs[k], np.asarray(xs[k])
        if len(fs) < len(xs):
            break
        es.tell(xs, [f if np.isfinite(f) else 1e9 for f in fs])
    return best_x, best


def sweep_discrete(objective, space: SearchSpace, x: np.ndarray, f: float,
                   budget: int) -> tuple[np.ndarray, float]:
    """Greedy: each discrete parameter that the shape shows in turn tries its other candidate
    values (the network's next choices), keeping any that lowers `objective` (a batch of
    candidates -> their values, as `cma_search`'s); at most `budget` evaluations. CMA-ES moves
    a discrete coordinate only as one of dozens at once, so that a wrong class of the network
    (a leg or slat count) is rarely corrected without this sweep. One parameter's choices
    differ from the shape in that parameter alone, kept or not, so they go in one batch (which
    the fit's helpers share), with the answer of trying them one after the other."""
    x, used = np.array(x, dtype=np.float64), 0
    first, shown = len(space.continuous), space.shown(x)
    for j, (p, values) in enumerate(space.discrete):
        if not shown[p.name]:   # a leg count without legs: no evaluation spent
            continue
        tries = [np.concatenate([x[:first + j], [(k + 0.5) / len(values)], x[first + j + 1:]])
                 for k in range(1, len(values))][:max(0, budget - used)]
        used += len(tries)
        kept = f
        for y, g in zip(tries, objective(tries) if tries else [], strict=True):
            if g < f:
                x, f = y, g
        if f < kept:
            shown = space.shown(x)
    return x, f


def sweep_continuous(objective, space: SearchSpace, x: np.ndarray, f: float, budget: int,
                     step: float = 0.15, extra: int = 0) -> tuple[np.ndarray, float]:
    """Greedy: each continuous parameter that the shape shows, then each of the `extra`
    coordinates after the parameters' (a drawing's camera), in turn tries +-`step` in the unit
    box (the second side only when the first does not help), keeping what lowers `objective`
    (as `sweep_discrete`'s);
    at most `budget` evaluations. Most parameters change one part of the shape; one at a time,
    each change is judged on its own, where a population of random moves of all of them at
    once mixes good and bad ones. A parameter of a part the shape lacks changes nothing, so
    it is skipped rather than given evaluations (docs/design.md#fit)."""
    x, used = np.array(x, dtype=np.float64), 0
    shown = space.shown(x)
    for j in [*range(len(space.continuous)), *range(len(x) - extra, len(x))]:
        if j < len(space.continuous) and not shown[space.continuous[j].name]:
            continue
        for sign in (1.0, -1.0):
            if used >= budget:
                return x, f
            y = x.copy()
            y[j] = np.clip(y[j] + sign * step, 0.0, 1.0)
            if y[j] == x[j]:
                continue
            g = objective([y])[0]
            used += 1
            if g < f:
                x, f = y, g
                shown = space.shown(x)
                break
    return x, f


def turn_about_z(points: np.ndarray, angle: float) -> np.ndarray:
    """Points turned by `angle` radians about +Z."""
    return Placement(turn=angle).apply(points)


def network_starts(model, recipe, cloud: np.ndarray, turns: int, decode: str,
                   top: int = 3) -> list[Start]:
    """The network's answer for the input turned by each of `turns` even angles about +Z
    (one batch): a `Start` each, whose pose turns the program's shape back onto the input."""
    from geocode.checkpoints import ranked_predictions

    angles = [2 * math.pi * k / turns for k in range(turns)]
    batch = np.stack([turn_about_z(cloud, -a) for a in angles]).astype(np.float32)
    ranked = ranked_predictions(model, recipe, "points", batch, decode, top)
    return [Start(values, options, turn=a) for (values, options), a in zip(ranked, angles, strict=True)]
