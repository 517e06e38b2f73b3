"""Files: atomic writes, OBJ meshes, unit-sphere normalisation, parquet tables (no bpy)."""

from __future__ import annotations

import io
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
import trimesh

_UMASK = os.umask(0o022)
os.umask(_UMASK)


@contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path beside `path`; rename it onto `path` only if the block succeeds,
    so that a crash never leaves a half-written file looking complete."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_UMASK)        # mkstemp makes 0600; outputs are ordinary files
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(data)


def write_text(path: str | os.PathLike, text: str) -> None:
    write_bytes(path, text.encode())


def obj_text(vertices: np.ndarray, faces: np.ndarray) -> str:
    """Wavefront OBJ of a triangle mesh; 6 decimals keep files byte-identical across runs."""
    out = io.StringIO()
    np.savetxt(out, np.asarray(vertices, dtype=np.float64), fmt="v %.6f %.6f %.6f")
    np.savetxt(out, np.asarray(faces, dtype=np.int64) + 1, fmt="f %d %d %d")
    return out.getvalue()


def write_obj(path: str | os.PathLike, mesh: trimesh.Trimesh) -> None:
    write_text(path, obj_text(mesh.vertices, mesh.faces))


def read_obj(path: str | os.PathLike) -> trimesh.Trimesh:
    """Read a triangle mesh; a missing, empty or unreadable file raises ValueError naming it."""
    path = Path(path)
    try:
        mesh = trimesh.load(path, file_type="obj", force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for a broken file
        raise ValueError(f"{path}: not a readable OBJ mesh ({exc})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ValueError(f"{path}: no triangles found; give an OBJ with at least one face")
    return mesh


def normalise_unit_sphere(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Centre on the bounding-box centre and scale so the farthest vertex is at distance 1."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    centre = (vertices.min(axis=0) + vertices.max(axis=0)) / 2
    vertices = vertices - centre
    radius = np.linalg.norm(vertices, axis=1).max()
    if not np.isfinite(radius) or radius <= 0:
        raise ValueError("mesh is degenerate: cannot scale it to the unit sphere")
    out = trimesh.Trimesh(vertices / radius, mesh.faces, process=False)
    out.metadata.update(mesh.metadata)
    return out


def write_parquet(path: str | os.PathLike, frame: pd.DataFrame) -> None:
    with atomic_path(path) as tmp:
        frame.to_parquet(tmp, index=False)
