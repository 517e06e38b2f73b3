"""geocode.reconstruct.inputs on files made here: every format, clouds with headers, scenes, size bounds,
and the one-line refusals; and the output names of `geocode.reconstruct.plan`."""

import io
import json
import struct
import zipfile
import zlib

import numpy as np
import pytest
import trimesh

from geocode.errors import UserError
from geocode.reconstruct import inputs
from geocode.reconstruct.inputs import keep_main_object, read_geometry, surface_points
from geocode.reconstruct.plan import RECORD, output_suffixes, plan_run


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


@pytest.mark.parametrize("size", [20000, 6000])     # more points than the samples, and fewer
def test_a_scan_stored_row_by_row_gives_samples_spread_over_its_whole_height(size):
    """A cloud sorted by height (a scanner's rows): the fit's first 4096 samples span the whole
    height, not its bottom, and the same seed gives the same samples."""
    rng = np.random.default_rng(1)
    angle, height = rng.uniform(0, 2 * np.pi, size), np.sort(rng.uniform(0, 1, size))
    g = inputs.Geometry(None, np.stack([np.cos(angle), np.sin(angle), height], 1), None, "cloud")
    samples = surface_points(g, 10000, np.random.default_rng(0))
    first = samples[:4096, 2]
    assert first.min() < 0.02 and first.max() > 0.98
    assert np.histogram(first, bins=10, range=(0, 1))[0].min() > 4096 / 10 * 0.7   # evenly, not one end
    assert np.array_equal(samples, surface_points(g, 10000, np.random.default_rng(0)))


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
    ("nan.xyz", lambda p: p.write_text("".join(f"{i} {i} {i}\n" for i in range(200)) + "nan 0 0\n"), "1 points have NaN"),  # noqa: E501  (a table row)
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
    from geocode.program import Program

    mesh = Program.load("table").evaluate({})
    mesh = trimesh.Trimesh(mesh.vertices * 37.0 + (100, -5, 3), mesh.faces, process=False)
    for suffix in (".obj", ".ply", ".stl", ".off", ".glb"):
        mesh.export(tmp_path / f"table{suffix}")
        got = read_geometry(tmp_path / f"table{suffix}")
        assert got.mesh.area == pytest.approx(mesh.area, rel=1e-4), suffix
    np.savetxt(tmp_path / "table.xyz", surface_points(got, 3000, np.random.default_rng(0)), header="x y z")
    assert read_geometry(tmp_path / "table.xyz").points.shape == (3000, 3)


# -- bounds, before anything is decoded --------------------------------------------------------

def png_header(path, width, height):
    """A PNG whose header says width x height: a few hundred bytes, never decoded whole."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(b"\0" * 1000)) + chunk(b"IEND", b""))
    return path


def test_a_huge_drawing_is_refused_from_its_header(tmp_path, monkeypatch):
    from PIL import ImageFile

    def decoded(*_):
        raise AssertionError("the pixels were decoded")
    path = png_header(tmp_path / "drawing.png", 30000, 30000)
    with monkeypatch.context() as patch, pytest.raises(UserError) as info:
        patch.setattr(ImageFile.ImageFile, "load", decoded)
        inputs.open_image(path)
    line = str(info.value)
    assert line.startswith(f"{path}: 30000 x 30000 pixels is over the limit of 36 million; ")
    assert f"at most {inputs.MAX_SIDE} x {inputs.MAX_SIDE} pixels" in line and "\n" not in line
    with inputs.open_image(png_header(tmp_path / "fine.png", 6000, 6000)) as image:
        assert image.size == (6000, 6000)
    (tmp_path / "words.png").write_text("not an image")
    with pytest.raises(UserError, match="words.png: not a readable PNG or JPEG image"):
        inputs.open_image(tmp_path / "words.png")


def test_an_npz_array_is_measured_from_its_header_before_it_is_unpacked(tmp_path):
    """A 2 kB .npz whose array says 24 GB: refused without allocating it."""
    path = tmp_path / "bomb.npz"
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 3)})
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("points.npy", header.getvalue() + b"\0" * 1000)
    with pytest.raises(UserError, match=r"bomb.npz: its array 'points' \(1000000000, 3\) is 22.4 GiB unpacked"):
        read_geometry(path)


def test_the_files_a_gltf_refers_to_count_towards_the_limit(tmp_path, monkeypatch):
    for name, data in one(stool()).export(file_type="gltf").items():
        (tmp_path / name).write_bytes(data)
    path = tmp_path / "model.gltf"
    assert read_geometry(path).kind == "mesh"
    monkeypatch.setattr(inputs, "MAX_BYTES", path.stat().st_size + 100)   # the .gltf fits, its buffers not
    with pytest.raises(UserError, match=r"model.gltf: with the files it refers to \(gltf_buffer_\d.bin the last\)"):
        read_geometry(path)


def test_materials_and_textures_are_never_read(tmp_path, monkeypatch):
    """An OBJ's material and texture files are not even opened: its mesh alone is read."""
    box = trimesh.creation.box()
    (tmp_path / "box.mtl").write_text("newmtl skin\nmap_Kd skin.png\n")
    (tmp_path / "box.obj").write_text(
        "mtllib box.mtl\nusemtl skin\n" + "".join(f"v {x} {y} {z}\nvt 0 0\n" for x, y, z in box.vertices)
        + "".join(f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}\n" for a, b, c in box.faces))
    (tmp_path / "skin.png").write_bytes(b"\0" * 100_000)
    asked, get = [], inputs.BoundedFiles.get
    monkeypatch.setattr(inputs.BoundedFiles, "get", lambda self, name: asked.append(name) or get(self, name))
    got = read_geometry(tmp_path / "box.obj")
    assert got.mesh.area == pytest.approx(6.0) and asked == []


# -- output names -----------------------------------------------------------------------------------

def touch(folder, *names):
    for name in names:
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(name)


def stems(plan):
    return {job.name: job.stem.relative_to(plan.out_dir).as_posix() for job in plan.jobs}


def test_each_input_gets_its_own_output_names(tmp_path):
    """Stems that collide keep their suffix; names made so collide again keep theirs too; a
    suffix-less output of one input that is another input (x.in-place.obj) counts."""
    touch(tmp_path / "in", "scan.obj", "scan.ply", "a.png", "a.jpg", "x/a.obj", "y/a.obj", "plain.stl",
          "scan-obj.stl", "v.obj", "v.in-place.obj")
    plan = plan_run(tmp_path / "in", tmp_path / "out", recursive=True)
    assert stems(plan) == {"scan.obj": "scan-obj", "scan.ply": "scan-ply", "a.png": "a-png", "a.jpg": "a-jpg",
                           "x/a.obj": "x/a", "y/a.obj": "y/a", "plain.stl": "plain", "scan-obj.stl": "scan-obj-stl",
                           "v.obj": "v-obj", "v.in-place.obj": "v.in-place-obj"}
    outputs = [f"{job.stem}{s}" for job in plan.jobs for s in output_suffixes(job.path)]
    assert len(set(outputs)) == len(outputs)
    assert stems(plan_run(tmp_path / "in", tmp_path / "out", recursive=True)) == stems(plan)


def test_outputs_never_replace_an_input_or_a_file_reconstruct_did_not_write(tmp_path):
    folder = tmp_path / "scans"
    touch(folder, "scan.obj", "chair.obj", "chair.blend")
    assert stems(plan_run(folder / "scan.obj", folder, recursive=False)) == {"scan.obj": "scan-obj"}
    assert stems(plan_run(folder / "chair.obj", folder, recursive=False)) == {"chair.obj": "chair-obj"}
    assert stems(plan_run(folder / "chair.obj", tmp_path / "out", recursive=False)) == {"chair.obj": "chair"}
    touch(folder, "index.html")
    with pytest.raises(UserError, match="index.html: would be replaced by the page, but reconstruct did not write it"):
        plan_run(folder / "scan.obj", folder, recursive=False)
    touch(tmp_path / "clouds", "summary.csv")
    with pytest.raises(UserError, match="summary.csv: would be replaced by the page"):
        plan_run(tmp_path / "clouds", tmp_path / "clouds", recursive=False)


def test_a_folder_reconstructed_into_itself_keeps_its_names_and_inputs(tmp_path):
    """The record makes a rerun replace the run's own files, never take them for inputs, and
    give the same names."""
    folder = tmp_path / "scans"
    touch(folder, "scan.obj", "scan.ply", "vase.stl")
    first = plan_run(folder, folder, recursive=True)
    first.write_record()
    touch(folder, *first.files)                      # what the run wrote
    again = plan_run(folder, folder, recursive=True)
    assert stems(again) == stems(first) == {"scan.obj": "scan-obj", "scan.ply": "scan-ply", "vase.stl": "vase"}
    assert json.loads(again.record_text())["files"] == sorted(first.files)
    (folder / RECORD).write_text("[1, 2]")
    with pytest.raises(UserError, match="is not a record of geocode reconstruct"):
        plan_run(folder, folder, recursive=True)
