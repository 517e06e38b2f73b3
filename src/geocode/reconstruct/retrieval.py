"""The nearest shape of the training set: the baseline every reconstruction must beat.

Retrieval answers an input with the training shape at the smallest plain Chamfer distance
(`geocode.metrics.chamfer`, 10,000 surface points each on the unit sphere), at the best of
four quarter-turns about the up axis. Comparing the input with every training mesh at full
resolution would take minutes, so it screens first: every training shape's stored random
cloud, subsampled to `SCREEN_POINTS`, against the input's at each turn, and re-ranks only
the `RERANK` nearest by the full distance. The screen's distances come from matrix products in
float32 (2.2x faster than a KD-tree per shape; its rounding, under 1e-7 on distances near 1e-2,
only orders the candidates, which the full distance then ranks).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from geocode.meshio import normalise_unit_sphere, read_obj
from geocode.metrics import chamfer
from geocode.points import load_clouds, sample_surface
from geocode.reconstruct.fit import turn_about_z

SCREEN_POINTS = 256
RERANK = 8
SCREEN_CHUNK = 32      # training shapes per matrix product: 256 x 8192 float32, 8 MB
QUARTER_TURNS = tuple(k * math.pi / 2 for k in range(4))


@dataclass(frozen=True)
class Match:
    shape_id: str
    mesh_path: Path
    turn: float          # radians about +Z that bring the training shape onto the input
    chamfer: float       # plain Chamfer distance at that turn


class TrainingShapes:
    """A training split's shapes, ready for nearest-shape queries."""

    def __init__(self, ids: Sequence[str], mesh_paths: Sequence[Path], clouds: np.ndarray):
        self.ids, self.mesh_paths = list(ids), list(mesh_paths)
        clouds = np.asarray(clouds, dtype=np.float32)                  # (M, SCREEN_POINTS, 3)
        flat = clouds.reshape(-1, 3)
        # Each point p as (-2p, 1, |p|^2): a query point q as (q, |q|^2, 1) then has
        # |q - p|^2 as their dot product, so one matrix product gives every squared distance.
        self.lifted = np.concatenate([-2 * flat.T, np.ones((1, len(flat)), np.float32),
                                      np.sum(flat * flat, axis=1)[None]])  # (5, M * SCREEN_POINTS)
        self.points_per_shape = clouds.shape[1]

    @classmethod
    def from_split(cls, split_dir: str | Path) -> TrainingShapes:
        """From a dataset split folder (`shapes/<id>.obj`, `points/<id>.npz`)."""
        split_dir = Path(split_dir)
        ids = sorted(p.stem for p in (split_dir / "points").glob("*.npz"))
        if not ids:
            raise ValueError(f"{split_dir}: no clouds in points/; generate the dataset first")
        clouds = [load_clouds(split_dir / "points" / f"{i}.npz")["random"][:SCREEN_POINTS] for i in ids]
        return cls(ids, [split_dir / "shapes" / f"{i}.obj" for i in ids], np.stack(clouds))

    def screen(self, query: np.ndarray, turns: Sequence[float] = QUARTER_TURNS) -> np.ndarray:
        """Coarse Chamfer distances (M, len(turns)) of every shape, turned, to the query."""
        rng = np.random.default_rng(0)
        q = np.asarray(query, dtype=np.float64)
        q = q[rng.choice(len(q), size=min(SCREEN_POINTS, len(q)), replace=False)]
        out = np.empty((len(self.ids), len(turns)))
        n = self.points_per_shape
        for j, angle in enumerate(turns):
            back = turn_about_z(q, -angle).astype(np.float32)          # the query in the shapes' frame
            lifted = np.concatenate([back, np.sum(back * back, axis=1, keepdims=True),
                                     np.ones((len(back), 1), np.float32)], axis=1)
            for start in range(0, len(self.ids), SCREEN_CHUNK):
                m = min(SCREEN_CHUNK, len(self.ids) - start)
                d = (lifted @ self.lifted[:, start * n:(start + m) * n]).reshape(len(back), m, n)
                to_shape = np.maximum(d.min(axis=2), 0).mean(axis=0)   # rounding can dip below 0
                to_query = np.maximum(d.min(axis=0), 0).mean(axis=1)
                out[start:start + m, j] = (to_shape + to_query) / 2
        return out

    def nearest(self, query_mesh: trimesh.Trimesh, n: int = 10000,
                turns: Sequence[float] = QUARTER_TURNS) -> Match:
        """The training shape nearest the query mesh (unit sphere, +Z up) by the plain
        Chamfer distance of `n` points each, at the best of `turns`."""
        query = sample_surface(normalise_unit_sphere(query_mesh), n, np.random.default_rng(0))
        return self.nearest_to_points(query, n, turns)

    def nearest_to_points(self, query: np.ndarray, n: int = 10000,
                          turns: Sequence[float] = QUARTER_TURNS) -> Match:
        return self.matches(query, 1, n, turns)[0]

    def matches(self, query: np.ndarray, k: int, n: int = 10000,
                turns: Sequence[float] = QUARTER_TURNS) -> list[Match]:
        """The `k` nearest distinct training shapes (each at its best turn), nearest first,
        re-ranked by the plain Chamfer distance of `n` points from the best screened."""
        coarse = self.screen(query, turns)
        best: dict[int, Match] = {}
        for flat in np.argsort(coarse, axis=None)[:max(RERANK, 2 * k)]:
            i, j = np.unravel_index(flat, coarse.shape)
            mesh = normalise_unit_sphere(read_obj(self.mesh_paths[i]))
            points = turn_about_z(sample_surface(mesh, n, np.random.default_rng(1)), turns[j])
            match = Match(self.ids[i], self.mesh_paths[i], float(turns[j]), chamfer(points, query))
            if i not in best or match.chamfer < best[i].chamfer:
                best[int(i)] = match
        return sorted(best.values(), key=lambda m: m.chamfer)[:k]
