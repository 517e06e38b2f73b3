"""`geocode bench curve`: nested training splits, the power law and the crossing on known
numbers, the plot's points where they belong, the refusals, and one small real curve."""

import itertools
import json
import re

import numpy as np
import pandas as pd
import pytest

from geocode.bench import curve
from geocode.bench.plot import BOTTOM, HEIGHT, TOP, Series, line_plot, nice_ticks, x_axis, y_axis
from geocode.blender.export import load_program
from geocode.cli import main
from geocode.config import compose, split_variations
from geocode.steps.dataset import sample_dataset, split_sizes, spread_subset


@pytest.fixture(scope="module")
def vase_recipe():
    return load_program("vase").recipe()


def test_nested_subsets_are_nested_and_factor_one_is_the_default_sampling(vase_recipe):
    base = {"test": 1, "val": 1, "train": 1}
    big = sample_dataset(vase_recipe, {**base, "train": 4}, seed=0, domain="vase")["train"]
    default = sample_dataset(vase_recipe, base, seed=0, domain="vase")["train"]
    subsets = [curve.nested_subset(big, f) for f in (1, 2, 4)]
    assert [len(s) for s in subsets] == [len(default), 2 * len(default), 4 * len(default)]
    for small, large in itertools.pairwise(subsets):
        assert set(small["id"]) < set(large["id"])
    assert (subsets[0].groupby(["forced", "forced_class"]).size() == 1).all()
    assert curve.redrawn(subsets[0], default) == 0
    values = [c for c in default.columns if c not in ("id", "shard", "forced", "forced_class")]
    pd.testing.assert_frame_equal(subsets[0][values], default[values])
    other = default.copy()
    other.loc[3, values[0]] += 1.0                  # a shape the default sampling does not hold
    assert curve.redrawn(subsets[0], other) == 1


def test_split_sizes_count_what_the_sample_step_writes(vase_recipe):
    for profile in ("smoke", "mini", "paper"):
        cfg = compose(["domain=vase", f"profile={profile}"])
        splits = sample_dataset(vase_recipe, split_variations(cfg, "vase"), seed=0, domain="vase")
        assert split_sizes(cfg, vase_recipe, "vase") == {
            s: len(spread_subset(f, cfg.data.max_shapes[s])) for s, f in splits.items()}, profile


def test_power_law_recovers_known_numbers():
    n = [274, 548, 1096, 2192]
    law = curve.power_law(n, [0.5 * v ** -0.4 for v in n])
    assert law["exponent"] == pytest.approx(-0.4, abs=1e-4) and law["scale"] == pytest.approx(0.5, rel=1e-4)


def test_crossing_on_known_numbers():
    # log gap +ln 2 at 100 shapes, -ln 2 at 400: halfway on log axes, at 200
    crossed = curve.crossing([100, 400], [4.0, 1.0], [2.0, 2.0])
    assert crossed["shapes"] == 200 and crossed["below"] == [400]
    assert curve.crossing([100, 200, 400], [3.0, 2.0, 1.0], [2.0, 2.0, 2.0])["shapes"] == 200   # equal at a point
    apart = curve.crossing([100, 200, 400], [1.0, 0.9, 0.8], [2.0, 1.9, 1.8])
    assert apart["shapes"] is None and apart["below"] == [100, 200, 400] and "nearer than" in apart["text"]
    assert "farther than" in curve.crossing([100, 200], [3.0, 2.5], [2.0, 1.5])["text"]


def test_curve_points_put_factor_one_at_the_domain_epochs_on_both_axes_once():
    assert curve.curve_points([1, 2, 4], [16, 48], domain_epochs=48) == [
        (1, 48, ["shapes", "epochs"]), (2, 48, ["shapes"]), (4, 48, ["shapes"]), (1, 16, ["epochs"])]
    # factor 1 at the domain's epochs is a point of the epochs axis too
    assert curve.curve_points([1, 4], [20], domain_epochs=5) == [
        (1, 5, ["shapes", "epochs"]), (4, 5, ["shapes"]), (1, 20, ["epochs"])]
    assert curve.curve_points([2], [20], domain_epochs=5) == [(2, 5, ["shapes"]), (1, 20, ["epochs"])]


def circles(svg: str) -> list[tuple[float, float]]:
    return [(float(x), float(y)) for x, y in re.findall(r'<circle cx="([\d.]+)" cy="([\d.]+)"', svg)]


def test_plot_puts_each_point_where_its_values_are():
    network = Series("network", [100, 200, 400], [3.0, 2.0, 1.0], [2.5, 1.5, 0.5], [3.5, 2.5, 1.5])
    nearest = Series("nearest", [100, 200, 400], [2.0, 1.8, 1.6], [1.9, 1.7, 1.5], [2.1, 1.9, 1.7])
    fit = Series("fit", list(np.geomspace(100, 1600, 9)), [3.0 * (v / 100) ** -0.5 for v in np.geomspace(100, 1600, 9)])
    svg = line_plot([network, nearest, fit], "training shapes", "distance", "title")
    assert svg.startswith("<svg") and svg.rstrip().endswith("</svg>")
    x, y = x_axis([network, nearest, fit], log=True), y_axis([network, nearest, fit])
    found = circles(svg)
    assert len(found) == 6                          # measured points only: the fit is a dashed line
    for (cx, cy), (vx, vy) in zip(found, [*zip(network.x, network.y, strict=True),
                                          *zip(nearest.x, nearest.y, strict=True)], strict=True):
        assert cx == pytest.approx(x(vx), abs=0.1) and cy == pytest.approx(y(vy), abs=0.1)
    # log x: 200 halfway between 100 and 400; a higher distance higher up the page
    assert found[1][0] == pytest.approx((found[0][0] + found[2][0]) / 2, abs=0.2)
    assert found[0][1] < found[2][1] < HEIGHT
    assert y.lo <= 0.5 and y.hi >= 3.5 and x.hi == 1600
    assert 'stroke-dasharray' in svg and ">1600</text>" in svg and ">training shapes</text>" in svg


def test_ticks_are_round_and_cover_the_values_within_the_plot():
    assert nice_ticks(0.00067, 0.003) == [0.0005, 0.001, 0.0015, 0.002, 0.0025, 0.003]
    assert nice_ticks(0.0, 0.06) == [0.0, 0.02, 0.04, 0.06]
    assert nice_ticks(2.0, 2.0)[0] < 2.0 < nice_ticks(2.0, 2.0)[-1]
    low = Series("a", [274, 1096], [0.0012, 0.0021], [0.00067, 0.0018], [0.0015, 0.0030006])
    svg = line_plot([low], "x", "y")
    for label_y in re.findall(r'<text x="[\d.]+" y="([\d.]+)" text-anchor="end"', svg):   # the y tick labels
        assert TOP <= float(label_y) - 4 <= HEIGHT - BOTTOM


@pytest.mark.parametrize("args, says", [
    (["--factors", "2", "1"], "not increasing"),
    (["--factors", "1", "1"], "not increasing"),
    (["--factors", "2"], "one training-set size"),
    (["--epochs", "16", "8"], "not increasing"),
    (["--factors", "0", "1"], ">= 1"),
    (["--epochs", "0"], ">= 1"),
])
def test_bad_axes_are_one_line(tmp_path, capsys, args, says):
    assert main(["bench", "curve", "vase", *args, "-o", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip()
    assert says in err and len(err.splitlines()) == 1 and not (tmp_path / "c").exists()


def test_a_folder_of_other_files_is_refused_untouched(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine")
    assert main(["bench", "curve", "vase", "-o", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "notes.txt" in err and len(err.splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


SMALL = ["profile=smoke", "data.variations.train=1", "train.limit_train_batches=2"]


def test_a_small_curve_end_to_end(tmp_path, capsys):
    out = tmp_path / "curve"
    args = ["bench", "curve", "vase", "--factors", "1", "2", "--epochs", "1", "-n", "3", "-o", str(out), "--json",
            *SMALL]
    assert main(args) == 0
    result = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in out.iterdir()) == sorted([*curve.RESULTS, *curve.WORK])
    assert json.loads((out / "curve.json").read_text()) == result

    classes = sum(p.n_values for p in load_program("vase").recipe().parameters)
    points = result["points"]
    assert [(p["factor"], p["epochs"], p["axes"], p["training_shapes"]) for p in points] == [
        (1, 1, ["shapes", "epochs"], classes), (2, 1, ["shapes"], 2 * classes)]
    for p in points:
        for name in ("network", "nearest"):
            low, high = p[f"{name}_ci"]
            assert 0 < low <= p[name] <= high
        assert p["ratio"] == pytest.approx(p["network"] / p["nearest"], rel=1e-2) and 0 < p["p"] <= 1
    assert result["val_shapes"] == 3 and result["x1_redrawn"] == 0 and result["trainings"] == "2 of 2"
    assert result["extrapolation"]["training_shapes"] == 30 * classes     # the paper's 30 variations
    law = result["power_law"]["network"]
    assert result["extrapolation"]["network"] == pytest.approx(law["scale"] * (30 * classes) ** law["exponent"],
                                                               rel=1e-3)

    x1, x2 = (out / "data" / f"x{f}" / "vase" for f in (1, 2))
    ids = [set(pd.read_parquet(d / "train" / "recipes.parquet")["id"]) for d in (x1, x2)]
    assert ids[0] < ids[1] and len(ids[1]) == 2 * classes
    assert {p.stem for p in (x1 / "train" / "points").iterdir()} == ids[0]
    assert (x1 / "val").resolve() == (out / "data" / "all" / "vase" / "val").resolve()
    table = pd.read_csv(out / "curve.csv")
    assert list(table["training_shapes"]) == [classes, 2 * classes]
    assert "| training shapes |" in (out / "curve.md").read_text()
    assert len(circles((out / "curve.svg").read_text())) == 4
    assert len(circles((out / "curve-epochs.svg").read_text())) == 2

    # a rerun reuses the data, the trainings and the scores; other validation shapes are scored
    # by the same models; another setting trains afresh
    def stamps(name):
        return {p: p.stat().st_mtime_ns for p in (out / "runs").glob(f"*/{name}")}

    records, checkpoints = stamps(curve.RECORD), stamps("checkpoints/best.ckpt")
    assert main(args) == 0
    assert json.loads(capsys.readouterr().out) == result and stamps(curve.RECORD) == records

    assert main([*args, "-n", "2"]) == 0
    fewer = json.loads(capsys.readouterr().out)
    assert fewer["val_shapes"] == 2 and stamps("checkpoints/best.ckpt") == checkpoints
    assert [p["train_seconds"] for p in fewer["points"]] == [p["train_seconds"] for p in points]

    assert main([*args, "train.lr=0.001"]) == 0
    capsys.readouterr()
    retrained = stamps("checkpoints/best.ckpt")
    assert len(retrained) == 2 and all(checkpoints[p] != t for p, t in retrained.items())
