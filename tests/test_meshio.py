"""OBJ files as the pipeline writes and reads them (`geocode.meshio`), without Blender."""

import io

import numpy as np
import pytest
import trimesh

from geocode.errors import UserError
from geocode.meshio import obj_text, read_obj, write_obj


def a_mesh(seed: int = 0) -> trimesh.Trimesh:
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(50, 3)) * [1.0, 1e-4, 1e3]    # small and large coordinates
    faces = rng.integers(0, 50, size=(80, 3))
    return trimesh.Trimesh(vertices, faces, process=False)


def test_obj_text_is_numpys_text_of_the_rows():
    mesh = a_mesh()
    want = io.StringIO()
    np.savetxt(want, mesh.vertices, fmt="v %.6f %.6f %.6f")
    np.savetxt(want, mesh.faces + 1, fmt="f %d %d %d")
    assert obj_text(mesh.vertices, mesh.faces) == want.getvalue()


def test_an_obj_of_ours_reads_back_as_trimesh_reads_it(tmp_path):
    path = tmp_path / "m.obj"
    write_obj(path, a_mesh())
    mesh = read_obj(path)
    other = trimesh.load(path, file_type="obj", force="mesh", process=False)
    assert np.array_equal(mesh.vertices, other.vertices) and np.array_equal(mesh.faces, other.faces)
    assert obj_text(mesh.vertices, mesh.faces) == path.read_text()     # a rewrite is byte-identical


@pytest.mark.parametrize("text, faces", [
    ("# a comment\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 1),
    ("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", 2),                    # a quad
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n", 1),            # normals
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1", 1),                              # relative, no last newline
])
def test_any_other_obj_is_read_by_trimesh(tmp_path, text, faces):
    path = tmp_path / "m.obj"
    path.write_text(text)
    assert len(read_obj(path).faces) == faces


def test_a_face_past_the_vertices_is_one_line(tmp_path):
    path = tmp_path / "m.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
    with pytest.raises(UserError, match="not a readable OBJ mesh"):
        read_obj(path)
