"""The command line: one clear line and exit code 2 for a user's mistake, never a traceback."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from geocode.cli import main, parse_values


def geocode(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "geocode.cli", *args], capture_output=True, text=True)


def test_importing_the_package_and_cli_pulls_in_neither_blender_nor_torch():
    code = "import sys, geocode, geocode.cli, geocode.config; print(sorted(m for m in ('bpy', 'torch') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_parse_values_reads_numbers_and_booleans():
    assert parse_values(["a=1.5", "b=true", "c=false", "d=-2"]) == {"a": 1.5, "b": 1.0, "c": 0.0, "d": -2.0}
    with pytest.raises(ValueError, match="name=number"):
        parse_values(["a=tall"])
    with pytest.raises(ValueError, match="name=number"):
        parse_values(["a"])


def test_config_prints_the_composed_profile(capsys):
    assert main(["config", "profile=smoke", "train.max_epochs=3"]) == 0
    out = capsys.readouterr().out
    assert "profile_name: smoke" in out and "max_epochs: 3" in out


@pytest.mark.parametrize("override, words", [
    ("data.shards=0", "data.shards=0: out of range; give a whole number >= 1"),
    ("profile=huge", "profile"),
    ("data.nonsense=1", "nonsense"),
    ("domain=tabel", "domain=tabel: no such domain; use one of "),
])
def test_bad_overrides_give_one_line(override, words):
    result = geocode("config", override)
    if override.startswith("domain="):
        from geocode.config import registry

        words += ", ".join(registry())
    assert result.returncode == 2
    assert words in result.stderr
    assert "Traceback" not in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_domain_group_comes_from_the_registry(tmp_path, monkeypatch):
    """A program and its recipe make a domain; nothing in conf/ is needed."""
    for name in ("vase", "stool"):
        (tmp_path / f"{name}.py").write_text("")
        (tmp_path / f"{name}.yaml").write_text("parameters: {}\n")
    monkeypatch.setenv("GEOCODE_PROGRAMS", str(tmp_path))
    result = geocode("config", "domain=stool")
    assert result.returncode == 0, result.stderr
    assert "domain:\n  name: stool\n" in result.stdout


def test_shape_rejects_unknown_names_and_out_of_range_values(tmp_path):
    out = tmp_path / "v.obj"
    result = geocode("shape", "vase", "no_such_parameter=1", "-o", str(out))
    assert result.returncode == 2 and "no_such_parameter" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    show = json.loads(geocode("program", "show", "vase", "--json").stdout)
    first = next(p for p in show["parameters"] if p["kind"] == "float")
    result = geocode("shape", "vase", f"{first['name']}={first['max'] + 10}", "-o", str(out))
    assert result.returncode == 2 and first["name"] in result.stderr and not out.exists()
    result = geocode("shape", "vase", f"{first['name']}={first['max']}", "-o", str(out))
    assert result.returncode == 0 and out.stat().st_size > 0


def test_program_show_json_lists_every_parameter():
    show = json.loads(geocode("program", "show", "vase", "--json").stdout)
    assert show["domain"] == "vase" and len(show["parameters"]) >= 39
    keys = {"name", "kind", "min", "max", "default", "classes", "visible_if"}
    assert all(keys <= set(p) for p in show["parameters"])
    assert sum(p["visible_if"] is not None for p in show["parameters"]) >= 5


def test_bench_epoch_refuses_an_unknown_device_in_one_line():
    result = geocode("bench", "epoch", "--device", "gpu")
    assert result.returncode == 2 and "--device gpu" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("args", [
    ["gallery", "chair", "-o", "{tmp}/g.png", "--n", "100000000"],
    ["shape", "chair", "-o", "{tmp}/c.obj", "--png", "/proc/x.png"],
    ["reconstruct", "vase", "{tmp}/x.obj", "-o", "{tmp}/out", "--refine", "1000000"],
])
def test_an_out_of_bound_size_or_unwritable_output_is_refused_before_blender_starts(args, tmp_path, monkeypatch, capsys):
    def started():
        raise AssertionError("Blender started for a refused command")
    monkeypatch.setattr("geocode.cli.import_blender", started)
    assert main([a.replace("{tmp}", str(tmp_path)) for a in args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("geocode: ") and args[-2] in err
    assert not list(tmp_path.iterdir())


@pytest.mark.blender
def test_a_shape_whose_picture_fails_leaves_no_obj(tmp_path, monkeypatch, capsys):
    from geocode.errors import UserError

    def broken_render(mesh, png):
        raise UserError(png, "cannot be rendered", "a test")
    monkeypatch.setattr("geocode.blender.gallery.render_mesh_png", broken_render)
    assert main(["shape", "vase", "-o", str(tmp_path / "c.obj"), "--png", str(tmp_path / "c.png")]) == 2
    assert "cannot be rendered" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
