"""Editing in parameter space (mix, interpolate) and the building blocks as a Blender extension."""

import json
import os
import subprocess
import sys
import zipfile

import numpy as np
import pytest
import yaml
from PIL import Image

from geocode import meshio
from geocode.cli import main
from geocode.program import Program
from geocode.tools import editing

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def vase():
    return Program.load("vase")


@pytest.fixture
def shapes(tmp_path):
    a = tmp_path / "a.yaml"
    b = tmp_path / "b.yaml"
    a.write_text("body_height: 0.7\nhandle_count: 0\nbelly_width: 0.3\n")
    b.write_text("body_height: 1.5\nhandle_count: 2\nhandle_reach: 0.3\nbelly_width: 0.7\n")
    return a, b


def test_read_values_fills_defaults_and_checks_ranges(vase, shapes, tmp_path):
    values = editing.read_values(shapes[0], vase)
    assert set(values) == {p.name for p in vase.parameters}
    assert values["body_height"] == 0.7
    bad = tmp_path / "bad.yaml"
    bad.write_text("body_height: 9\n")
    with pytest.raises(ValueError, match=r"bad\.yaml: body_height=9"):
        editing.read_values(bad, vase)


def test_mix_takes_exactly_the_named_parameters(vase, shapes):
    a, b = (editing.read_values(p, vase) for p in shapes)
    take = editing.select(vase, ["handle", "belly_width"])
    assert take[0] == "handle_count" and "belly_width" in take
    assert all(n.startswith("handle_") for n in take if n != "belly_width")
    mixed = editing.mix(a, b, take)
    for name in mixed:
        assert mixed[name] == (b[name] if name in take else a[name]), name
    with pytest.raises(ValueError, match="--take nothing"):
        editing.select(vase, ["nothing"])


def test_interpolation_ends_at_the_inputs_and_switches_discrete_at_the_midpoint(vase, shapes):
    a, b = (editing.read_values(p, vase) for p in shapes)
    sequence = editing.interpolate(vase, a, b, 6)
    assert sequence[0] == a and sequence[-1] == b
    heights = [s["body_height"] for s in sequence]
    assert heights == sorted(heights) and len(set(heights)) == 6
    assert [s["handle_count"] for s in sequence] == [0, 0, 0, 2, 2, 2]


def _assert_written_shape(obj, values_file, program, values):
    """The YAML holds `values` and the OBJ is the program's mesh at them, on the unit sphere."""
    assert {k: float(v) for k, v in yaml.safe_load(values_file.read_text()).items()} == values
    mesh, want = meshio.read_obj(obj), meshio.normalise_unit_sphere(program.evaluate(values))
    np.testing.assert_array_equal(mesh.faces, want.faces)
    np.testing.assert_allclose(mesh.vertices, want.vertices, atol=1e-6)


def test_mix_writes_a_with_the_parameters_taken_from_b(vase, shapes, tmp_path):
    a, b = (editing.read_values(p, vase) for p in shapes)
    assert main(["mix", "vase", *map(str, shapes), "--take", "handle", "-o", str(tmp_path / "m.obj")]) == 0
    mixed = {name: (b if name.startswith("handle_") else a)[name] for name in a}
    assert (mixed["body_height"], mixed["belly_width"], mixed["handle_count"], mixed["handle_reach"]) \
        == (0.7, 0.3, 2.0, 0.3)
    _assert_written_shape(tmp_path / "m.obj", tmp_path / "m.yaml", vase, mixed)


def test_interpolate_writes_each_step_and_a_strip_of_them(vase, shapes, tmp_path):
    a, b = (editing.read_values(p, vase) for p in shapes)
    out = tmp_path / "seq"
    assert main(["interpolate", "vase", *map(str, shapes), "--steps", "3", "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "step-00.obj", "step-00.yaml", "step-01.obj", "step-01.yaml", "step-02.obj",
        "step-02.yaml", "strip.png"]
    steps = editing.interpolate(vase, a, b, 3)
    assert steps[0] == a and steps[2] == b and steps[1]["body_height"] == pytest.approx(1.1)
    for i, values in enumerate(steps):
        _assert_written_shape(out / f"step-{i:02d}.obj", out / f"step-{i:02d}.yaml", vase, values)
    strip = Image.open(out / "strip.png")
    assert strip.width == 3 * strip.height                  # one square picture per step, in a row


def test_bad_shape_file_gives_one_line_and_writes_nothing(shapes, tmp_path, capsys):
    out = tmp_path / "out"
    missing = tmp_path / "missing.yaml"
    assert main(["mix", "vase", str(missing), str(shapes[1]), "--take", "handle",
                 "-o", str(out / "m.obj")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "missing.yaml" in err
    assert not out.exists()


def test_interpolate_whose_strip_fails_leaves_no_step(shapes, tmp_path, capsys, monkeypatch):
    from geocode.errors import UserError

    def broken_strip(meshes, png):
        raise UserError(png, "cannot be rendered", "a test")
    monkeypatch.setattr("geocode.blender.gallery.render_strip", broken_strip)
    out = tmp_path / "seq"
    assert main(["interpolate", "vase", *map(str, shapes), "--steps", "3", "-o", str(out)]) == 2
    assert "cannot be rendered" in capsys.readouterr().err
    assert not out.exists()


INSTALL = """
import bpy, json, sys
bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="user_default",
                                         enable_on_install=True)
import bl_ext.user_default.geocode_nodes as addon
menus = [m for m in dir(bpy.types) if m.startswith("NODE_MT_geocode")]
in_add_menu = addon.draw_add_menu in bpy.types.NODE_MT_add._dyn_ui_initialize()
tree = bpy.data.node_groups.new("user program", "GeometryNodeTree")
added = {}
for category, names in addon.categories().items():
    for name in names:
        node = tree.nodes.new("GeometryNodeGroup")
        node.node_tree = addon.load_block(name)
        added[name] = [s.name for s in node.inputs]
print("RESULT", json.dumps({"menus": menus, "in_add_menu": in_add_menu, "added": added}))
"""


def test_addon_installs_into_blender_and_adds_every_block(tmp_path):
    out = tmp_path / "geocode_nodes.zip"
    assert main(["addon", "build", "-o", str(out)]) == 0
    with zipfile.ZipFile(out) as z:
        assert {"blender_manifest.toml", "__init__.py", "blocks.blend", "blocks.json"} <= set(z.namelist())
        categories = json.loads(z.read("blocks.json"))
        assert 'type = "add-on"' in z.read("blender_manifest.toml").decode()
    from geocode.nodes import BLOCKS

    assert sorted(n for names in categories.values() for n in names) == sorted(BLOCKS)
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "blender")}
    run = subprocess.run([sys.executable, "-c", INSTALL, str(out)], env=env, text=True,
                         capture_output=True, timeout=300)
    line = next(ln for ln in run.stdout.splitlines() if ln.startswith("RESULT"))
    result = json.loads(line[len("RESULT "):])
    assert "NODE_MT_geocode" in result["menus"] and result["in_add_menu"]
    assert sorted(result["added"]) == sorted(BLOCKS)
    assert all(result["added"].values())  # every group node has its block's inputs
    assert (tmp_path / "blender").exists()
