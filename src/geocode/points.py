"""Point clouds from meshes (docs/paper-numbers.md#dataset-generation and #robustness): surface
sampling, farthest point sampling, the per-shape clouds of the dataset, and the perturbed
inputs of the robustness tables."""

from __future__ import annotations

import io
import logging
import math
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numba
import numpy as np
import trimesh

from geocode import meshio, paths
from geocode.errors import UserError, one_line
from geocode.meshio import REDO_EXPORT
from geocode.seeds import generator
from geocode.timing import Progress

log = logging.getLogger(__name__)

CLOUD_KEYS = ("fps", "random")
_ID_BITS = 24           # a sample's id: its face << _ID_BITS | its number on that face
OVERSAMPLE = 8          # candidate points per sample kept (`surface_samples`)


_GOLDEN, _MIX_A, _MIX_B = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xBF58476D1CE4E5B9),
                           np.uint64(0x94D049BB133111EB))


@numba.njit(cache=True, nogil=True)
def _mix(x):
    """splitmix64's finaliser: a well-spread uint64 for each uint64 (wrapping arithmetic)."""
    x = x + _GOLDEN
    x = (x ^ (x >> np.uint64(30))) * _MIX_A
    x = (x ^ (x >> np.uint64(27))) * _MIX_B
    return x ^ (x >> np.uint64(31))


@numba.njit(cache=True, nogil=True)
def _unit(x):
    """uint64 -> float64 in [0, 1)."""
    return np.float64(x >> np.uint64(11)) * 2.0 ** -53


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Each face's area, (F,) float64 (ValueError for a face naming a missing vertex)."""
    vertices = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(faces) and not 0 <= faces.min() <= faces.max() < len(vertices):
        raise ValueError(f"faces name vertices outside 0..{len(vertices) - 1}")
    return _face_areas(vertices, faces)


@numba.njit(cache=True, nogil=True)
def _face_areas(vertices, faces):
    out = np.empty(len(faces))
    for f in range(len(faces)):
        p, q, r = vertices[faces[f, 0]], vertices[faces[f, 1]], vertices[faces[f, 2]]
        ax, ay, az = q[0] - p[0], q[1] - p[1], q[2] - p[2]
        bx, by, bz = r[0] - p[0], r[1] - p[1], r[2] - p[2]
        cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        out[f] = math.sqrt((cx * cx + cz * cz) + cy * cy) / 2   # numpy einsum's order: to the bit
    return out


def surface_samples(vertices: np.ndarray, faces: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """n points uniform over the surface (area-weighted), (n, 3) float64, in random order.

    Stable under rounding: a mesh moved a little (a file saved turned, a program's shape at a
    value 1e-6 away) gives the same points moved alike, in the same order, where inverse-CDF
    sampling sends some points to other faces (and the fit's objective, the network's cloud
    and all after them jump; docs/design.md#pose-and-sampling). Face f gets floor(OVERSAMPLE * n * its
    share of the area + r_f) candidate points, r_f uniform; each candidate's place in its
    face, its slot (of n) and its rank come from a hash of (face, number), not from a running
    draw; each slot keeps its best ranked candidate (a slot left empty, e^-OVERSAMPLE of
    them, repeats its neighbour's). A moved vertex changes a count only where it carries the
    count across an integer, and that moves one slot. Compiled: one pass over the faces,
    whose memory beside the mesh is 8 bytes a face (the areas), whatever the face count.
    """
    vertices = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    if not 0 < n < 1 << (_ID_BITS - 4):
        raise ValueError(f"surface_samples: n={n} must be in 1..{(1 << (_ID_BITS - 4)) - 1}")
    area = face_areas(vertices, faces)
    total = area.sum()
    if not total > 0:
        raise ValueError("mesh has no surface area to sample")
    salt = np.array([_mix(np.uint64(s)) for s in rng.integers(1 << 62, size=5)], dtype=np.uint64)
    best_rank, best_id = _slots(area, OVERSAMPLE * n / total, salt, n)
    kept = np.flatnonzero(best_rank != _EMPTY)
    if not len(kept):
        raise ValueError("mesh has no surface area to sample")
    ids = best_id[kept[np.searchsorted(kept, np.arange(n)) % len(kept)]]
    return _points_on_faces(vertices, faces, ids, salt)


_EMPTY = np.uint64(np.iinfo(np.uint64).max)


@numba.njit(cache=True, nogil=True)
def _slots(area, density, salt, n):
    """(rank, id) of the best ranked candidate in each of the n slots (rank _EMPTY: none).
    Face f's candidates are ids f << _ID_BITS | k, k < floor(density * area + r_f)."""
    best_rank, best_id = np.full(n, _EMPTY, np.uint64), np.zeros(n, np.uint64)
    for f in range(len(area)):
        face = np.uint64(f)
        count = int(math.floor(area[f] * density + _unit(_mix(face ^ salt[0]))))
        for k in range(count):
            ident = (face << np.uint64(_ID_BITS)) | np.uint64(k)
            slot = _mix(ident ^ salt[1]) % np.uint64(n)
            rank = _mix(ident ^ salt[2]) >> np.uint64(1)    # below _EMPTY
            if rank <= best_rank[slot]:
                best_rank[slot], best_id[slot] = rank, ident
    return best_rank, best_id


@numba.njit(cache=True, nogil=True)
def _points_on_faces(vertices, faces, ids, salt):
    """The point of each candidate id: uniform in its face, from a hash of the id."""
    out = np.empty((len(ids), 3))
    for i in range(len(ids)):
        u, v = _unit(_mix(ids[i] ^ salt[3])), _unit(_mix(ids[i] ^ salt[4]))
        if u + v > 1:
            u, v = 1 - u, 1 - v
        face = faces[np.int64(ids[i] >> np.uint64(_ID_BITS))]
        p, q, r = vertices[face[0]], vertices[face[1]], vertices[face[2]]
        for a in range(3):
            out[i, a] = p[a] + u * (q[a] - p[a]) + v * (r[a] - p[a])
    return out


def sample_surface(mesh: trimesh.Trimesh, n: int, rng: np.random.Generator) -> np.ndarray:
    """n points uniform over the mesh's surface area, (n,3) float32 (`surface_samples`)."""
    return surface_samples(mesh.vertices, mesh.faces, n, rng).astype(np.float32)


def farthest_point_sampling(points: np.ndarray, k: int, start: int = 0) -> np.ndarray:
    """Indices (k,) int64 of the greedy farthest-point subset that begins at `start`: each
    pick maximises d_i = min over chosen c of |p_i - c|^2 (float32, as a plain loop would).

    Exact, but it skips work: points are bucketed in grid cells, and a new centre q can only
    lower the distances in a cell whose box is nearer to q than the cell's largest d, so
    late picks visit a few cells instead of every point (compiled with numba).
    """
    pts = np.asarray(points, dtype=np.float32)
    n = len(pts)
    if not 0 < k <= n:
        raise ValueError(f"farthest_point_sampling: k={k} must be in 1..{n} (number of points)")
    cells = _grid_cells(pts, points_per_cell=32)
    order = np.argsort(cells, kind="stable")
    by_cell = cells[order]
    bounds = np.r_[np.flatnonzero(np.r_[True, by_cell[1:] != by_cell[:-1]]), n].astype(np.int64)
    first = int(np.flatnonzero(order == start)[0])
    return order[_fps_in_cells(np.ascontiguousarray(pts[order]), bounds, k, first)]


def _grid_cells(pts: np.ndarray, points_per_cell: int) -> np.ndarray:
    """A cell number per point on a regular grid over the bounding box, about
    `points_per_cell` points per cell on average."""
    lo, hi = pts.min(0), pts.max(0)
    side = max(1, round((len(pts) / points_per_cell) ** (1 / 3)))
    ijk = ((pts - lo) / np.maximum(hi - lo, 1e-12) * side).astype(np.int64).clip(0, side - 1)
    return (ijk[:, 0] * side + ijk[:, 1]) * side + ijk[:, 2]


@numba.njit(cache=True, nogil=True)
def _fps_in_cells(pts, bounds, k, cur):
    """FPS over points sorted by cell (cell c holds pts[bounds[c]:bounds[c+1]])."""
    n_cells = len(bounds) - 1
    lo = np.empty((n_cells, 3))
    hi = np.empty((n_cells, 3))
    for c in range(n_cells):
        for a in range(3):
            lo[c, a] = pts[bounds[c]:bounds[c + 1], a].min()
            hi[c, a] = pts[bounds[c]:bounds[c + 1], a].max()
    dist = np.full(len(pts), np.inf, dtype=np.float32)
    cell_max = np.full(n_cells, np.inf)
    out = np.empty(k, dtype=np.int64)
    for i in range(k):
        out[i] = cur
        q = pts[cur]
        for c in range(n_cells):
            gap = 0.0
            for a in range(3):
                g = max(lo[c, a] - q[a], 0.0, q[a] - hi[c, a])
                gap += g * g
            if gap * (1 - 1e-5) >= cell_max[c]:      # slightly low: exact despite rounding
                continue
            top = np.float32(0)
            for j in range(bounds[c], bounds[c + 1]):
                dx, dy, dz = pts[j, 0] - q[0], pts[j, 1] - q[1], pts[j, 2] - q[2]
                d = dx * dx + dy * dy + dz * dz
                if d < dist[j]:
                    dist[j] = d
                if dist[j] > top:
                    top = dist[j]
            cell_max[c] = top
        best = np.argmax(cell_max)
        cur = bounds[best] + np.argmax(dist[bounds[best]:bounds[best + 1]])
    return out


def make_clouds(
    mesh: trimesh.Trimesh,
    surface: int = 30000,
    fps: int = 1500,
    random: int = 1500,
    rng: np.random.Generator | None = None,
) -> dict[str, np.ndarray]:
    """The two clouds of one shape (docs/paper-numbers.md#dataset-generation), float32: "fps" =
    farthest point sampling of `surface` area-weighted samples; "random" = a uniform random
    subset of those samples (itself a uniform surface sample). rng=None means default_rng(0)."""
    rng = np.random.default_rng(0) if rng is None else rng
    dense = sample_surface(mesh, surface, rng)
    pick = rng.choice(surface, size=random, replace=False)
    return {"fps": dense[farthest_point_sampling(dense, fps)], "random": dense[pick]}


def _npz_bytes(arrays: Mapping[str, np.ndarray]) -> bytes:
    """An .npz archive with fixed timestamps (np.savez stamps the current time), so that
    the same arrays always give the same bytes."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_STORED) as zf:
        for key in sorted(arrays):
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            body = io.BytesIO()
            np.lib.format.write_array(body, np.ascontiguousarray(arrays[key]), allow_pickle=False)
            zf.writestr(info, body.getvalue())
    return buf.getvalue()


def save_clouds(path: str | Path, clouds: Mapping[str, np.ndarray]) -> None:
    """Write the clouds as .npz atomically (a crash never leaves a partial file)."""
    meshio.write_bytes(path, _npz_bytes({k: np.asarray(v, np.float32) for k, v in clouds.items()}))


def load_clouds(path: str | Path) -> dict[str, np.ndarray]:
    """Read an .npz of clouds; ValueError naming the file when it is missing or broken."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise UserError(path, f"not a readable point-cloud .npz ({one_line(exc)})",
                        "delete it and rerun the points step") from None


def eval_pick(n_random: int, n_pick: int, seed: int, shape_id: str) -> np.ndarray:
    """The fixed evaluation choice of `n_pick` of a shape's random points (sorted indices)."""
    return np.sort(generator(seed, "eval-cloud", shape_id).permutation(n_random)[:n_pick])


def eval_cloud(clouds: Mapping[str, np.ndarray], n_random: int, seed: int, shape_id: str) -> np.ndarray:
    """The evaluation cloud: all FPS points + a fixed draw, from (seed, id), of `n_random` random
    points. Shapes: fps (F, 3), random (R, 3) -> (F + n_random, 3) float32."""
    rand = np.asarray(clouds["random"], dtype=np.float32)
    pick = eval_pick(len(rand), n_random, seed, shape_id)
    return np.concatenate([np.asarray(clouds["fps"], dtype=np.float32), rand[pick]])


def add_noise(points: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """points + N(0, sigma^2) per coordinate (sigma in unit-sphere units), float32."""
    pts = np.asarray(points, dtype=np.float32)
    return (pts + rng.normal(0.0, sigma, size=pts.shape)).astype(np.float32)


def sparse_cloud(mesh: trimesh.Trimesh, n: int, rng: np.random.Generator) -> np.ndarray:
    """n uniform random surface points, no FPS (the sparse-input robustness test)."""
    return sample_surface(mesh, n, rng)


def simplify(mesh: trimesh.Trimesh, fraction: float) -> trimesh.Trimesh:
    """Quadric decimation (open3d, Garland-Heckbert error metric) to about
    fraction * faces triangles, at least 4."""
    import open3d as o3d  # heavy import, only needed here

    if not 0 < fraction <= 1:
        raise ValueError(f"simplify: fraction={fraction} must be in (0, 1]")
    target = max(4, int(round(fraction * len(mesh.faces))))
    o3 = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector(np.asarray(mesh.vertices, dtype=np.float64)),
        o3d.utility.Vector3iVector(np.asarray(mesh.faces, dtype=np.int32)),
    )
    out = o3.simplify_quadric_decimation(target_number_of_triangles=target)
    return trimesh.Trimesh(np.asarray(out.vertices), np.asarray(out.triangles), process=False)


def _complete(path: Path) -> bool:
    """Whether a clouds file exists and holds both clouds (writes are atomic, so this is
    a cheap guard against files from some other tool)."""
    if not path.exists():
        return False
    try:
        with np.load(path, allow_pickle=False) as data:
            return all(k in data.files for k in CLOUD_KEYS)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile):
        return False


def points_shard(
    split_dir: str | Path, shard: int, cfg_points: Mapping[str, int], seed: int
) -> Path:
    """Clouds for the shapes of one shard; returns the done file.

    Reads ids from <split_dir>/done/export-<shard>.txt, writes <split_dir>/points/<id>.npz
    from <split_dir>/shapes/<id>.obj (skipping complete ones), then, last and atomically,
    <split_dir>/done/points-<shard>.txt. cfg_points: keys surface, fps, random. Each shape's
    rng is seeded from (seed, id), so reruns and any shard order give identical bytes.
    """
    split_dir = Path(split_dir)
    ids_file = paths.done_file(split_dir, "export", shard)
    if not ids_file.exists():
        raise UserError(ids_file, "missing", f"run the export step for shard {shard} first")
    ids = [line.strip() for line in ids_file.read_text().splitlines() if line.strip()]
    sizes = {k: int(cfg_points[k]) for k in ("surface", "fps", "random")}
    progress = Progress(f"points shard {shard}", len(ids), log)
    for shape_id in ids:
        out = paths.cloud_file(split_dir, shape_id)
        if not _complete(out):
            mesh = meshio.read_obj(paths.shape_file(paths.shapes_dir(split_dir), shape_id), REDO_EXPORT)
            rng = generator(seed, "points", shape_id)
            save_clouds(out, make_clouds(mesh, **sizes, rng=rng))
        progress.step()
    progress.finish()
    done = paths.done_file(split_dir, "points", shard)
    meshio.write_text(done, "".join(f"{i}\n" for i in ids))
    return done


def network_cloud(points: np.ndarray, points_cfg, rng: np.random.Generator) -> np.ndarray:
    """As the evaluation clouds are: `fps` farthest points + `train_random` random ones."""
    points = np.asarray(points, dtype=np.float32)
    n_fps = min(points_cfg.fps, len(points))
    fps = farthest_point_sampling(points, n_fps)
    rest = np.setdiff1d(np.arange(len(points)), fps)
    extra = rng.choice(rest, size=min(points_cfg.train_random, len(rest)), replace=False)
    return points[np.concatenate([fps, np.sort(extra)])]
