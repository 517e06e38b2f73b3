"""Reading a user's shape file, whatever tool made it, into one mesh or one point cloud; opening a
drawing.

`read_geometry(path)` gives a `Geometry`: a triangle mesh (every format trimesh reads without
extra packages: .obj .ply .stl .off .glb .gltf) or a cloud (.xyz .txt .pts .csv .npy .npz and a
.ply without faces), in the file's own frame and units. `surface_points(geometry, n, rng)` then
samples it. What cannot be used stops with one `UserError` line naming the file, the problem
and the fix; what was changed on the way (pieces dropped, points subsampled) is said in
`Geometry.note`, one line for the log and the result.

Scenes (glTF/GLB nodes, OBJ objects): every piece is moved by its node's transform, then the
pieces are grouped by proximity (`SCENE_RULE`, see `keep_main_object`): asset files split one
object into many pieces, and those stay together; a piece far from the rest (a second object,
a stray prop) or a ground plane under everything is dropped when what remains is clearly the
object (`MAIN_SHARE` of the surface area).

Size, checked before anything is decoded: files above `MAX_BYTES` are refused (trimesh reads a
file whole, about 3-5x its size in memory), the files a mesh refers to (a glTF's buffers)
counted in, its materials and textures never read; a .npz's array, from its header, above
`MAX_BYTES` unpacked too. Meshes are kept up to `MAX_FACES`; beyond, their surface is sampled to
`LARGE_POINTS` points and the mesh let go. Sampling (`points.surface_samples`) holds one chunk of
faces at a time, so its temporary memory stays under about 0.3 GB however large the mesh. Clouds
above `MAX_POINTS` are subsampled (seeded, reproducible). A drawing (`open_image`) is refused
above `MAX_PIXELS`, from its header.
"""

from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from geocode.errors import UserError, one_line
from geocode.points import face_areas, surface_samples
from geocode.seeds import generator

MESH_SUFFIXES = tuple(s for s in (".obj", ".ply", ".stl", ".off", ".glb", ".gltf", ".3mf", ".dae")
                      if s[1:] in trimesh.available_formats())
CLOUD_SUFFIXES = (".xyz", ".txt", ".pts", ".csv", ".npy", ".npz")   # and .ply without faces
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
SUFFIXES = MESH_SUFFIXES + CLOUD_SUFFIXES + IMAGE_SUFFIXES   # every input kind reconstruct reads
MIN_POINTS = 100
MAX_BYTES = 1 << 30            # 1 GiB
MAX_FACES = 5_000_000          # larger meshes are kept as LARGE_POINTS surface points
LARGE_POINTS = 1_000_000
MAX_POINTS = 2_000_000         # larger clouds are subsampled to this
MAX_SIDE = 6000
MAX_PIXELS = MAX_SIDE ** 2     # a drawing's pixels at most (an A4 page scanned at 600 dpi: 35 million);
                               # reading one takes about 30 bytes a pixel at its peak
HEADER_LINES = 200             # leading non-numeric lines a text cloud may have
GAP_SHARE = 0.02               # pieces whose boxes are this close (share of the scene's diagonal) touch
MAIN_SHARE = 0.8               # the main group must hold this share of the area for others to go
FLAT_SHARE = 0.01              # a piece thinner than this share of its size is flat (a plane)
SCENE_RULE = (f"pieces whose bounding boxes lie within {GAP_SHARE:.0%} of the scene's diagonal "
              f"of each other form one object; the largest keeps the file if it holds "
              f">= {MAIN_SHARE:.0%} of the area (else all are kept); a flat piece at one end of "
              f"the object and 1.5x wider than it is a ground plane, dropped")


@dataclass
class Geometry:
    """One input shape in its file's frame: `mesh` (float64 vertices) or `points` (N, 3)
    float64, never both; `note` says in one line what was read and what was changed."""

    path: Path
    points: np.ndarray | None
    mesh: trimesh.Trimesh | None
    note: str

    @property
    def kind(self) -> str:
        return "mesh" if self.mesh is not None else "cloud"


def read_geometry(path: str | Path) -> Geometry:
    """The mesh or cloud of `path`; a UserError line for what cannot be used."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES + CLOUD_SUFFIXES:
        raise UserError(path, f"unknown input kind {suffix or '(none)'}",
                        f"give a mesh ({' '.join(MESH_SUFFIXES)}) or a point cloud "
                        f"({' '.join(CLOUD_SUFFIXES)}, .ply without faces)")
    if not path.is_file():
        raise UserError(path, "no such file", "check the path")
    size = path.stat().st_size
    if size == 0:
        raise UserError(path, "the file is empty", "give a mesh or a point cloud")
    if size > MAX_BYTES:
        raise UserError(path, f"{size / 2**30:.1f} GiB is above the {MAX_BYTES / 2**30:.0f} GiB "
                        "limit", "decimate the mesh or subsample the cloud first")
    try:
        if suffix in (".npy", ".npz"):
            points, note = _numpy_cloud(path), "cloud"
        elif suffix in CLOUD_SUFFIXES:
            points, note = _text_cloud(path), "cloud"
        else:
            return _mesh_geometry(path)
    except UserError:
        raise
    except TooLarge as exc:
        raise UserError(path, str(exc), "decimate the mesh first") from None
    except Exception as exc:  # numpy and trimesh raise many types for a broken file
        raise UserError(path, f"not a readable {suffix} file ({one_line(exc, 120)})",
                        "export it again from its tool") from None
    return _cloud_geometry(path, points, note)


# -- clouds ---------------------------------------------------------------------------------------

def _numpy_cloud(path: Path) -> np.ndarray:
    """An (N, >=3) array of a .npy, or of the .npz key that looks most like points (chosen
    from the arrays' headers; only that one is unpacked, if it fits `MAX_BYTES`)."""
    if path.suffix.lower() == ".npy":
        return np.load(path, allow_pickle=False)
    with np.load(path, allow_pickle=False) as archive:
        headers = {k: _npz_header(archive, k) for k in archive.files}
        shaped = [k for k, (shape, _) in headers.items() if len(shape) == 2 and shape[1] >= 3]
        if not shaped:
            raise UserError(path, f"no N x 3 array among {archive.files}",
                            "save the points as an N x 3 array")
        named = [k for k in shaped if k.lower() in ("points", "xyz", "pc", "cloud", "vertices", "pos")]
        key = (named or shaped)[0]
        shape, dtype = headers[key]
        unpacked = math.prod(shape) * dtype.itemsize
        if unpacked > MAX_BYTES:
            raise UserError(path, f"its array {key!r} {shape} is {unpacked / 2**30:.1f} GiB unpacked, above "
                            f"the {MAX_BYTES / 2**30:.0f} GiB limit", "subsample the cloud first")
        return archive[key]


def _npz_header(archive, key: str) -> tuple[tuple, np.dtype]:
    """(shape, dtype) of one array of a .npz, from its .npy header: nothing unpacked."""
    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    with archive.zip.open(f"{key}.npy") as member:
        version = np.lib.format.read_magic(member)
        if version not in readers:
            raise ValueError(f"array {key!r}: .npy version {version} is not read")
        shape, _, dtype = readers[version](member)
    return shape, dtype


_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^[-+]?(nan|inf)$", re.IGNORECASE)


def _fields(line: str) -> list[str]:
    return [f for f in re.split(r"[\s,;]+", line.strip()) if f]


def _is_point_line(line: str) -> bool:
    fields = _fields(line)
    return len(fields) >= 3 and all(_NUMBER.match(f) for f in fields[:3])


def _text_cloud(path: Path) -> np.ndarray:
    """x y z per row of a text file: leading lines that are not points (a header, a count,
    column names) are skipped; commas, semicolons or blanks separate; further columns
    (normals, colours, intensity) are ignored."""
    with open(path, errors="replace") as handle:
        head = [handle.readline() for _ in range(HEADER_LINES)]
    start = next((i for i, line in enumerate(head) if _is_point_line(line)), None)
    if start is None:
        raise UserError(path, f"no line of x y z numbers in its first {HEADER_LINES} lines",
                        "give one point per row: x y z (more columns are ignored)")
    sample = head[start]
    delimiter = "," if "," in sample else ";" if ";" in sample else None
    return np.loadtxt(path, skiprows=start, usecols=(0, 1, 2), delimiter=delimiter, ndmin=2,
                      comments=("#", "//"))


def _cloud_geometry(path: Path, points, note: str) -> Geometry:
    points = np.asarray(points)
    if points.ndim != 2 or points.shape[1] < 3:
        raise UserError(path, f"expected N x 3 coordinates, got shape {points.shape}",
                        "give one point (x y z) per row")
    points = np.asarray(points[:, :3], dtype=np.float64)
    _check_finite(path, points, "points")
    if len(points) < MIN_POINTS:
        raise UserError(path, f"{len(points)} points", f"give at least {MIN_POINTS}")
    if not np.ptp(points, axis=0).max() > 0:
        raise UserError(path, "all points coincide", "give a cloud with some extent")
    note = f"{note} of {len(points)} points"
    if len(points) > MAX_POINTS:
        keep = generator(0, "inputs", "subsample", path.name).choice(len(points), MAX_POINTS, replace=False)
        points = points[np.sort(keep)]
        note += f", subsampled to {MAX_POINTS}"
    return Geometry(path, points, None, note)


def _check_finite(path: Path, array: np.ndarray, what: str) -> None:
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        raise UserError(path, f"{int(bad.sum())} {what} have NaN or infinite coordinates",
                        "remove them")


# -- meshes and scenes ----------------------------------------------------------------------------

def _load(path: Path):
    """trimesh's reading of the file, without its materials and textures, the files it refers
    to bounded (`BoundedFiles`); ModelNet's `OFF<counts>` first line is split first."""
    suffix = path.suffix.lower()
    if suffix == ".off":
        data = path.read_bytes()
        fixed = re.sub(rb"^\s*OFF(?=[\s]*[-+\d])", b"OFF\n", data, count=1)
        return trimesh.load(io.BytesIO(fixed), file_type="off", process=False)
    options = {"process": False, "skip_materials": True, "resolver": BoundedFiles(path)}
    if suffix == ".obj":   # one piece per `o`/`g` object, so that far-apart objects can be told
        return trimesh.load(path, split_objects=True, group_material=False, **options)
    return trimesh.load(path, **options)


class BoundedFiles(trimesh.resolvers.FilePathResolver):
    """trimesh's reader of the files a mesh file refers to (a glTF's buffers), in its folder:
    each is counted, before it is read, against what `MAX_BYTES` leaves beside the file."""

    def __init__(self, path: Path):
        super().__init__(str(path))
        self.path, self.left, self.seen = path, MAX_BYTES - path.stat().st_size, set()

    def absolute(self, name: str) -> Path:
        found = super().absolute(name)
        if found.is_file() and found not in self.seen:
            self.seen.add(found)
            self.left -= found.stat().st_size
            if self.left < 0:
                raise TooLarge(f"with the files it refers to ({found.name} the last) it is above the "
                               f"{MAX_BYTES / 2**30:.0f} GiB limit")
        return found


class TooLarge(OSError):
    """The files a mesh refers to come to more than `MAX_BYTES` (not a ValueError: trimesh's
    resolver takes those for a name it should try otherwise)."""


def scene_pieces(loaded) -> tuple[list[trimesh.Trimesh], list[np.ndarray]]:
    """The triangle meshes of a load, each moved by its scene node's transform, and the
    vertices of its point clouds (glTF/PLY may hold points only)."""
    if isinstance(loaded, trimesh.Scene):
        meshes, clouds = [], []
        for node in loaded.graph.nodes_geometry:
            transform, name = loaded.graph[node]
            geom = loaded.geometry[name]
            if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
                meshes.append(trimesh.Trimesh(trimesh.transform_points(geom.vertices, transform),
                                              geom.faces, process=False))
            elif isinstance(geom, trimesh.PointCloud) and len(geom.vertices):
                clouds.append(trimesh.transform_points(geom.vertices, transform))
        return meshes, clouds
    if isinstance(loaded, trimesh.Trimesh) and len(loaded.faces):
        return [loaded], []
    vertices = getattr(loaded, "vertices", None)
    return [], [np.asarray(vertices)] if vertices is not None and len(vertices) else []


def _box_gaps(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(n, n) Euclidean gap between axis-aligned boxes (0 where they overlap)."""
    gap = np.maximum(0.0, np.maximum(lo[:, None] - hi[None], lo[None] - hi[:, None]))
    return np.linalg.norm(gap, axis=2)


def _groups(lo, hi, area, members):
    """Proximity groups of the pieces `members` (indices): labels and each group's area."""
    clo, chi = lo[members], hi[members]
    diagonal = np.linalg.norm(chi.max(0) - clo.min(0))
    _, label = connected_components(csr_matrix(_box_gaps(clo, chi) <= GAP_SHARE * diagonal),
                                    directed=False)
    return label, np.bincount(label, weights=area[members])


def _ground_planes(lo, hi, area) -> np.ndarray:
    """Flat pieces at one end, along their thin axis, of the main group of the other pieces
    and wider than it by half along both other axes: a floor or backdrop under the object,
    not a part of it (a floor touches everything, so it is set aside before grouping)."""
    size = hi - lo
    flat = size.min(1) <= FLAT_SHARE * size.max(1)
    solid = np.flatnonzero(~flat)
    out = np.zeros(len(lo), bool)
    if not len(solid) or not flat.any():
        return out
    label, group_area = _groups(lo, hi, area, solid)
    main = solid[label == np.argmax(group_area)]
    mlo, mhi = lo[main].min(0), hi[main].max(0)
    for i in np.flatnonzero(flat):
        thin = int(np.argmin(size[i]))
        slack = FLAT_SHARE * size[i].max()
        at_end = hi[i, thin] <= mlo[thin] + slack or lo[i, thin] >= mhi[thin] - slack
        wider = all(size[i, a] > 1.5 * (mhi[a] - mlo[a]) for a in range(3) if a != thin)
        out[i] = at_end and wider
    return out


def keep_main_object(pieces: list[trimesh.Trimesh]) -> tuple[list[int], str]:
    """The pieces that make the object (indices) and a note; see SCENE_RULE.

    Why boxes and not exact distances: asset pieces (a seat, four legs, screws) touch or
    interpenetrate, so their boxes overlap or nearly do; a second object stands apart. Box
    gaps cost O(pieces^2), not O(faces), so scenes of thousands of pieces stay cheap."""
    n = len(pieces)
    if n == 1:
        return [0], ""
    lo = np.array([p.vertices.min(0) for p in pieces])
    hi = np.array([p.vertices.max(0) for p in pieces])
    area = np.array([p.area for p in pieces])
    ground = _ground_planes(lo, hi, area)
    candidates = np.flatnonzero(~ground)
    label, group_area = _groups(lo, hi, area, candidates)
    main = int(np.argmax(group_area))
    share = group_area[main] / max(group_area.sum(), 1e-300)
    keep = candidates[label == main] if share >= MAIN_SHARE else candidates
    dropped_ground, dropped_far = int(ground.sum()), len(candidates) - len(keep)
    parts = [f"{n} pieces, {len(keep)} kept as one object"]
    if dropped_far:
        parts.append(f"{dropped_far} apart from it dropped ({1 - share:.0%} of the area)")
    elif share < MAIN_SHARE and len(group_area) > 1:
        parts.append(f"{len(group_area)} separate groups, none with {MAIN_SHARE:.0%} of the area: all kept")
    if dropped_ground:
        parts.append(f"{dropped_ground} ground plane{'s' if dropped_ground > 1 else ''} dropped")
    return sorted(keep.tolist()), "; ".join(parts)


def _mesh_geometry(path: Path) -> Geometry:
    meshes, clouds = scene_pieces(_load(path))
    if not meshes:
        points = np.concatenate(clouds) if clouds else np.zeros((0, 3))
        if not len(points):
            raise UserError(path, "no geometry found (no faces, no points)",
                            "export the object's mesh, not an empty scene")
        return _cloud_geometry(path, points, "cloud (no faces)")
    for mesh in meshes:
        _check_finite(path, np.asarray(mesh.vertices), "vertices")
    keep, note = keep_main_object(meshes)
    mesh = trimesh.util.concatenate([meshes[i] for i in keep]) if len(keep) > 1 else meshes[keep[0]]
    mesh = trimesh.Trimesh(np.asarray(mesh.vertices, dtype=np.float64), mesh.faces, process=False)
    faces = len(mesh.faces)
    area = float(face_areas(mesh.vertices, mesh.faces).sum())
    if not area > 0:
        raise UserError(path, f"the mesh has no surface area ({faces} faces, all degenerate)",
                        "give a mesh with real faces")
    note = f"mesh of {faces} faces" + (f" ({note})" if note else "")
    if faces > MAX_FACES:
        points = surface_samples(mesh.vertices, mesh.faces, LARGE_POINTS,
                                 generator(0, "inputs", "large", path.name))
        return Geometry(path, points, None, f"{note}, above {MAX_FACES} faces: "
                        f"kept as {LARGE_POINTS} surface points")
    return Geometry(path, None, mesh, note)


# -- drawings -------------------------------------------------------------------------------------

def open_image(path: Path) -> Image.Image:
    """A PNG or JPEG drawing, its header read and its size checked against `MAX_PIXELS`; its
    pixels are decoded only at `load()`. PIL's own check (which stops far larger images with an
    exception of its own) is lifted for the header, so that one line says the size."""
    limit, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
    try:
        image = Image.open(path, formats=("PNG", "JPEG"))
    except (OSError, ValueError) as exc:
        raise UserError(path, f"not a readable PNG or JPEG image ({one_line(exc, 120)})",
                        "save the drawing as .png or .jpg") from None
    finally:
        Image.MAX_IMAGE_PIXELS = limit
    width, height = image.size
    if width * height > MAX_PIXELS:
        image.close()
        raise UserError(path, f"{width} x {height} pixels is over the limit of {MAX_PIXELS / 1e6:.0f} million",
                        f"give a drawing of at most {MAX_SIDE} x {MAX_SIDE} pixels (scale it down: "
                        "it is brought to 224 x 224)")
    return image


# -- sampling -------------------------------------------------------------------------------------

def surface_points(geometry: Geometry, n: int, rng: np.random.Generator) -> np.ndarray:
    """n points of the input, (n, 3) float64 in its own frame, in random order (`rng`), so that
    any first k of them are spread over the whole input: area-weighted surface samples of a
    mesh; a cloud's own points, subsampled without repeats (or all of them, with repeats to
    reach n, when it has fewer). A scan stores its points row by row: in the file's order,
    its first points are one part of the object."""
    if geometry.mesh is not None:
        return surface_samples(geometry.mesh.vertices, geometry.mesh.faces, n, rng)
    points = geometry.points
    if len(points) >= n:
        return points[rng.choice(len(points), n, replace=False)]
    extra = rng.choice(len(points), n - len(points), replace=True)
    return points[rng.permutation(np.concatenate([np.arange(len(points)), extra]))]
