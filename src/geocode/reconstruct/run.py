"""`geocode reconstruct`: a user's meshes, scans, point clouds or drawings -> the program's
parameters, its mesh (in the program's frame and back over the input), an editable .blend,
and a page of every input beside its result.

A mesh or cloud (any file `geocode.reconstruct.inputs` reads) is brought to the training data's frame:
its up axis found (`--up auto`, `geocode.reconstruct.pose`; with auto, the two likeliest axes are both
tried), centred and scaled to the unit sphere, and sampled as the dataset's clouds are. The
network then sees it at TURNS turns about its up axis in one batch (the front of a real shape
is anyone's guess), and its answer at the turn nearest the input is corrected by its own
feedback (`fit.cloud_feedback`); the nearest of those rounds is the network's answer (all of
`--budget 0`). Its answers, its feedback rounds and the nearest training shapes are the
starts of `geocode.reconstruct.fit`, which scores every start and searches the program's parameters and
the shape's pose from the best.
A drawing of any size and stroke width is cropped to its strokes, scaled to the sketches'
extent, its strokes thinned or thickened to theirs (2 px), and binarised onto a 224x224 white
canvas; the network answers it, and `geocode.reconstruct.sketchfit` searches the parameters and the camera
for the shape whose line drawing is nearest its strokes (docs/design.md#drawing-fit).
"""

from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import trimesh
import yaml
from PIL import Image
from scipy import ndimage

from geocode.errors import UserError, one_line
from geocode.meshio import normalise_unit_sphere
from geocode.metrics import chamfer
from geocode.points import network_cloud
from geocode.reconstruct import pose as poses
from geocode.reconstruct.fit import (
    CloudDistance,
    FitResult,
    Placement,
    Start,
    cloud_feedback,
    fit,
    helper_pool,
    network_starts,
    shape_points,
)
from geocode.reconstruct.inputs import IMAGE_SUFFIXES, Geometry, open_image, read_geometry, surface_points

log = logging.getLogger(__name__)

SKETCH_SIZE = 224
SKETCH_EXTENT = 191            # median extent of the strokes in the dataset's sketches (px)
STROKE = 2.0                   # their stroke width (px)
TURNS = 8                      # turns about the up axis at which the network sees a 3D input
UP_CANDIDATES = 2              # up axes tried with --up auto
NEAREST = 3                    # nearest training shapes added to the starts
TARGET_POINTS = 4096           # points of the input the fit compares with
WORKERS = 8                    # default processes at most (a CMA-ES generation: 12-17 candidates)
SCORE_POINTS = 10000           # points each of the reported (plain) Chamfer distances
PAGE_NOTE = ("Chamfer distance to the input: unit sphere, squared, mean of both directions / 2;"
             " drawings: mean distance between the strokes (px of 224), both ways / 2")


def sketch_from_image(path: Path) -> np.ndarray:
    """A drawing (dark strokes on a light background, any size) as a training sketch:
    (1, 224, 224) float32, white 1, strokes 0."""
    with open_image(path) as im:
        try:
            im.load()
            rgba = im.convert("RGBA")
        except (OSError, ValueError) as exc:
            raise UserError(path, f"not a readable image ({one_line(exc, 120)})", "save the drawing again") from None
    white = Image.new("RGBA", rgba.size, "white")
    gray = np.asarray(Image.alpha_composite(white, rgba).convert("L"))
    darkest, lightest = int(gray.min()), int(gray.max())
    if lightest - darkest < 32:
        raise UserError(f"{path}: the image is blank (no strokes); draw dark lines on white")
    ink = gray < (lightest + darkest) / 2
    ys, xs = np.nonzero(ink)
    ink = ink[ys.min():ys.max() + 1, xs.min():xs.max() + 1]
    width = 2 * np.percentile(ndimage.distance_transform_edt(ink)[ink], 90)
    scale = SKETCH_EXTENT / max(ink.shape)
    size = (max(1, round(ink.shape[1] * scale)), max(1, round(ink.shape[0] * scale)))
    small = np.asarray(Image.fromarray(ink.astype(np.uint8) * 255).resize(size, Image.BOX)) / 255
    scaled_width = width * scale
    strokes = small > (0.5 if scaled_width >= STROKE else 0.2)   # keep thin strokes whole
    reach = round(scaled_width / 2)
    if reach > round(STROKE / 2):
        strokes = centre_lines(strokes, reach)
    canvas = np.ones((SKETCH_SIZE, SKETCH_SIZE), dtype=np.float32)
    top, left = (SKETCH_SIZE - strokes.shape[0]) // 2, (SKETCH_SIZE - strokes.shape[1]) // 2
    canvas[top:top + strokes.shape[0], left:left + strokes.shape[1]][strokes] = 0.0
    return canvas[None]


def centre_lines(strokes: np.ndarray, reach: int) -> np.ndarray:
    """Strokes of any width (half-widths up to `reach` px) thinned to about the sketches'
    2 px: a pixel stays where its distance to the background is within 1 px of the largest in
    its neighbourhood, i.e. on its stroke's centre line. Unlike erosion, thin strokes and
    fine details stay whole."""
    depth = ndimage.distance_transform_edt(strokes)
    ridge = ndimage.maximum_filter(depth, size=2 * reach + 1)
    return strokes & (depth >= ridge - 1.0)


# -- one input -----------------------------------------------------------------------------------

@dataclass
class Frame:
    """A 3D input in the canonical frame of one up axis: `pose` (input -> canonical), its
    surface samples there, and the network's cloud of them."""

    pose: poses.Pose
    samples: np.ndarray
    cloud: np.ndarray


@dataclass
class Answer:
    """One fitted program: raw values, where it sits on the canonical input, its distance."""

    values: dict[str, float]
    where: Placement
    chamfer: float


@dataclass
class Reconstruction:
    path: Path
    kind: str                          # "mesh", "cloud" or "drawing"
    answers: list[Answer]              # best first; [0] is the result
    frame: Frame | None = None         # 3D inputs
    network: float | None = None       # plain Chamfer distance of the network's answer (its best
                                       # turn, then the nearest of its feedback rounds)
                                       # (drawings: the drawing distance in px, as `after`)
    geometry: Geometry | None = None
    drawing: np.ndarray | None = None  # (1, 224, 224), drawings
    result_drawing: np.ndarray | None = None   # ... Freestyle's drawing of the fitted answer
    camera: object = None              # ... the view it was drawn from (a linedraw.View)
    fit: FitResult | None = None
    summary: dict = field(default_factory=dict)


class Reconstructor:
    """What every input of one run shares: the program, the model, the training shapes."""

    def __init__(self, cfg, domain: str, checkpoint: Path | None = None,
                 refine: int | None = None, up: str = "auto", candidates: int = 1, model: bool = True,
                 workers: int | None = None):
        from geocode import paths
        from geocode.checkpoints import default_checkpoint, load_model
        from geocode.config import settings
        from geocode.program import Program

        self.cfg, self.domain, self.up, self.candidates = cfg, domain, up, candidates
        if up != "auto":
            poses.axis_rotation(up)               # a bad --up: one line before any work
        self.program = Program.load(domain)
        self.recipe = self.program.recipe()
        self.refine_given = refine
        self.refine = cfg.eval.reconstruct_budget if refine is None else refine
        self.tuning = settings(cfg).fit           # how the fits search (fit.cloud, fit.drawing)
        self.model = self.training = None
        if not model:                             # the pose and the scores alone (bench span)
            return
        # processes beside this one that score the fit's candidates: started now, so that
        # their Blender loads while the network and the training shapes do
        self.helpers = (default_workers() if workers is None else workers) - 1
        if self.refine > 0 and self.helpers > 0:
            helper_pool(domain, self.helpers)
        self.checkpoint = checkpoint or default_checkpoint(cfg, domain)
        if not self.checkpoint.is_file():
            raise UserError(
                f"{self.checkpoint}: no trained {domain} model; run `snakemake -j2 results/tables` "
                f"(or `geocode train domain={domain}`) first, or pass --checkpoint")
        self.model = load_model(self.checkpoint, recipe=self.recipe)
        self.training = training_shapes(paths.split_dir(cfg, domain, "train"))

    def __call__(self, path: Path) -> Reconstruction:
        started = time.perf_counter()
        if path.suffix.lower() in IMAGE_SUFFIXES:
            result = self.drawing(path)
        else:
            result = self.shape(path)
        result.summary.update(input=str(path), kind=result.kind, checkpoint=str(self.checkpoint),
                              seconds=round(time.perf_counter() - started, 2))
        return result

    def drawing(self, path: Path) -> Reconstruction:
        """The network's answer to a drawing, then (unless --budget 0) `sketchfit`'s search of
        the parameters and the camera; both scored by Freestyle's drawing of them."""
        from geocode.checkpoints import ranked_prediction, reader
        from geocode.config import sketch_fit_budget, sketch_fit_searches
        from geocode.reconstruct.linedraw import drawing_distance
        from geocode.reconstruct.sketchfit import fit_drawing, freestyle_drawing

        sketch = sketch_from_image(path)
        values, options = ranked_prediction(self.model, self.recipe, "sketch", sketch, self.cfg.eval.decode)
        network = Answer(self.program.check(values), Placement(), math.nan)
        result = Reconstruction(path, "drawing", [network], drawing=sketch)
        budget = sketch_fit_budget(self.cfg, self.domain) if self.refine_given is None else self.refine_given
        if budget == 0:
            return result
        found = fit_drawing(self.program, self.recipe, [Start(values, options)], sketch, budget,
                            self.tuning.drawing, seed=self.cfg.seed, helpers=self.helpers,
                            read=reader(self.model, self.recipe, "sketch"),
                            **sketch_fit_searches(self.cfg, self.domain))

        def scored(values: dict, camera) -> tuple[float, np.ndarray]:
            drawn = freestyle_drawing(normalise_unit_sphere(self.program.evaluate(values)), camera)
            return drawing_distance(drawn, sketch), drawn

        result.network, _ = scored(network.values, found.start_camera)
        after, result.result_drawing = scored(found.values, found.camera)
        result.answers = [Answer(self.program.check(found.values), Placement(), after)]
        result.camera = found.camera
        result.summary.update(camera=asdict(found.camera), drawing_before=round(result.network, 3),
                              drawing_after=round(after, 3), evaluations=found.evaluations)
        return result

    def shape(self, path: Path) -> Reconstruction:
        from geocode.checkpoints import reader

        geometry = read_geometry(path)
        frames = self.frames(geometry)
        answers = [network_starts(self.model, self.recipe, f.cloud, TURNS, self.cfg.eval.decode) for f in frames]
        read = reader(self.model, self.recipe, "points")
        found = [self.network_answer(f, a, read) for f, a in zip(frames, answers, strict=True)]
        i = int(np.argmin([a.chamfer for a, _ in found]))   # the up axis whose answer is nearest
        frame, (network, feedback) = frames[i], found[i]
        result = Reconstruction(path, geometry.kind, [], frame, geometry=geometry)
        result.network = network.chamfer
        matches = self.training.matches(frame.samples[:SCORE_POINTS], NEAREST) if self.training else []
        if self.refine > 0:   # the fit
            starts = answers[i] + self.nearest_starts(matches, answers[i]) + feedback
            result.fit = fit(self.program, self.recipe, starts, frame.samples[:TARGET_POINTS],
                             self.refine, self.tuning.cloud, seed=self.cfg.seed,
                             restarts=max(self.tuning.cloud.restarts, self.candidates),
                             helpers=self.helpers)
            fitted = [Answer(v, w, self.score(frame, v, w)) for v, w in result.fit.found]
            result.answers = distinct_answers([*fitted, network], self.candidates)
        else:
            result.answers = [network]
        best = result.answers[0]
        result.summary.update(
            note=geometry.note, up=frame.pose.up, pose=placement(frame, best.where),
            chamfer_before=round(result.network, 6), chamfer_after=round(best.chamfer, 6),
            **({"evaluations": result.fit.evaluations} if result.fit else {}),
            **self.baselines(frame, matches))
        return result

    def baselines(self, frame: Frame, matches: list) -> dict:
        """The distances of the two answers that need no network, in the pose found: the
        nearest training shape (`matches`, nearest first) and the program's defaults, each at
        its best quarter-turn about the up axis."""
        defaults = self.points({}, SCORE_POINTS)
        out = {"chamfer_defaults": round(min(chamfer(Placement(turn=k * math.pi / 2).apply(defaults),
                                                     frame.samples[:SCORE_POINTS]) for k in range(4)), 6)}
        if matches:
            out["chamfer_nearest"] = round(matches[0].chamfer, 6)
        return out

    def frames(self, geometry: Geometry) -> list[Frame]:
        rng = np.random.default_rng(self.cfg.seed)
        samples = surface_points(geometry, self.cfg.data.points.surface, rng)
        ups = (poses.up_candidates(samples, self.domain, UP_CANDIDATES) if self.up == "auto"
               else [self.up])
        frames = []
        for up in ups:
            pose = poses.find_pose(samples, up=up, domain=self.domain, mesh=geometry.mesh, squared=self.up == "auto")
            canonical = pose.to_canonical(samples).astype(np.float32)
            frames.append(Frame(pose, canonical, network_cloud(canonical, self.cfg.data.points, rng)))
        return frames

    def network_answer(self, frame: Frame, answers: list[Start], read) -> tuple[Answer, list[Start]]:
        """The network's answer in one frame: its answer at the turn nearest the input
        (`answers`: one per turn), or the nearest of its own feedback rounds from there
        (`fit.cloud_feedback`, `read` the network's reader); and those rounds, as starts of the
        fit. The up axis is chosen by these answers, after the feedback: a box's first answer
        may fit as well on a side or upside down, its corrected ones less often (the
        development set: docs/design.md#network-feedback)."""
        _, start = self.best_answer(frame, answers)
        feedback = cloud_feedback(read, self.program, self.recipe, frame.cloud, start, self.cfg.data.points,
                                  self.cfg.seed, self.tuning.cloud.feedback)
        best = min((Answer(self.program.check(s.values), where, self.score(frame, s.values, where))
                    for s in [start, *feedback] for where in [start_placement(s)]), key=lambda a: a.chamfer)
        return best, feedback

    def best_answer(self, frame: Frame, answers: list[Start]) -> tuple[float, Start]:
        """(plain distance, answer) of the network's answer (one per turn) nearest the input."""
        plain = CloudDistance(frame.samples[:TARGET_POINTS], trim=0.0)
        return min(((plain(start_placement(s).apply(self.points(s.values))), s) for s in answers), key=lambda t: t[0])

    def nearest_starts(self, matches: list, starts: list[Start]) -> list[Start]:
        """The nearest training shapes (`retrieval.Match`es) as starts of the fit, each with the
        discrete options of the network's answer (`starts`, one per turn) at the nearest turn
        after its own values."""
        nearest = []
        for match in matches:
            values = yaml.safe_load(match.mesh_path.with_suffix(".yaml").read_text())
            turn = min(starts, key=lambda s: abs(math.remainder(s.turn - match.turn, 2 * math.pi)))
            options = {name: list(dict.fromkeys([float(values[name]), *o]))
                       for name, o in turn.options.items() if name in values}
            nearest.append(Start(self.program.check(values), options, match.turn))
        return nearest

    def points(self, values: dict, n: int = 2048) -> np.ndarray:
        return shape_points(self.program, self.program.check(values), n)

    def score(self, frame: Frame, values: dict, where: Placement) -> float:
        """The plain Chamfer distance (SCORE_POINTS each, squared, mean of both directions / 2)
        between the input and a posed shape, on the input's unit sphere."""
        return chamfer(where.apply(self.points(values, SCORE_POINTS)), frame.samples[:SCORE_POINTS])

    def mesh(self, answer: Answer) -> trimesh.Trimesh:
        """The answer's mesh posed on the canonical input (part labels kept)."""
        mesh = normalise_unit_sphere(self.program.evaluate(answer.values))
        posed = trimesh.Trimesh(answer.where.apply(mesh.vertices), mesh.faces, process=False)
        posed.metadata.update(mesh.metadata)
        return posed


def start_placement(start: Start) -> Placement:
    """Where a start's shape sits: turned by the start's turn, unscaled, not moved."""
    return Placement(turn=start.turn)


def distinct_answers(answers: list[Answer], k: int) -> list[Answer]:
    """The k best answers whose values differ (rounded), best first."""
    out, seen = [], set()
    for answer in sorted(answers, key=lambda a: a.chamfer):
        key = tuple(sorted((n, round(v, 3)) for n, v in answer.values.items()))
        if key not in seen:
            seen.add(key)
            out.append(answer)
    return out[:max(1, k)]


def training_shapes(split_dir: Path):
    """The run's training shapes for retrieval, or None (with a line) where there are none."""
    from geocode.reconstruct.retrieval import TrainingShapes

    try:
        return TrainingShapes.from_split(split_dir)
    except ValueError:
        log.info("%s: no training shapes; the network's answers alone start the fit", split_dir)
        return None


# -- the command --------------------------------------------------------------------------------

def default_workers() -> int:
    return min(len(os.sched_getaffinity(0)), WORKERS)


def reconstruct(cfg, domain: str, input_path: Path, out_dir: Path, checkpoint: Path | None = None,
                refine: int | None = None, up: str = "auto", candidates: int = 1,
                recursive: bool = False, workers: int | None = None) -> dict:
    """Reconstruct one input file, or every input of a folder, into `out_dir`: per input
    <name>.yaml, .obj, .in-place.obj (3D inputs), .png and .blend (all of them, or none where
    that input fails; names: `geocode.reconstruct.plan`), and `index.html` + `summary.csv` over
    all inputs. `workers` processes: one file's fit shares its candidates between them (this
    one included); a folder's files are spread over them (`geocode.reconstruct.workers`), each
    reconstructing whole files, and gathered here in input order."""
    from geocode.reconstruct import page
    from geocode.reconstruct.plan import plan_run

    plan = plan_run(Path(input_path), Path(out_dir), recursive, candidates)
    settings = {"domain": domain, "checkpoint": checkpoint, "refine": refine, "up": up, "candidates": candidates}
    many = len(plan.jobs) > 1
    entries, summaries = reconstruct_jobs(cfg, settings, plan, workers, alone=not many)
    page.write_page(entries, plan.out_dir, page_title(domain), note=PAGE_NOTE)
    return folder_summary(summaries, plan.out_dir) if many else summaries[0]


def page_title(domain: str) -> str:
    return f"geocode reconstruct {domain}"


def reconstruct_jobs(cfg, settings: dict, plan, workers: int | None = None, alone: bool = False):
    """(page entries, summaries) of the plan's inputs, in order: reconstructed by `workers`
    processes (default: one per core, at most WORKERS), a file's fit sharing its candidates
    between them or, for several files, each reconstructing whole files. An input `alone`
    stops the run on its UserError; else that is its entry."""
    from contextlib import closing

    from geocode.reconstruct.workers import spread
    from geocode.timing import Progress

    workers = default_workers() if workers is None else workers
    processes = min(workers, len(plan.jobs))
    if processes > 1:
        outcomes = spread(cfg, settings, plan, processes, workers // processes, Reconstructor, reconstruct_file)
    else:
        outcomes = in_process(cfg, settings, plan, workers, alone)
    progress = Progress(f"reconstruct {settings['domain']}", len(plan.jobs), log, every=1e9 if alone else 0.0)
    entries, summaries = [], []
    with closing(outcomes):
        for entry, summary in outcomes:
            if entry.error:
                log.warning("%s", entry.error)
            entries.append(entry)
            summaries.append(summary)
            progress.step()
    if not alone:
        progress.finish()
    return entries, summaries


def folder_summary(summaries: list[dict], out_dir: Path) -> dict:
    """A folder run's counts, the medians of its distances and seconds, and its page."""
    done = [s for s in summaries if "error" not in s]
    seconds = [s["seconds"] for s in done]
    # the medians of each kind of distance (3D inputs' Chamfer, drawings' px) apart
    medians = {f"{key}_median": round(float(np.median(values)), 6)
               for key in ("chamfer_before", "chamfer_after", "chamfer_nearest", "chamfer_defaults",
                           "drawing_before", "drawing_after")
               if (values := [s[key] for s in done if key in s])}
    return {"inputs": len(summaries), "reconstructed": len(done), "failed": len(summaries) - len(done),
            **medians,
            "seconds_median": round(float(np.median(seconds)), 2) if seconds else None,
            "seconds_range": [min(seconds), max(seconds)] if seconds else None,
            "page": str(Path(out_dir) / "index.html")}


def in_process(cfg, settings: dict, plan, workers: int, alone: bool):
    """(page entry, summary) of each input, reconstructed in this process, in order. An input
    `alone` has its record go with its outputs (a failed one leaves nothing); a folder's is
    written first, as its page will be whatever happens."""
    run = Reconstructor(cfg, **settings, workers=workers)
    if not alone:
        plan.write_record()
    for job in plan.jobs:
        yield reconstruct_file(run, job, plan.out_dir, alone=alone, record=plan if alone else None)


def reconstruct_file(run: Reconstructor, job, out_dir: Path, alone: bool = False, record=None):
    """One input reconstructed and its files written: (its page entry, its summary). A UserError
    stops the run where the input is `alone`; else it is the input's entry (its one line)."""
    from geocode.reconstruct import page

    started = time.perf_counter()
    try:
        result = run(job.path)
        entry = write_outputs(run, result, job.stem, out_dir, job.name, record)
    except UserError as exc:
        if alone:
            raise
        return page.Entry(name=job.name, kind="", error=str(exc)), {"input": str(job.path), "error": str(exc)}
    # a user's seconds: the pictures, .blend and other files included
    entry.seconds = result.summary["seconds"] = round(time.perf_counter() - started, 2)
    return drawn(entry), result.summary


def drawn(entry):
    """A page entry whose pictures are drawn, without the meshes and points they were drawn
    from (a cloud's count of points stays: the page says it)."""
    from dataclasses import replace

    return replace(entry, input=None, result=None, result_drawing=None,
                   candidates=[replace(c, mesh=None) for c in entry.candidates])


def write_outputs(run: Reconstructor, result: Reconstruction, stem: Path, out_dir: Path, name: str,
                  record=None):
    """One input's files (reserved first: all of them or none) and its page entry; with
    `record` (a `plan.Plan`), the output folder's record too, in the same transaction."""
    from geocode.blender.export import write_shape
    from geocode.blender.gallery import grid
    from geocode.meshio import obj_text
    from geocode.outputs import Outputs
    from geocode.reconstruct import page

    suffixes = [".yaml", ".obj", ".png", ".blend"] + ([".in-place.obj"] if result.frame else [])
    best = result.answers[0]
    with Outputs() as out:
        files = {s: out.reserve(stem.parent / f"{stem.name}{s}") for s in suffixes}
        if record is not None:
            out.reserve(record.record_path).write_text(record.record_text())
        write_shape(files[".obj"], files[".yaml"], run.program, best.values)
        posed = run.mesh(best)
        if result.frame is not None:
            in_place = result.frame.pose.to_input_frame(posed.vertices)
            files[".in-place.obj"].write_text(obj_text(in_place, posed.faces))
        links = {s.lstrip("."): files_link(stem, s, out_dir) for s in suffixes if s != ".png"}
        entry = page.Entry(
            name=name, kind=result.kind, result=posed, seconds=result.summary.get("seconds"),
            input=result.drawing[0] if result.kind == "drawing" else input_shape(result),
            before=result.network, after=best.chamfer if result.fit or result.camera else None,
            unit=" px" if result.kind == "drawing" else "", result_drawing=result.result_drawing,
            pose=pose_facts(result), parameters=best.values, links=links,
            candidates=[page.Candidate(run.mesh(a), a.chamfer, {}) for a in result.answers[1:]])
        placed: dict[Path, Path] = {}
        page.render_entry(entry, out_dir, place=lambda p: placed.setdefault(p, out.reserve(p)))
        roles = [k for k in ("input", "result_drawing", "result") if k in entry.pictures]
        pictures = [Image.open(placed[out_dir / entry.pictures[k]]).convert("RGB") for k in roles]
        captions = [{"result_drawing": "our line drawing"}.get(k, k) for k in roles]
        grid(pictures, captions, columns=len(roles)).save(files[".png"], format="PNG")
        run.program.evaluate(best.values)     # the modifier now holds the values: save them with it
        run.program.save_blend(files[".blend"])
    return entry


def files_link(stem: Path, suffix: str, out_dir: Path) -> str:
    return (stem.parent / f"{stem.name}{suffix}").relative_to(out_dir).as_posix()


def input_shape(result: Reconstruction):
    """The input in the canonical frame, for its picture: the mesh itself, or the cloud."""
    geometry, frame = result.geometry, result.frame
    if geometry.mesh is not None:
        return trimesh.Trimesh(frame.pose.to_canonical(geometry.mesh.vertices), geometry.mesh.faces,
                               process=False)
    return frame.samples


def pose_facts(result: Reconstruction) -> dict:
    if result.camera is not None:
        view = result.camera
        return {"azimuth": view.azimuth, "elevation": view.elevation, "roll": view.roll,
                "scale": view.scale}
    if result.frame is None:
        return {}
    return {"up": result.frame.pose.up, **placement(result.frame, result.answers[0].where)}


def placement(frame: Frame, where: Placement) -> dict:
    """Where the result sits: its turn about the up axis in the input's own frame (the
    canonical frame is the input turned by `frame.pose.turn`), scale and offset."""
    out = where.to_dict()
    out["turn_deg"] = round((out["turn_deg"] - frame.pose.turn) % 360, 2)
    return out


