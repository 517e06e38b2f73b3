"""`geocode reconstruct` and the fit, on small files made here; the model is an untrained
network of the real architecture (its prediction is arbitrary, the plumbing is real)."""

import csv
import io
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import trimesh
import yaml
from PIL import Image, ImageDraw
from scipy import ndimage

from geocode.cli import main
from geocode.meshio import normalise_unit_sphere
from geocode.points import sample_surface
from geocode.program import Program
from geocode.reconstruct.fit import CloudDistance, Start, fit, shape_points
from geocode.reconstruct.linedraw import TRUNCATE
from geocode.reconstruct.page import SIZE
from geocode.reconstruct.plan import RECORD, SHAPE_OUTPUTS
from geocode.reconstruct.run import SKETCH_EXTENT, sketch_from_image

pytestmark = pytest.mark.blender
SHAPE = {"body_height": 1.2, "handle_count": 2, "belly_width": 0.6}


def untrained_checkpoint(path, domain):
    import torch

    from geocode.models import GeoCodeModule
    from geocode.models.heads import head_specs

    torch.manual_seed(0)
    model = GeoCodeModule(heads=head_specs(Program.load(domain).recipe()))
    torch.save({"state_dict": model.state_dict(), "hyper_parameters": dict(model.hparams)}, path)
    return path


def older_program_checkpoint(checkpoint, path):
    """`checkpoint`, stamped as trained when the program's first float had other classes
    (its range changed since): its classes would decode to other values."""
    import torch

    from geocode.checkpoints import recipe_stamp

    recipe = Program.load("vase").recipe()
    stamp = recipe_stamp(recipe)
    name = next(p.name for p in recipe.parameters if p.kind == "float")
    stamp["grid"][name] = [v * 0.5 if isinstance(v, float) else v for v in stamp["grid"][name]]
    torch.save({**torch.load(checkpoint, weights_only=True), "recipe": stamp}, path)
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A vase as every input kind, and checkpoints."""
    root = tmp_path_factory.mktemp("inputs")
    mesh = Program.load("vase").evaluate(SHAPE)
    plain = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    for suffix in ("obj", "ply", "stl"):
        plain.export(root / f"vase.{suffix}")
    y_up = plain.copy()
    y_up.vertices = np.stack([plain.vertices[:, 0], plain.vertices[:, 2], -plain.vertices[:, 1]], 1)
    y_up.export(root / "vase.glb")
    cloud = sample_surface(plain, 3000, np.random.default_rng(1))
    np.save(root / "cloud.npy", cloud)
    np.savetxt(root / "cloud.xyz", cloud)
    trimesh.PointCloud(cloud).export(root / "cloud.ply")
    drawing = Image.new("RGB", (900, 600), "white")
    ImageDraw.Draw(drawing).ellipse((250, 60, 650, 540), outline="black", width=14)
    drawing.save(root / "drawing.jpg")
    return {"root": root, "ckpt": untrained_checkpoint(root / "vase.ckpt", "vase")}


@pytest.mark.parametrize("name", ["vase.obj", "vase.ply", "vase.stl", "vase.glb", "cloud.npy",
                                  "cloud.xyz", "cloud.ply", "drawing.jpg"])
def test_every_input_kind_gives_values_mesh_preview_and_blend(files, tmp_path, capsys, name):
    refine = ["--budget", "0"] if name.endswith(".jpg") else ["--budget", "6"]
    code = main(["reconstruct", "vase", str(files["root"] / name), "-o", str(tmp_path),
                 "--checkpoint", str(files["ckpt"]), "--json", *refine])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)      # --json prints the JSON alone
    stem = name.split(".")[0]
    drawing = name.endswith(".jpg")
    per_input = (".yaml", ".obj", ".png", ".blend") + (() if drawing else (".in-place.obj",))
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [f"{stem}{s}" for s in per_input] + ["index.html", "summary.csv", "page", RECORD])
    values = yaml.safe_load((tmp_path / f"{stem}.yaml").read_text())
    assert set(values) == {p.name for p in Program.load("vase").parameters}
    if not drawing:
        assert summary["kind"] == ("cloud" if name.startswith("cloud") else "mesh")
        assert summary["evaluations"] == 6
        assert summary["chamfer_after"] <= summary["chamfer_before"]


def test_the_program_defaults_are_measured_in_the_pose_found(files, tmp_path, capsys):
    """The defaults' distance to the default vase (sampling, and handles at the turn found) is a
    fraction of their distance to a box; no training shapes here, so no nearest one."""
    Program.load("vase").evaluate({}).export(tmp_path / "default.obj")
    trimesh.creation.box(extents=(1.0, 0.6, 1.4)).export(tmp_path / "box.obj")
    distances = {}
    for name, path in (("default", tmp_path / "default.obj"), ("other", tmp_path / "box.obj")):
        assert main(["reconstruct", "vase", str(path), "-o", str(tmp_path / name), "--up", "z",
                     "--checkpoint", str(files["ckpt"]), "--json", "--budget", "0"]) == 0
        summary = json.loads(capsys.readouterr().out)
        assert "chamfer_nearest" not in summary
        distances[name] = summary["chamfer_defaults"]
    assert distances["default"] < distances["other"] / 5, distances


def test_a_drawing_is_fitted_with_its_camera(files, tmp_path, capsys):
    """--budget on a drawing searches shape and camera within the budget, and the page and
    the preview show our line drawing of the result between the drawing and the shape."""
    out = tmp_path / "out"
    assert main(["reconstruct", "vase", str(files["root"] / "drawing.jpg"), "-o", str(out),
                 "--checkpoint", str(files["ckpt"]), "--json", "--budget", "6"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["evaluations"] == 6
    assert set(summary["camera"]) == {"azimuth", "elevation", "roll", "scale", "offset"}
    # distances truncated at TRUNCATE px per stroke pixel; that far only when a drawing is blank
    assert 0 < summary["drawing_after"] < TRUNCATE and 0 < summary["drawing_before"] < TRUNCATE
    html = (out / "index.html").read_text()
    assert "our line drawing of the result" in html and " px" in html
    with Image.open(out / "drawing.png") as preview:
        assert preview.width == 3 * SIZE          # drawing, our line drawing, shaded shape


def test_the_in_place_mesh_lies_over_the_input(files, tmp_path):
    """A vase moved far away and scaled up comes back over itself in its own frame."""
    mesh = trimesh.load(files["root"] / "vase.obj", process=False)
    mesh.vertices = mesh.vertices * 40.0 + [100.0, -20.0, 7.0]
    mesh.export(tmp_path / "far.obj")
    out = tmp_path / "out"
    assert main(["reconstruct", "vase", str(tmp_path / "far.obj"), "-o", str(out), "--up", "z",
                 "--checkpoint", str(files["ckpt"]), "--budget", "4"]) == 0
    placed = trimesh.load(out / "far.in-place.obj", process=False)
    assert np.allclose(placed.bounds.mean(0), mesh.bounds.mean(0), atol=0.3 * 40)
    assert 0.5 < placed.extents.max() / mesh.extents.max() < 2.0


def test_a_folder_is_reconstructed_with_a_page(files, tmp_path, capsys):
    """Every input of a folder and its subfolders (equal stems kept apart), a bad one noted
    on the page without stopping the rest."""
    folder = tmp_path / "in"
    (folder / "sub").mkdir(parents=True)
    for target in (folder / "vase.obj", folder / "sub" / "vase.obj"):
        target.write_bytes((files["root"] / "vase.obj").read_bytes())
    (folder / "broken.xyz").write_text("not a cloud\n")
    out = tmp_path / "out"
    assert main(["reconstruct", "vase", str(folder), "-o", str(out), "--recursive", "--json",
                 "--checkpoint", str(files["ckpt"]), "--budget", "3", "--candidates", "2"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    seconds = summary.pop("seconds_median"), *summary.pop("seconds_range")
    before, after = summary.pop("chamfer_before_median"), summary.pop("chamfer_after_median")
    assert summary.pop("chamfer_defaults_median") > 0      # no training shapes here: no nearest one
    assert summary == {"inputs": 3, "reconstructed": 2, "failed": 1, "page": str(out / "index.html")}
    assert 0 < after <= before   # the same file twice: its own distances, the fit never worse
    assert 0 < seconds[1] <= seconds[0] <= seconds[2]
    assert (out / "vase.blend").exists() and (out / "sub" / "vase.blend").exists()
    html = (out / "index.html").read_text()
    assert "sub/vase.obj" in html and "broken.xyz" in html
    assert len((out / "summary.csv").read_text().strip().splitlines()) == 4


def listing(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())


def rows_without_seconds(summary_csv):
    return [{k: v for k, v in row.items() if k != "seconds"}
            for row in csv.DictReader(io.StringIO(summary_csv.read_text()))]


def test_one_file_into_its_own_folder_replaces_neither_it_nor_the_users_files(files, tmp_path, capsys):
    folder = tmp_path / "scans"
    folder.mkdir()
    scan = folder / "chair.obj"
    scan.write_bytes((files["root"] / "vase.obj").read_bytes())
    (folder / "chair.blend").write_text("the user's own")
    mine = {p.name: p.read_bytes() for p in folder.iterdir()}
    for _ in range(2):   # a rerun: the same names, its own files replaced
        assert main(["reconstruct", "vase", str(scan), "-o", str(folder), "--refine", "0",
                     "--checkpoint", str(files["ckpt"])]) == 0
        assert {name: (folder / name).read_bytes() for name in mine} == mine
        assert {p.name for p in folder.iterdir()} == {*mine, *(f"chair-obj{s}" for s in SHAPE_OUTPUTS),
                                                      "index.html", "summary.csv", "page", RECORD}


def test_a_folder_into_itself_gives_each_input_its_names_and_one_process_s_results(files, tmp_path):
    """scan.obj and scan.ply, a.png and a.jpg, reconstructed into their own folder by one process
    and then by two: the inputs untouched, each input its own files (the suffix kept where
    stems collide), the same names, no output taken for an input, the same results."""
    folder = tmp_path / "scans"
    folder.mkdir()
    for source, name in (("vase.obj", "scan.obj"), ("vase.ply", "scan.ply"), ("drawing.jpg", "a.jpg")):
        (folder / name).write_bytes((files["root"] / source).read_bytes())
    Image.open(files["root"] / "drawing.jpg").save(folder / "a.png")
    mine = {p.name: p.read_bytes() for p in folder.iterdir()}
    runs = []
    for workers in ("1", "2"):
        assert main(["reconstruct", "vase", str(folder), "-o", str(folder), "--refine", "4", "--workers", workers,
                     "--checkpoint", str(files["ckpt"])]) == 0
        assert {name: (folder / name).read_bytes() for name in mine} == mine
        values = {p.name: p.read_text() for p in folder.glob("*.yaml")}
        runs.append((listing(folder), rows_without_seconds(folder / "summary.csv"), values))
    assert runs[0] == runs[1]
    names, rows, values = runs[0]
    assert sorted(values) == ["a-jpg.yaml", "a-png.yaml", "scan-obj.yaml", "scan-ply.yaml"]
    assert [row["name"] for row in rows] == ["a.jpg", "a.png", "scan.obj", "scan.ply"]
    assert all(not row["error"] for row in rows)
    assert "scan-obj.in-place.obj" in names and "a-png.in-place.obj" not in names


def test_a_huge_drawing_is_one_line(files, tmp_path, capsys):
    from test_inputs import png_header

    out = tmp_path / "out"
    path = png_header(tmp_path / "drawing.png", 30000, 30000)
    assert main(["reconstruct", "vase", str(path), "-o", str(out), "--checkpoint", str(files["ckpt"])]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"geocode: {path}: 30000 x 30000 pixels is over the limit of 36 million; give a drawing "
                   "of at most 6000 x 6000 pixels (scale it down: it is brought to 224 x 224)")
    assert not out.exists()


def test_a_set_up_error_in_the_workers_is_one_line_before_any_file(files, tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("a.obj", "b.obj"):
        (folder / name).write_bytes((files["root"] / "vase.obj").read_bytes())
    out = tmp_path / "out"
    assert main(["reconstruct", "vase", str(folder), "-o", str(out), "--workers", "2",
                 "--checkpoint", str(tmp_path / "none.ckpt")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "none.ckpt: no trained vase model" in err, err
    assert not out.exists()


RUN = "import sys; from geocode.cli import main; sys.exit(main(sys.argv[1:]))"


def test_a_stop_signal_ends_the_workers_and_leaves_no_half_written_file(files, tmp_path):
    """SIGTERM to the command (as Snakemake or SLURM stop a job) while a worker writes a file's
    outputs: every worker ends, their temporary files removed, exit 143 with one line."""
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("a.obj", "b.obj", "c.obj"):
        (folder / name).write_bytes((files["root"] / "vase.obj").read_bytes())
    out = tmp_path / "out"
    command = subprocess.Popen([sys.executable, "-c", RUN, "reconstruct", "vase", str(folder), "-o", str(out),
                                "--workers", "2", "--refine", "20", "--checkpoint", str(files["ckpt"])],
                               stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 600
    while not list(out.rglob("*.tmp")) and command.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    command.send_signal(signal.SIGTERM)
    _, err = command.communicate(timeout=120)
    assert command.returncode == 143, err
    assert err.strip().splitlines()[-1] == "geocode: stopped by SIGTERM; rerun the same command to go on"
    assert not list(out.rglob("*.tmp"))
    for _ in range(100):            # the workers (and Python's resource tracker) have ended
        try:
            os.killpg(command.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        pytest.fail("processes of the stopped command are still running")


def test_a_y_up_file_comes_to_the_same_frame_as_a_z_up_one(files):
    from geocode.config import compose
    from geocode.reconstruct.inputs import read_geometry
    from geocode.reconstruct.run import Reconstructor

    run = Reconstructor(compose(["domain=vase"]), "vase", files["ckpt"], refine=0, up="y")
    glb = run.frames(read_geometry(files["root"] / "vase.glb"))[0].samples
    run.up = "z"
    obj = run.frames(read_geometry(files["root"] / "vase.obj"))[0].samples
    assert np.allclose(glb.min(0), obj.min(0), atol=0.05) and np.allclose(glb.max(0), obj.max(0), atol=0.05)


def test_the_network_answer_is_the_nearest_of_its_feedback_rounds(files):
    """--budget 0: the network's answer at its best turn, or one of its own feedback rounds
    where that lies nearer the input: never farther than the answer it started from."""
    from geocode.config import compose
    from geocode.reconstruct.fit import network_starts
    from geocode.reconstruct.inputs import read_geometry
    from geocode.reconstruct.run import TURNS, Reconstructor, start_placement

    run = Reconstructor(compose(["domain=vase"]), "vase", files["ckpt"], refine=0, up="z")
    result = run(files["root"] / "vase.obj")
    frame = run.frames(read_geometry(files["root"] / "vase.obj"))[0]
    _, start = run.best_answer(frame, network_starts(run.model, run.recipe, frame.cloud, TURNS, run.cfg.eval.decode))
    assert result.network == result.answers[0].chamfer
    assert result.network <= run.score(frame, start.values, start_placement(start)) + 1e-12


def test_drawing_is_brought_to_the_sketch_format(files):
    sketch = sketch_from_image(files["root"] / "drawing.jpg")
    assert sketch.shape == (1, 224, 224) and set(np.unique(sketch)) <= {0.0, 1.0}
    ink = sketch[0] == 0
    ys, xs = np.nonzero(ink)
    assert abs(max(ys.ptp(), xs.ptp()) + 1 - SKETCH_EXTENT) <= 6   # thinning eats the rim
    width = 2 * np.percentile(ndimage.distance_transform_edt(ink)[ink], 90)
    assert width <= 3   # 14 px strokes thinned to the sketches' ~2 px


def test_fit_never_increases_the_distance_and_stays_in_range(files):
    from geocode.config import compose, settings

    vase = Program.load("vase")
    recipe = vase.recipe()
    target = vase.evaluate(SHAPE)
    cloud = sample_surface(normalise_unit_sphere(target), 2000, np.random.default_rng(3))
    start = {p.name: p.default for p in vase.parameters}
    options = {"handle_count": [0.0, 2.0, 4.0]}
    tuning = settings(compose([])).fit.cloud
    result = fit(vase, recipe, [Start(start, options)], cloud, budget=40, tuning=tuning, seed=0)
    assert result.evaluations == 40
    assert result.after <= result.before
    fitted = result.pose.apply(shape_points(vase, result.values))
    assert result.after == pytest.approx(CloudDistance(cloud, tuning.trim)(fitted))
    for p in recipe.parameters:
        assert p.min <= result.values[p.name] <= p.max
    assert result.values["handle_count"] in options["handle_count"]


BAD = [
    ("empty.obj", b"", "the file is empty"),
    ("broken.npy", b"not numpy", "not a readable .npy"),
    ("nan.xyz", b"".join(b"%f %f %f\n" % (i, i, i) for i in range(200)) + b"nan 0 0\n", "NaN"),
    ("few.xyz", b"".join(b"%d 0 %d\n" % (i, i % 7) for i in range(50)), "give at least 100"),
    ("shape.fbx", b"x", "unknown input kind .fbx"),
]


@pytest.mark.parametrize("name,content,message", BAD)
def test_bad_input_gives_one_line_and_writes_nothing(files, tmp_path, capsys, name, content, message):
    path = tmp_path / name
    path.write_bytes(content)
    out = tmp_path / "out"
    assert main(["reconstruct", "vase", str(path), "-o", str(out), "--checkpoint", str(files["ckpt"])]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and name in err and message in err
    assert not out.exists()


def test_blank_image_missing_and_foreign_checkpoints_are_refused(files, tmp_path, capsys):
    blank = tmp_path / "blank.png"
    Image.new("L", (300, 300), 255).save(blank)
    out = tmp_path / "out"
    chair_ckpt = untrained_checkpoint(tmp_path / "chair.ckpt", "chair")
    older = older_program_checkpoint(files["ckpt"], tmp_path / "older.ckpt")
    cases = [
        ([str(files["root"] / "vase.obj"), "--checkpoint", str(older)], "retrain"),
        ([str(blank), "--checkpoint", str(files["ckpt"])], "blank"),
        ([str(files["root"] / "vase.obj"), "--checkpoint", str(tmp_path / "none.ckpt")], "no trained vase model"),
        ([str(files["root"] / "vase.obj"), "--checkpoint", str(chair_ckpt)], "other parameters"),
        ([str(files["root"] / "vase.obj"), f"paths.runs={tmp_path / 'runs'}"], "no trained vase model"),
    ]
    for args, message in cases:
        assert main(["reconstruct", "vase", args[0], "-o", str(out), *args[1:]]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err, err
        assert not out.exists()


def test_a_failure_in_the_last_output_leaves_none(files, tmp_path, capsys, monkeypatch):
    from geocode.errors import UserError

    def broken_save(self, path):
        raise UserError(path, "cannot be saved", "a test")
    monkeypatch.setattr(Program, "save_blend", broken_save)
    out = tmp_path / "out"
    assert main(["reconstruct", "vase", str(files["root"] / "vase.obj"), "-o", str(out),
                 "--checkpoint", str(files["ckpt"]), "--budget", "0"]) == 2
    assert "cannot be saved" in capsys.readouterr().err
    assert not out.exists()


REOPEN = """
import bpy, json, sys
bpy.ops.wm.open_mainfile(filepath=sys.argv[1])
mod = next(m for o in bpy.data.objects for m in o.modifiers
           if m.type == "NODES" and m.node_group.name == "GeoCode vase")
values = {item.name: mod[item.identifier] for item in mod.node_group.interface.items_tree
          if item.item_type == "SOCKET" and item.in_out == "INPUT" and item.socket_type != "NodeSocketGeometry"}
print("RESULT", json.dumps({k: (list(v) if hasattr(v, "__len__") else v) for k, v in values.items()}))
"""


def test_blend_reopens_with_the_values_set(files, tmp_path):
    assert main(["reconstruct", "vase", str(files["root"] / "vase.obj"), "-o", str(tmp_path),
                 "--checkpoint", str(files["ckpt"]), "--budget", "3"]) == 0
    values = yaml.safe_load((tmp_path / "vase.yaml").read_text())
    run = subprocess.run([sys.executable, "-c", REOPEN, str(tmp_path / "vase.blend")],
                         capture_output=True, text=True, timeout=300)
    line = next(ln for ln in run.stdout.splitlines() if ln.startswith("RESULT"))
    saved = json.loads(line[len("RESULT "):])
    for name, value in values.items():
        assert saved[name] == pytest.approx(float(value), abs=1e-5), name


def test_thick_strokes_are_thinned_and_thin_ones_kept(tmp_path):
    """A drawing with a 16 px outline and a 2 px detail: the outline comes out about 2 px
    wide, and the detail survives (erosion to the outline's width would erase it)."""
    image = np.full((400, 400), 255, np.uint8)
    image[40:360, 40:56] = image[40:360, 344:360] = image[40:56, 40:360] = image[344:360, 40:360] = 0
    image[100:300, 199:201] = 0                             # the detail: a 2 px line inside
    Image.fromarray(image).save(tmp_path / "box.png")
    ink = sketch_from_image(tmp_path / "box.png")[0] == 0
    assert ink[:, 100:124].any(axis=1).sum() > 80           # the detail's column is still drawn
    width = 2 * np.percentile(ndimage.distance_transform_edt(ink)[ink], 90)
    assert width <= 3
    left = ink[112, :40]                                     # across the left outline
    assert 1 <= left.sum() <= 3
