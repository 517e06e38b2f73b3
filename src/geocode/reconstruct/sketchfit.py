"""Fit a program to a drawing: search its parameters and the camera for the shape whose line
drawing (`geocode.reconstruct.linedraw`, a numpy stand-in for the dataset's Freestyle sketches, within
~0.2 px of them) is nearest the drawing's strokes (`linedraw.drawing_distance`).

The search space is `geocode.reconstruct.fit`'s unit box over the recipe's parameters (continuous over
their range, discrete among the network's top choices) plus six camera coordinates:
azimuth within `azimuth_span` degrees of its start (the starts go all around), elevation over
0..`max_elevation` degrees (free-hand drawings are often frontal or side views), roll within
+-`max_roll` degrees, a scale within a factor `scale_span` of its start and a shift within
+-`shift_span` px. These, and the other names in `quotes` below, are the config's fit.drawing
(`settings.DrawingFit`, conf/fit/default.yaml), which a fit is given as `tuning`.

The starts are the network's answer seen from each of `camera_guesses` (the dataset's two
trained views and their mirror images; frontal, side and back views from low down), each
framed twice: as the dataset frames a unit-sphere shape (scale 1, no shift) and with its
strokes' bounding box on the drawing's (as `reconstruct.sketch_from_image` frames a user's
drawing). Every start is scored first, a start from a view farther than NEAR_VIEW degrees of
azimuth from the dataset's trained ones counting `view_margin` px more: the network answers as
if the drawing came from those, and a view a quarter-turn away draws a shape of swapped width
and depth alike, which the search cannot tell apart from the drawing but the program's frame
can (on the table test sketches this took the fit from 0.92x to 0.43x of the network's
distance). A view that near draws no such twin, and a drawing from beside the trained views
(the test sets' third camera, 20 degrees off) starts best there (docs/design.md#drawing-fit). Given the network's reader
(`checkpoints.reader`), the best start is first corrected by the network itself
(`drawing_feedback`, `feedback` rounds): its reading of our drawing of the answer is compared
with its reading of the input, and the difference moves the continuous parameters, which
cancels what the network misreads alike in both; the best round, by the drawing distance,
replaces the start (on 30 chair test sketches of the trained cameras the fitted Chamfer
distance went from 0.58x to 0.50x of the network's, for six of the 800 evaluations; on 100
vases from 0.77x to 0.73x: docs/design.md#drawing-fit).
The network's answer may be searched once for each of the first few options of the discrete
parameter it is least sure of (`held_options`; how many: `fit_drawing`'s `branches`, per
domain in the config's eval.sketch_fit_branches), that option held, each search on an equal
share of the evaluations; the branch whose drawing ends nearest is the answer (with
`orders` 2, each branch searched in both sweep orders, below). Within a search, from the
best start, for each of `sweep_steps`: every shown discrete parameter's other choices one at a
time, then every shown continuous parameter and camera coordinate +-step one at a time (or
the continuous sweep first: a switch judged on a shape fitted around the start's structure;
`fit.sweep_discrete`, `fit.sweep_continuous`), keeping what helps (coordinate sweeps: one
parameter mostly moves one part of the drawing, and the network's answer is near, so single
moves judged alone beat a population of 60-dimensional random moves at these budgets); then
CMA-ES with per-coordinate steps on everything with what is left. The objective adds to the
drawing distance `prior` * |x - x0|^2 over the parameters' unit-box coordinates (x0: the
start's): one view leaves depth undecided, and where the drawing does not tell, the network's
answer should stand (on chair test sketches it took the fitted Chamfer distance from 0.7x to
about 0.5x of the network's). The best shape seen is the answer, so the fit never ends farther
from the drawing than the start it searched from.
Branches, measured on 30 test sketches of the trained cameras (`geocode bench fit <domain>
--modality sketch -n 30 --split test`, 800 evaluations), the fitted Chamfer distance against the network's:
three branches took the chair from 0.48x to 0.38x and the cabinet from 0.42x to 0.39x; the
table from 0.43x to 0.55x and the lamp from 0.15x to 0.22x, whose searches need the whole
budget; the vase from 0.82x to 0.67x; docs/design.md#drawing-fit),
and searching each of its branches in both sweep orders (1600 evaluations) from 0.53x to 0.49x
(novel camera 0.71x to 0.70x).
"""

from __future__ import annotations

import math
import time
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from geocode.meshio import normalise_unit_sphere
from geocode.reconstruct.fit import (
    SearchSpace,
    Start,
    cma_search,
    helper_pool,
    helper_state,
    network_feedback,
    share_out,
    sweep_continuous,
    sweep_discrete,
)
from geocode.reconstruct.linedraw import SIZE, DrawingDistance, Outline, View, stroke_mask, strokes
from geocode.settings import DrawingFit as DrawingFitSettings

# Not settings: the dataset's views, and what no result depends on.
TRAINED_VIEWS = ((35.0, 30.0), (55.0, 30.0))   # (azimuth, elevation) degrees of the dataset's training
                         # sketches (data.sketch's training cameras), the views the network answers from
NEAR_VIEW = 20.0         # degrees of azimuth: views this near a trained one start without the view
                         # margin (so near, they draw no twin of swapped width and depth)
CACHE = 8                # shapes kept between evaluations (the starts share theirs): speed only


@dataclass
class DrawingFit:
    values: dict[str, float]   # every program parameter, raw
    camera: View               # the view of the unit-sphere shape that draws like the input
    before: float              # the best start's drawing distance (px)
    after: float               # ... the fitted shape's (<= before; the curve adds the prior)
    evaluations: int
    seconds: float
    start: int = 0             # index of the start (camera guess x framing) it came from
    start_camera: View = field(default_factory=View)   # the best start's view (of `before`)
    curve: list[float] = field(default_factory=list)   # best distance after each evaluation


class CameraSpace:
    """Six unit-box coordinates <-> a `View` around a start view: azimuth, elevation, roll,
    log-scale, shift x, shift y (each coordinate's middle, 0.5, is the start's value, except
    the elevation, which spans 0..tuning.max_elevation absolutely); the spans are `tuning`'s."""

    def __init__(self, start: View, tuning: DrawingFitSettings):
        self.start, self.tuning = start, tuning

    def x0(self) -> np.ndarray:
        el = float(np.clip(self.start.elevation / self.tuning.max_elevation, 0.0, 1.0))
        return np.array([0.5, el, 0.5, 0.5, 0.5, 0.5])

    def view(self, x: np.ndarray) -> View:
        x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
        s, t = self.start, self.tuning
        return View(azimuth=s.azimuth + (2 * x[0] - 1) * t.azimuth_span,
                    elevation=x[1] * t.max_elevation,
                    roll=s.roll + (2 * x[2] - 1) * t.max_roll,
                    scale=s.scale * t.scale_span ** (2 * x[3] - 1),
                    offset=(s.offset[0] + (2 * x[4] - 1) * t.shift_span,
                            s.offset[1] + (2 * x[5] - 1) * t.shift_span))


def bounding_box(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(centre (x, y), extent (w, h)) of a stroke mask's pixels, None when blank."""
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        return None
    lo, hi = np.array([xs.min(), ys.min()]), np.array([xs.max() + 1, ys.max() + 1])
    return (lo + hi) / 2, hi - lo


def framed(view: View, ours: np.ndarray, target: np.ndarray) -> View:
    """`view` scaled and shifted so that the bounding box of `ours` (its strokes, drawn from
    `view`) lands on the target's: scale s = (w_t + h_t) / (w_o + h_o) about the image centre
    m, shift = c_t - m - s (c_o - m) (+ the view's own shift, scaled)."""
    a, b = bounding_box(ours), bounding_box(target)
    if a is None or b is None:
        return view
    s = float(np.sum(b[1]) / max(np.sum(a[1]), 1.0))
    m = SIZE / 2
    shift = b[0] - m - s * (a[0] - m - np.asarray(view.offset))
    return View(view.azimuth, view.elevation, view.roll, view.scale * s,
                (float(shift[0]), float(shift[1])))


class Shapes:
    """The program's unit-sphere outlines by parameter values, the last CACHE kept (the
    starts share one shape; a refused combination is None)."""

    def __init__(self, program):
        self.program = program
        self.kept: dict[tuple, Outline | None] = {}

    def __call__(self, values: dict[str, float]) -> Outline | None:
        key = tuple(sorted(values.items()))
        if key not in self.kept:
            try:
                mesh = normalise_unit_sphere(self.program.evaluate(values))
                self.kept[key] = Outline(mesh.vertices, mesh.faces)
            except ValueError:   # a combination the program refuses, or a degenerate mesh
                self.kept[key] = None
            if len(self.kept) > CACHE:
                self.kept.pop(next(iter(self.kept)))
        return self.kept[key]


def drawn_distance(shapes: Shapes, distance: DrawingDistance, values: dict, view: View) -> float:
    """The drawing distance of the shape of `values` seen from `view` (inf: a refused shape)."""
    outline = shapes(values)
    return math.inf if outline is None else distance(strokes(outline, view))


class Drawer:
    """Drawing distances of batches of (values, view) to one target. With `helpers` > 0 a batch
    is shared out between this process and `fit.helper_pool`'s processes, each with its own
    program and shape cache: the same numbers, in the same order, sooner."""

    def __init__(self, program, target: np.ndarray, helpers: int = 0):
        self.shapes, self.distance, self.target = Shapes(program), DrawingDistance(target), target
        self.helpers = helpers
        self.pool = helper_pool(program.domain, helpers) if helpers > 0 else None
        self.token = uuid.uuid4().hex

    def __call__(self, batch: list[tuple[dict, View]]) -> list[float]:
        return share_out(self.pool, self.helpers, batch, lambda item: drawn_distance(self.shapes, self.distance, *item),
                         _helper_distances, self.token, self.target)

    def here(self, batch: list[tuple[dict, View]]) -> list[float]:
        """Drawing distances of a batch in this process alone."""
        return [drawn_distance(self.shapes, self.distance, *item) for item in batch]

    def finish(self, recipe, tuning: DrawingFitSettings,
               jobs: list[tuple]) -> list[tuple[dict, View, float, list[float]]]:
        """`finish_search(recipe, tuning, draw, *job)` of each job, shared out whole between this
        process and the helpers (a single job draws its batches with the helpers instead)."""
        if self.pool is None or len(jobs) < 2:
            return [finish_search(recipe, tuning, self, *job) for job in jobs]
        return share_out(self.pool, self.helpers, jobs, lambda job: finish_search(recipe, tuning, self.here, *job),
                         _helper_finish, self.token, self.target, recipe, tuning)


def _helper_state(token: str, target: np.ndarray):
    """In a helper process: (its program, (Shapes, DrawingDistance to `target`)) for a fit."""
    return helper_state(token, lambda program: (Shapes(program), DrawingDistance(target)))


def _helper_distances(token: str, target: np.ndarray, batch: list[tuple[dict, View]]) -> list[float]:
    _, (shapes, distance) = _helper_state(token, target)
    return [drawn_distance(shapes, distance, v, w) for v, w in batch]


def _helper_finish(token: str, target: np.ndarray, recipe, tuning: DrawingFitSettings,
                   jobs: list[tuple]) -> list[tuple[dict, View, float, list[float]]]:
    _, (shapes, distance) = _helper_state(token, target)
    return [finish_search(recipe, tuning, lambda batch: [drawn_distance(shapes, distance, *item) for item in batch],
                          *job)
            for job in jobs]


def camera_starts(shapes: Shapes, values: dict, target: np.ndarray,
                  guesses: Sequence[Sequence[float]]) -> list[View]:
    """Each camera guess twice: the dataset's framing (scale 1, no shift), and the start
    shape's strokes framed on the drawing's (`framed`)."""
    outline = shapes(values)
    views = []
    for az, el in guesses:
        view = View(az, el)
        views.append(view)
        if outline is not None:
            views.append(framed(view, strokes(outline, view), target))
    return views


def near_trained_view(view: View) -> bool:
    """Whether a view lies at a trained view's elevation within NEAR_VIEW degrees of its
    azimuth (so near, it draws no twin of swapped width and depth)."""
    return any(view.elevation == el and abs((view.azimuth - az + 180.0) % 360.0 - 180.0) <= NEAR_VIEW
               for az, el in TRAINED_VIEWS)


def fit_drawing(program, recipe, starts: Sequence[Start], drawing: np.ndarray,
                budget: int, tuning: DrawingFitSettings, seed: int = 0, helpers: int = 0,
                read=None, branches: int = 1, orders: int = 1) -> DrawingFit:
    """Search at most `budget` program evaluations for the parameters and camera whose line
    drawing is nearest `drawing` ((224, 224) or (1, 224, 224) float, white 1, strokes 0, as
    `reconstruct.sketch_from_image` or `training_data.load_sketch` give), by
    `linedraw.drawing_distance`, as `tuning` (the config's fit.drawing) says. The first of
    `starts` (the network's answer, with its discrete options, the least sure first) is
    searched once per branch (`held_options`; at most `branches`, the config's
    eval.sketch_fit_branches, and as many as give each tuning.branch_budget evaluations), each
    on an equal share of the budget, the other starts beside it; each search tries every start
    from every camera guess and framing (`open_search`), then sweeps and CMA-ES from the best
    (`finish_search`; module docstring). With `orders` 2 (the config's eval.sketch_fit_orders)
    each branch is searched twice from its one opening, its discrete switches judged before
    and after each continuous sweep. The answer is the search whose drawing ends nearest. Its
    camera views the unit-sphere shape (`meshio.normalise_unit_sphere`) of its values.
    `helpers`: processes that draw the starts beside this one (`Drawer`) and then finish
    searches beside it, each whole (the same numbers sooner). `read`: the network's reading of
    drawings (`checkpoints.reader`), for `drawing_feedback` on the best start before the
    search (None: no feedback)."""
    started = time.perf_counter()
    drawer = Drawer(program, stroke_mask(drawing), helpers)
    first = Start(program.check(starts[0].values), starts[0].options, starts[0].turn)
    orders = max(1, min(orders, budget // tuning.branch_budget))
    held = held_options(recipe, first, min(branches, budget // (tuning.branch_budget * orders)))
    n = len(held) * orders
    shares = [budget // n + (k >= n - budget % n) for k in range(n)]   # equal, the remainder last
    openings = [open_search(program, recipe, [start, *starts[1:]], drawing, drawer, shares[b * orders], tuning, read)
                for b, start in enumerate(held)]
    jobs = [(openings[k // orders], shares[k] - len(openings[k // orders].curve), seed, k % orders == 0)
            for k in range(n)]
    ends = drawer.finish(recipe, tuning, jobs)
    curve: list[float] = []
    for d in [d for o in openings for d in o.curve] + [d for end in ends for d in end[3]]:
        curve.append(min(d, curve[-1]) if curve else d)
    k = min(range(n), key=lambda k: ends[k][2])   # the search whose drawing ends nearest
    values, camera, after, _ = ends[k]
    return DrawingFit(values=values, camera=camera, before=openings[0].before, after=after,
                      evaluations=len(curve), seconds=time.perf_counter() - started,
                      start=jobs[k][0].index, start_camera=openings[0].view, curve=curve)


@dataclass
class Opening:
    """A search after its starts and the network's feedback (`open_search`): where its
    sweeps begin, and what it cost."""
    start: Start          # the best start's values (after the feedback) and options
    view: View            # ... its view
    score: float          # ... its objective
    before: float         # the best start's drawing distance before the feedback
    index: int            # which start (camera guess x framing) it is
    curve: list[float]    # best objective after each evaluation


def objective(recipe, draw, spaces: Sequence[tuple[SearchSpace, CameraSpace]], curve: list[float],
              tuning: DrawingFitSettings):
    """(evaluate, the starts' coordinates x0): the search's objective on candidates [(start i,
    x)], drawn by `draw` in one batch: the drawing distance plus tuning.prior (and
    tuning.camera_prior) times the squared unit-box move from x0[i]; inf where the recipe's rules fail or the
    program refuses. Each value goes on `curve` as the best so far."""
    x0s = [np.concatenate([space.x0(), cams.x0()]) for space, cams in spaces]

    def evaluate(candidates: Sequence[tuple[int, np.ndarray]]) -> list[float]:
        shaped = []
        for i, x in candidates:
            space, cams = spaces[i]
            n = len(x) - 6
            shaped.append((space.values(np.asarray(x[:n])), cams.view(x[n:]), n))
        valid = [k for k, (v, _, _) in enumerate(shaped) if recipe.satisfies(v)]
        drawn = dict(zip(valid, draw([shaped[k][:2] for k in valid]), strict=True))
        out = []
        for k, (i, x) in enumerate(candidates):
            value, n = drawn.get(k, math.inf), shaped[k][2]
            if math.isfinite(value):
                moved = (np.clip(x, 0, 1) - x0s[i]) ** 2
                value += tuning.prior * float(np.sum(moved[:n])) + tuning.camera_prior * float(np.sum(moved[n:]))
            curve.append(min(value, curve[-1]) if curve else value)
            out.append(value)
        return out

    return evaluate, x0s


def open_search(program, recipe, starts: Sequence[Start], drawing: np.ndarray, drawer: Drawer,
                budget: int, tuning: DrawingFitSettings, read) -> Opening:
    """A search's first part (`fit_drawing`'s docstring): every start from every camera guess
    and framing, scored in one batch (a view far from the trained ones with tuning.view_margin),
    then the network's feedback on the best."""
    shapes, distance = drawer.shapes, drawer.distance
    spaces = []
    for s in starts:
        space = SearchSpace(recipe, Start(program.check(s.values), s.options))
        spaces += [(space, CameraSpace(v, tuning))
                   for v in camera_starts(shapes, space.start.values, drawer.target, tuning.camera_guesses)]
    curve: list[float] = []
    evaluate, x0s = objective(recipe, drawer, spaces, curve, tuning)
    scores = evaluate(list(enumerate(x0s[:max(1, budget)])))
    handicap = [0.0 if near_trained_view(cams.start) else tuning.view_margin for _, cams in spaces[:len(scores)]]
    i = int(np.argsort(np.add(scores, handicap), kind="stable")[0])
    (space, cams), before = spaces[i], float(scores[i])
    start, score = space.start, before
    if read is not None and math.isfinite(before):   # the network corrects its own reading
        rounds = drawing_feedback(read, shapes, distance, recipe, drawing, start.values, cams.start,
                                  min(tuning.feedback, budget - len(curve)))
        for d, _ in rounds:
            curve.append(min(d, curve[-1]))
        d, values = min(rounds, key=lambda r: r[0], default=(math.inf, None))
        if d < score:
            start, score = Start(values, start.options), d
    return Opening(start, cams.start, score, before, i, curve)


def finish_search(recipe, tuning: DrawingFitSettings, draw, opening: Opening, budget: int, seed: int,
                  switches_first: bool) -> tuple[dict, View, float, list[float]]:
    """A search's second part, from its opening, within `budget` evaluations: for each of
    tuning.sweep_steps, sweeps one coordinate at a time, the discrete switches before the continuous sweep
    (`switches_first`: a switch judged on the start's shape) or after it (judged on a shape
    fitted around the start's structure; each order finds answers the other misses,
    docs/design.md#drawing-fit), then CMA-ES on all. (values, view, drawing distance less the
    prior, curve) of the best candidate; `draw` as `Drawer`."""
    space, cams = SearchSpace(recipe, opening.start), CameraSpace(opening.view, tuning)
    curve: list[float] = []
    evaluate, (x,) = objective(recipe, draw, [(space, cams)], curve, tuning)
    f = opening.score

    def batch(xs: Sequence[np.ndarray]) -> list[float]:
        return evaluate([(0, x) for x in xs])

    def switches(x: np.ndarray, f: float) -> tuple[np.ndarray, float]:
        return sweep_discrete(batch, space, x, f, budget - len(curve))

    for step in tuning.sweep_steps:
        if switches_first:
            x, f = switches(x, f)
        x, f = sweep_continuous(batch, space, x, f, budget - len(curve), step, extra=6)
        if not switches_first:
            x, f = switches(x, f)
    stds = np.concatenate([np.full(len(x) - 6, tuning.sigma), tuning.camera_sigma])
    y, g = cma_search(batch, x, budget - len(curve), seed, 1.0, stds)
    best, best_x = (g, y) if g < f else (f, x)
    n = len(best_x) - 6
    values, view = space.values(best_x[:n]), cams.view(best_x[n:])
    return values, view, min(draw([(values, view)])[0], best), curve


def held_options(recipe, start: Start, k: int) -> list[Start]:
    """`start` once for each of the first k options of the discrete parameter the network is
    least sure of (the first of `start.options` that the start's shape shows and that has more
    than one option; `checkpoints.ranked_predictions` lists the least sure first), that choice
    held; [start] when none has. Near the fit's residual a drawing does not tell a vase's
    handle count, say, from widths that imitate it, so each choice gets a search of its own
    and the drawings' distances judge only finished searches (docs/design.md#drawing-fit)."""
    shown = recipe.shown(start.values)
    for name, values in start.options.items():
        if len(values) > 1 and shown[name] and k > 1:
            return [Start({**start.values, name: v}, {**start.options, name: [v]}, start.turn)
                    for v in values[:k]]
    return [start]


def drawing_feedback(read, shapes: Shapes, distance: DrawingDistance, recipe, drawing: np.ndarray,
                     values: dict, view: View, rounds: int) -> list[tuple[float, dict]]:
    """`fit.network_feedback` on a drawing: the network reads the input's strokes and our line
    drawings from `view`, both as stroke masks (the style our drawing has). [(drawing
    distance, values)] of each round."""
    def image(mask: np.ndarray) -> np.ndarray:
        return np.where(mask, 0.0, 1.0).astype(np.float32)[None]

    def render(values: dict) -> np.ndarray | None:
        outline = shapes(values)
        return None if outline is None else image(strokes(outline, view))

    wanted = read(image(stroke_mask(drawing))[None])[0]
    return [(distance(drawn), v) for v, drawn in network_feedback(read, render, recipe, wanted, values, rounds)]


# -- benches ------------------------------------------------------------------------------------

def mean_curve(curves: Sequence[Sequence[float]],
               points: Sequence[int] = (1, 10, 25, 50, 100, 200, 300, 400, 600, 800, 1200, 1600,
                                        2400)) -> dict:
    """{evaluations: the mean over fits of the best drawing distance after that many} (a fit
    that stopped earlier counts with its final value; None while a fit has found no shape the
    program makes yet, so that the JSON stays standard, without Infinity)."""
    out = {}
    for p in points:
        if curves and p <= max(len(c) for c in curves):
            mean = float(np.mean([c[min(p, len(c)) - 1] for c in curves]))
            out[p] = round(mean, 4) if math.isfinite(mean) else None
    return out


def freestyle_drawing(mesh, view: View) -> np.ndarray:
    """Freestyle's drawing (blender/sketch.py, needs bpy) of a unit-sphere mesh from `view`:
    rendered from its azimuth and elevation, then rolled, scaled and shifted in the image as
    `View.project` does (p - m = s R(roll) (q - m) + shift about the image centre m; nearest
    pixel), for scoring a fit's answer with the dataset's own renderer. (224, 224) float32,
    white 1, strokes 0."""
    import tempfile
    from pathlib import Path

    from PIL import Image
    from scipy import ndimage

    from geocode.blender.sketch import Camera, renderer

    freestyle = renderer(SIZE)
    freestyle.set_mesh(mesh.vertices, mesh.faces)
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "view.png"
        freestyle.render(Camera("fit", view.azimuth, view.elevation), png)
        with Image.open(png) as im:
            image = np.asarray(im.convert("L"), dtype=np.float32) / 255.0
    c, s = math.cos(math.radians(view.roll)), math.sin(math.radians(view.roll))
    inverse = np.array([[c, -s], [s, c]]) / view.scale      # (row, col) of the source per target
    m = SIZE / 2
    shift = np.array([view.offset[1], view.offset[0]])
    offset = m - 0.5 - inverse @ (m - 0.5 + shift)
    return ndimage.affine_transform(image, inverse, offset=offset, order=0, cval=1.0)
