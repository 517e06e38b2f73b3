"""geocode.reconstruct.inputs on files made here: every format, clouds with headers, scenes, size bounds,
and the one-line refusals."""

import numpy as np
import pytest
import trimesh

from geocode.errors import UserError
from geocode.reconstruct import inputs
from geocode.reconstruct.inputs import keep_main_object, read_geometry, surface_points


def stool():
    """A small stool of separate pieces (a seat and four legs), as asset files split one."""
    seat = trimesh.creation.box((0.5, 0.5, 0.05)).apply_translation((0, 0, 0.45))
    legs = [trimesh.creation.box((0.04, 0.04, 0.42)).apply_translation((x, y, 0.21))
            for x in (-0.22, 0.22) for y in (-0.22, 0.22)]
    return [seat, *legs]


def one(pieces):
    return trimesh.util.concatenate(pieces)


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".off", ".glb"])
def test_every_mesh_format_reads_the_same_surface(tmp_path, suffix):
    mesh = one(stool())
    path = tmp_path / f"stool{suffix}"
    mesh.export(path)
    got = read_geometry(path)
    assert got.kind == "mesh" and got.mesh.vertices.dtype == np.float64
    assert got.mesh.area == pytest.approx(mesh.area, rel=1e-4)
    lo, hi = got.mesh.bounds
    extent = sorted(hi - lo)
    assert extent == pytest.approx(sorted(mesh.extents), rel=1e-4)   # glTF may turn Y-up


def test_modelnet_off_with_the_counts_on_the_header_line(tmp_path):
    box = trimesh.creation.box()
    text = f"OFF{len(box.vertices)} {len(box.faces)} 0\n"
    text += "".join(f"{x} {y} {z}\n" for x, y, z in box.vertices)
    text += "".join(f"3 {a} {b} {c}\n" for a, b, c in box.faces)
    path = tmp_path / "chair_0001.off"
    path.write_text(text)
    got = read_geometry(path)
    assert len(got.mesh.faces) == 12 and got.mesh.area == pytest.approx(6.0)


def cloud(n=500, seed=0):
    return np.random.default_rng(seed).normal(size=(n, 3))


@pytest.mark.parametrize("name,write", [
    ("header.xyz", lambda p, c: p.write_text("x y z\n" + "".join(f"{a} {b} {d}\n" for a, b, d in c))),
    ("count.pts", lambda p, c: p.write_text(f"{len(c)}\n" + "".join(f"{a} {b} {d} 12 200 100 50\n" for a, b, d in c))),
    ("named.csv", lambda p, c: p.write_text("X,Y,Z,nx,ny,nz\n" + "".join(f"{a},{b},{d},0,0,1\n" for a, b, d in c))),
    ("plain.txt", lambda p, c: np.savetxt(p, np.column_stack([c, c]))),
    ("points.npy", lambda p, c: np.save(p, c.astype(np.float32))),
    ("scan.npz", lambda p, c: np.savez(p, labels=np.arange(len(c)), points=c)),
    ("cloud.ply", lambda p, c: trimesh.PointCloud(c).export(p)),
])
def test_clouds_with_headers_separators_and_extra_columns(tmp_path, name, write):
    points = cloud()
    path = tmp_path / name
    write(path, points)
    got = read_geometry(path)
    assert got.kind == "cloud" and got.points.shape == (500, 3)
    assert np.allclose(got.points, points, atol=1e-5)


def test_scene_pieces_are_one_object_and_a_far_one_and_a_floor_are_dropped(tmp_path):
    pieces = stool()
    far = trimesh.creation.box((0.1, 0.1, 0.1)).apply_translation((5, 0, 0.05))
    floor = trimesh.creation.box((4, 4, 0.001)).apply_translation((0, 0, -0.0005))
    scene = trimesh.Scene()
    for i, p in enumerate(pieces):   # glTF nodes carry the placement, not the vertices
        centre = p.bounds.mean(0)
        scene.add_geometry(p.copy().apply_translation(-centre), node_name=f"n{i}",
                           transform=trimesh.transformations.translation_matrix(centre))
    scene.add_geometry(far, node_name="far")
    scene.add_geometry(floor, node_name="floor")
    path = tmp_path / "scene.glb"
    scene.export(path)
    got = read_geometry(path)
    assert got.mesh.area == pytest.approx(one(pieces).area, rel=1e-4)
    assert "7 pieces, 5 kept" in got.note and "1 apart" in got.note and "1 ground plane" in got.note
    lo, hi = got.mesh.bounds   # glTF is Y-up: trimesh gives the file's own frame
    assert max(hi - lo) == pytest.approx(0.5, abs=1e-3)


def test_obj_objects_are_pieces_and_two_equal_objects_are_both_kept(tmp_path):
    a, b = one(stool()), one(stool()).apply_translation((3, 0, 0))
    keep, note = keep_main_object([a, b])
    assert keep == [0, 1] and "none with 80%" in note
    text = ""
    offset = 0
    for name, mesh in (("stool", a), ("lamp", trimesh.creation.icosphere(1, 0.05).apply_translation((9, 0, 0)))):
        text += f"o {name}\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in mesh.vertices)
        text += "".join(f"f {i + 1 + offset} {j + 1 + offset} {k + 1 + offset}\n" for i, j, k in mesh.faces)
        offset += len(mesh.vertices)
    path = tmp_path / "two.obj"
    path.write_text(text)
    got = read_geometry(path)
    assert got.mesh.area == pytest.approx(a.area, rel=1e-4) and "1 apart" in got.note


def test_large_meshes_become_points_and_large_clouds_are_subsampled(tmp_path, monkeypatch):
    monkeypatch.setattr(inputs, "MAX_FACES", 100)
    monkeypatch.setattr(inputs, "LARGE_POINTS", 5000)
    monkeypatch.setattr(inputs, "MAX_POINTS", 300)
    trimesh.creation.icosphere(3).export(tmp_path / "ball.stl")
    got = read_geometry(tmp_path / "ball.stl")
    assert got.kind == "cloud" and got.points.shape == (5000, 3) and "above 100 faces" in got.note
    np.save(tmp_path / "many.npy", cloud(1000))
    got = read_geometry(tmp_path / "many.npy")
    assert got.points.shape == (300, 3) and "subsampled to 300" in got.note
    again = read_geometry(tmp_path / "many.npy")
    assert np.array_equal(got.points, again.points)   # seeded


def test_surface_points_of_a_cloud_subsample_or_repeat():
    g = inputs.Geometry(None, cloud(200), None, "cloud")
    few = surface_points(g, 50, np.random.default_rng(0))
    many = surface_points(g, 300, np.random.default_rng(0))
    assert few.shape == (50, 3) and len(np.unique(few, axis=0)) == 50
    assert many.shape == (300, 3) and len(np.unique(many, axis=0)) == 200


def test_a_file_above_the_byte_limit_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setattr(inputs, "MAX_BYTES", 10)
    path = tmp_path / "huge.xyz"
    path.write_text("0 0 0\n" * 10)
    with pytest.raises(UserError, match="huge.xyz: .* limit; decimate"):
        read_geometry(path)


def zero_area_stl(path):
    trimesh.Trimesh([[0, 0, 0], [1, 1, 1], [2, 2, 2]], [[0, 1, 2]], process=False).export(path)


def nan_obj(path):
    path.write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")


BAD = [
    ("shape.fbx", lambda p: p.write_bytes(b"x"), "unknown input kind .fbx"),
    ("empty.obj", lambda p: p.write_bytes(b""), "the file is empty"),
    ("broken.npy", lambda p: p.write_bytes(b"not numpy"), "not a readable .npy"),
    ("words.xyz", lambda p: p.write_text("just\nwords\n"), "no line of x y z numbers"),
    ("flat.npy", lambda p: np.save(p, np.zeros((200, 2))), "expected N x 3"),
    ("nan.xyz", lambda p: p.write_text("".join(f"{i} {i} {i}\n" for i in range(200)) + "nan 0 0\n"), "1 points have NaN"),
    ("few.xyz", lambda p: p.write_text("".join(f"{i} 0 {i % 7}\n" for i in range(50))), "give at least 100"),
    ("same.xyz", lambda p: p.write_text("1 2 3\n" * 200), "all points coincide"),
    ("line.stl", zero_area_stl, "no surface area"),
    ("nan.obj", nan_obj, "NaN or infinite"),
    ("nothing.ply", lambda p: p.write_text("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\n"
                                           "property float y\nproperty float z\nend_header\n"), "no geometry"),
]


@pytest.mark.parametrize("name,write,message", BAD)
def test_what_cannot_be_used_is_one_line_naming_the_file(tmp_path, name, write, message):
    path = tmp_path / name
    write(path)
    with pytest.raises(UserError) as info:
        read_geometry(path)
    line = str(info.value)
    assert "\n" not in line and name in line and message in line, line
    assert ";" in line   # the fix


@pytest.mark.blender
def test_a_program_shape_in_every_format(tmp_path):
    pytest.importorskip("bpy")
    from geocode.program import Program

    mesh = Program.load("table").evaluate({})
    mesh = trimesh.Trimesh(mesh.vertices * 37.0 + (100, -5, 3), mesh.faces, process=False)
    for suffix in (".obj", ".ply", ".stl", ".off", ".glb"):
        mesh.export(tmp_path / f"table{suffix}")
        got = read_geometry(tmp_path / f"table{suffix}")
        assert got.mesh.area == pytest.approx(mesh.area, rel=1e-4), suffix
    np.savetxt(tmp_path / "table.xyz", surface_points(got, 3000, np.random.default_rng(0)), header="x y z")
    assert read_geometry(tmp_path / "table.xyz").points.shape == (3000, 3)
