"""`geocode reconstruct`: a user's mesh, point cloud or sketch -> the program's parameters,
its mesh, a preview and an editable .blend.

Inputs are brought to the training data's form: meshes are normalised to the unit sphere and
sampled as the dataset's clouds are (farthest points + random points); point clouds are
normalised the same way; a drawing of any size and stroke width is cropped to its strokes,
scaled to the sketches' extent, its strokes thinned or thickened to theirs (2 px), and
binarised onto a 224x224 white canvas. The network predicts each parameter's class; for
clouds, `fit` then searches the program's parameters for the shape nearest the input.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image
from scipy import ndimage

from geocode.errors import UserError, one_line
from geocode.meshio import normalise_unit_sphere
from geocode.points import farthest_point_sampling, sample_surface

MESHES = (".obj", ".ply", ".stl", ".glb", ".gltf")
CLOUDS = (".xyz", ".npy")      # .ply without faces is a cloud too
IMAGES = (".png", ".jpg", ".jpeg")
MIN_POINTS = 100
SKETCH_SIZE = 224
SKETCH_EXTENT = 191            # median extent of the strokes in the dataset's sketches (px)
STROKE = 2.0                   # their stroke width (px)
OUTPUTS = (".yaml", ".obj", ".png", ".blend")


@dataclass
class UserInput:
    path: Path
    kind: str                          # "points" or "sketch"
    data: np.ndarray                   # the network's input: (N, 3) or (1, 224, 224) float32


def read_input(path: str | Path, up: str | None, points_cfg) -> UserInput:
    """The network input of a mesh, cloud or drawing file; ValueError naming the file."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESHES + CLOUDS + IMAGES:
        raise UserError(f"{path}: unknown input kind {suffix or '(none)'}; give a mesh "
                         f"({', '.join(MESHES)}), a cloud ({', '.join(CLOUDS)}, .ply) or a "
                         f"drawing ({', '.join(IMAGES)})")
    if not path.is_file():
        raise UserError(f"{path}: no such file; check the path")
    if path.stat().st_size == 0:
        raise UserError(f"{path}: the file is empty; give a mesh, a point cloud or a drawing")
    if suffix in IMAGES:
        return UserInput(path, "sketch", sketch_from_image(path))
    points, mesh = _read_geometry(path)
    up = up or ("y" if suffix in (".glb", ".gltf") else "z")   # glTF is Y-up by definition
    rng = np.random.default_rng(0)
    if mesh is not None:
        mesh = trimesh.Trimesh(z_up(mesh.vertices, up), mesh.faces, process=False)
        points = sample_surface(normalise_unit_sphere(mesh), points_cfg.surface, rng)
    else:
        points = unit_sphere(z_up(points, up), path)
    return UserInput(path, "points", network_cloud(points, points_cfg, rng))


def _read_geometry(path: Path) -> tuple[np.ndarray | None, trimesh.Trimesh | None]:
    """(points, None) for a cloud file, (None, mesh) for a mesh file."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            points = np.load(path, allow_pickle=False)
        elif suffix == ".xyz":
            points = np.loadtxt(path, ndmin=2, usecols=(0, 1, 2))
        else:
            loaded = trimesh.load(path, process=False)
            if isinstance(loaded, trimesh.Scene):
                loaded = loaded.to_geometry() if loaded.geometry else None
            if isinstance(loaded, trimesh.Trimesh) and len(loaded.faces):
                return None, _finite_mesh(loaded, path)
            points = getattr(loaded, "vertices", None)
    except Exception as exc:  # numpy and trimesh raise many types for a broken file
        raise UserError(path, f"not a readable {suffix} file ({one_line(exc, 120)})",
                        "export it again from its tool") from None
    points = np.asarray(points if points is not None else np.zeros((0, 3)), dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise UserError(f"{path}: expected N x 3 coordinates, got shape {points.shape}; "
                        "give one point (x y z) per row")
    if not np.isfinite(points).all():
        raise UserError(f"{path}: {int((~np.isfinite(points)).any(axis=1).sum())} points have "
                         "NaN or infinite coordinates; remove them")
    if len(points) < MIN_POINTS:
        raise UserError(f"{path}: {len(points)} points; give at least {MIN_POINTS}")
    return points, None


def _finite_mesh(mesh: trimesh.Trimesh, path: Path) -> trimesh.Trimesh:
    if not np.isfinite(mesh.vertices).all():
        raise UserError(f"{path}: the mesh has NaN or infinite vertices; repair it")
    if not mesh.area > 0:
        raise UserError(f"{path}: the mesh has no surface area; give a mesh with faces")
    return mesh


def z_up(points: np.ndarray, up: str) -> np.ndarray:
    """Coordinates in our convention (Z up) from a Y-up or Z-up file."""
    points = np.asarray(points, dtype=np.float64)
    if up == "z":
        return points
    if up == "y":   # a quarter turn about X: (x, y, z) -> (x, -z, y)
        return np.stack([points[:, 0], -points[:, 2], points[:, 1]], axis=1)
    raise UserError(f"--up {up}: give y or z")


def unit_sphere(points: np.ndarray, path: Path) -> np.ndarray:
    """Centre on the bounding-box centre, farthest point at distance 1 (as meshes are)."""
    centred = points - (points.min(axis=0) + points.max(axis=0)) / 2
    radius = np.linalg.norm(centred, axis=1).max()
    if not radius > 0:
        raise UserError(f"{path}: all points coincide; give a cloud with some extent")
    return centred / radius


def network_cloud(points: np.ndarray, points_cfg, rng: np.random.Generator) -> np.ndarray:
    """As the evaluation clouds are: `fps` farthest points + `train_random` random ones."""
    points = np.asarray(points, dtype=np.float32)
    n_fps = min(points_cfg.fps, len(points))
    fps = farthest_point_sampling(points, n_fps)
    rest = np.setdiff1d(np.arange(len(points)), fps)
    extra = rng.choice(rest, size=min(points_cfg.train_random, len(rest)), replace=False)
    return points[np.concatenate([fps, np.sort(extra)])]


def sketch_from_image(path: Path) -> np.ndarray:
    """A drawing (dark strokes on a light background, any size) as a training sketch:
    (1, 224, 224) float32, white 1, strokes 0."""
    try:
        with Image.open(path) as im:
            im.load()
            rgba = im.convert("RGBA")
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: not a readable image ({exc})") from None
    white = Image.new("RGBA", rgba.size, "white")
    gray = np.asarray(Image.alpha_composite(white, rgba).convert("L"), dtype=np.float64)
    if gray.max() - gray.min() < 32:
        raise UserError(f"{path}: the image is blank (no strokes); draw dark lines on white")
    ink = gray < (gray.max() + gray.min()) / 2
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


# -- the command --------------------------------------------------------------------------------

def reconstruct(cfg, domain: str, input_path: Path, out_dir: Path,
                checkpoint: Path | None = None, refine: int | None = None,
                up: str | None = None) -> dict:
    """Predict (and for clouds, fit) the program's parameters for one input file and write
    <stem>.yaml, .obj, .png (input beside result) and .blend into `out_dir`: all four, or
    none where any step fails (each is reserved before the work, see `geocode.outputs`)."""
    from geocode.outputs import Outputs

    with Outputs() as out:
        files = {suffix: out.reserve(out_dir / f"{input_path.stem}{suffix}") for suffix in OUTPUTS}
        return _reconstruct(cfg, domain, input_path, files, checkpoint, refine, up)


def _reconstruct(cfg, domain: str, input_path: Path, files: dict[str, Path],
                 checkpoint: Path | None, refine: int | None, up: str | None) -> dict:
    from geocode.checkpoints import (
        check_checkpoint,
        default_checkpoint,
        load_model,
        ranked_prediction,
    )
    from geocode.fit import Start, fit
    from geocode.program import Program

    program = Program.load(domain)
    user_input = read_input(input_path, up, cfg.data.points)
    checkpoint = checkpoint or default_checkpoint(cfg, domain)
    if not checkpoint.is_file():
        raise UserError(
            f"{checkpoint}: no trained {domain} model; run `snakemake -j2 results/tables` (or "
            f"`geocode train domain={domain}`) first, or pass --checkpoint")
    recipe = program.recipe()
    model = load_model(checkpoint)
    check_checkpoint(model, recipe, checkpoint, domain)
    start, options = ranked_prediction(model, recipe, user_input.kind, user_input.data, cfg.eval.decode)
    if refine is None:
        refine = cfg.eval.fit_budget if user_input.kind == "points" else 0
    summary = {"input": str(input_path), "kind": user_input.kind, "checkpoint": str(checkpoint)}
    values = program.check(start)
    if refine > 0:
        if user_input.kind != "points":
            raise UserError("--refine: fitting needs a 3D input (mesh or cloud); give --refine 0 "
                             "for a drawing")
        result = fit(program, recipe, [Start(start, options)], user_input.data, refine, seed=cfg.seed)
        values = result.values
        summary.update(chamfer_before=round(result.before, 6), chamfer_after=round(result.after, 6),
                       evaluations=result.evaluations, fit_seconds=round(result.seconds, 2))
    write_outputs(program, values, user_input, files)
    return summary


def write_outputs(program, values: dict, user_input: UserInput, files: dict[str, Path]) -> None:
    """The values (.yaml), mesh (.obj), preview (.png) and program with its modifier set to
    `values` (.blend), each to its file in `files` (by suffix)."""
    from geocode.blender.gallery import render_preview
    from geocode.tools.editing import write_shape

    mesh = write_shape(files[".obj"], files[".yaml"], program, values)
    render_preview(user_input, mesh, files[".png"])
    program.evaluate(values)             # the modifier now holds the values: save them with it
    program.save_blend(files[".blend"])
