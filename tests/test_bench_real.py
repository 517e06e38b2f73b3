"""`geocode bench real` and `geocode bench span` on a small folder of program shapes made here
(turned, moved, saved as other formats); the model is an untrained network of the real
architecture, so the numbers are arbitrary and the plumbing is real."""

import json
import math
import statistics

import numpy as np
import pytest
import trimesh

from geocode.cli import main
from geocode.config import compose, settings
from geocode.metrics import chamfer_meshes
from geocode.program import Program

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    from test_reconstruct import untrained_checkpoint

    root = tmp_path_factory.mktemp("real")
    (root / "vase").mkdir()
    mesh = Program.load("vase").evaluate({"body_height": 1.2, "handle_count": 2})
    plain = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    y_up = plain.copy()
    y_up.vertices = np.stack([plain.vertices[:, 0], plain.vertices[:, 2], -plain.vertices[:, 1]], 1) * 30.0
    y_up.export(root / "vase" / "twin.off")       # two files of one stem: their outputs apart
    plain.export(root / "vase" / "twin.stl")
    (root / "up.yaml").write_text('"*.off": y\n"*": z\n')
    runs = root / "runs"
    (runs / "vase" / "joint" / "checkpoints").mkdir(parents=True)
    untrained_checkpoint(runs / "vase" / "joint" / "checkpoints" / "best.ckpt", "vase")
    return root


def test_bench_real_scores_every_file_against_its_baselines_and_writes_their_pages(folder, tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["bench", "real", str(folder), "--budget", "4", "--up-truth", str(folder / "up.yaml"),
                 "-o", str(out), "--json", f"paths.runs={folder / 'runs'}"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["vase"]
    assert result["shapes"] == 2 and result["up_agrees"].endswith("/2")
    files = result["files"]
    for key in ("network", "fit", "defaults"):
        assert result[f"median_{key}"] == pytest.approx(statistics.median(f[key] for f in files), abs=1e-6)
        # the same shape, turned to +y and scaled 30x in one file: the same scores once posed
        assert files[0][key] == pytest.approx(files[1][key], rel=0.05), key
    assert all(f["fit"] <= f["network"] for f in files)          # the network's answer is a candidate
    vase = Program.load("vase")   # defaults: the default shape against the file's, on the unit sphere
    defaults = chamfer_meshes(vase.evaluate({}), vase.evaluate({"body_height": 1.2, "handle_count": 2}))
    assert all(f["defaults"] == pytest.approx(defaults, rel=0.1) for f in files)
    assert math.isnan(result["median_nearest"])                  # the run has no training shapes
    assert {f["up_true"] for f in result["files"]} == {"+y", "+z"}
    page = (out / "vase" / "index.html").read_text()
    assert "twin.off" in page and "twin.stl" in page
    # named as `geocode reconstruct` names them: each keeps its suffix, none over the other
    assert all((out / "vase" / f"{stem}{s}").is_file() for stem in ("twin-off", "twin-stl")
               for s in (".yaml", ".obj", ".in-place.obj", ".blend"))
    assert not (out / "vase" / "twin.obj").exists()
    card = (folder / "runs" / "vase" / "joint" / "README.md").read_text()
    assert "Real shapes (`geocode bench real`, 2 files)" in card
    # without the true up axis the baselines are the reconstruction's own, in the pose it found
    assert main(["bench", "real", str(folder), "--budget", "4", "--json", f"paths.runs={folder / 'runs'}"]) == 0
    found = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["vase"]["files"]
    assert all(f["up_true"] is None and f["defaults"] == pytest.approx(defaults, rel=0.1) for f in found)


def test_bench_span_fits_from_the_defaults_and_writes_a_page(folder, tmp_path, capsys):
    out = tmp_path / "span"
    assert main(["bench", "span", "vase", str(folder / "vase"), "--budget", "12", "-o", str(out),
                 "--up-truth", str(folder / "up.yaml"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["shapes"] == 2 and result["budget"] == 12
    assert all(f["evaluations"] == 12 and f["chamfer"] > 0 for f in result["files"])
    assert "twin.off" in (out / "index.html").read_text()


def test_span_finds_a_shape_standing_half_a_quarter_turn_off():
    """A table whose level turn ended on its diagonals: from the quarter-turns the fit's 30
    degrees of turn cannot reach it; the span judges reconstruct's eight turns (12 forms of
    the table each) before its search."""
    from geocode.bench.span import span_fit
    from geocode.reconstruct.fit import shape_points, turn_about_z

    program = Program.load("table")
    target = turn_about_z(shape_points(program, program.check({}), 4096), math.pi / 4)
    result = span_fit(program, program.recipe(), target, budget=100, tuning=settings(compose([])).fit.cloud, seed=0)
    assert result.after < 5e-4 and abs(math.degrees(result.pose.turn) - 45.0) < 2.0


def test_short_fits_rank_the_starts_by_where_they_end_within_their_budget(monkeypatch):
    """Each round fits the best starts briefly and ranks them by where they end; the next round
    starts from those ends; the evaluations stay within the budget."""
    import geocode.bench.span as span
    from geocode.reconstruct.fit import shape_points

    program = Program.load("table")
    recipe = program.recipe()
    target = shape_points(program, program.check({"pedestal": 1.0}), 2048)
    options = span.all_options(recipe)
    starts = [span.start_at(program.check(v), options, 0.0)
              for v in ({}, {"pedestal": 1.0, "top_width": 0.5}, {"leg_style": 1.0})]
    monkeypatch.setattr(span, "HALVING", ((2, 8), (1, 6)))
    tuning = settings(compose([])).fit.cloud
    ranked, used = span.judged_by_short_fits(program, recipe, starts, target, budget=30, tuning=tuning, seed=0)
    assert used <= 30 and len(ranked) == 1 and ranked[0].values["pedestal"] == 1.0
    assert ranked[0].values["top_width"] != 0.5   # the end of a fit, not the start itself
    ranked, used = span.judged_by_short_fits(program, recipe, starts, target, budget=2, tuning=tuning, seed=0)
    assert used == 2 and len(ranked) == 2


def test_switch_starts_put_each_other_value_of_one_discrete_parameter_first():
    from geocode.bench.span import switch_starts

    defaults = {"legs": 0.0, "sled": 0.0, "height": 0.5}
    options = {"legs": [0.0, 1.0, 2.0], "sled": [0.0, 1.0]}
    starts = switch_starts(defaults, options, turn=1.5)
    assert [(s.values["legs"], s.values["sled"]) for s in starts] == [(1.0, 0.0), (2.0, 0.0), (0.0, 1.0)]
    assert all(s.turn == 1.5 and s.values["height"] == 0.5 for s in starts)
    assert starts[1].options == {"legs": [2.0, 0.0, 1.0], "sled": [0.0, 1.0]}
