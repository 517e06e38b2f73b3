"""results/report: learning curves and per-parameter accuracy from a real (tiny) training run,
the gallery, and the page opened in headless Chromium."""

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from test_training_data import DOMAIN, toy_config

from geocode.paths import summary_file
from geocode.steps.report import (
    cloud_image,
    curve_svg,
    run_training_html,
    save_png,
    training_html,
    write_report,
)
from geocode.steps.train import epoch_metrics, train

CHROMIUM = shutil.which("chromium")
# Appended to a copy of the page: after load, the body says how many images decoded.
IMAGE_CHECK = ("<script>addEventListener('load', () => { const im = [...document.images];"
               " document.body.dataset.images = im.filter(i => i.complete && i.naturalWidth > 0).length"
               " + '/' + im.length; });</script>")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A three-epoch joint run on the synthetic dataset: (run folder, summary)."""
    with toy_config(tmp_path_factory.mktemp("report"), epochs=3) as cfg:
        result = train(cfg)
    return Path(result["out_dir"]), json.loads(summary_file(Path(result["out_dir"])).read_text())


def test_summary_and_curves_come_from_the_training_logs(run):
    out, summary = run
    curves = epoch_metrics(out)
    assert list(curves.index) == [0, 1, 2]
    for column in ("train/acc_points", "val/acc_sketch", "train/loss_points", "val/loss_sketch"):
        assert curves[column].notna().all(), column
    assert summary["best_val_acc"] == pytest.approx(curves["val/acc"].max())
    assert summary["best_val_acc_points"] == curves.loc[curves["val/acc"].idxmax(), "val/acc_points"]
    assert list(summary["majority_per_parameter"]) == ["height", "has_handle", "handle_size", "legs"]
    assert summary["majority_val_acc"] == pytest.approx(np.mean(list(summary["majority_per_parameter"].values())))


def test_chart_draws_every_curve_and_the_majority_line(run):
    out, summary = run
    curves = epoch_metrics(out)
    svg = curve_svg(curves, "acc", majority=0.25, height=220)
    assert svg.count("<polyline") == 4 and "<title>majority</title>" in svg
    y_majority = 195 + (10 - 195) * 0.25  # the plot spans y 195 (0) .. 10 (1)
    assert f"y1='{y_majority:.1f}'" in svg
    first = svg.split("<polyline points='")[1].split("'")[0].split()
    assert len(first) == 3  # one vertex per epoch
    assert curve_svg(curves.drop(columns=["train/loss_sketch", "val/loss_sketch"]), "loss").count("<polyline") == 2


def test_parameter_table_marks_what_was_recovered(run):
    out, summary = run
    curves = epoch_metrics(out)
    best = curves.loc[curves["val/acc"].idxmax()]
    summary = dict(summary, majority_per_parameter={"height": 0.0, "has_handle": 1.0, "handle_size": 0.5, "legs": 0.5})
    best_height = best["val_param/points/height"]
    page = training_html(curves, summary)
    row = page.split("<td>height</td>")[1].split("</tr>")[0]
    assert f"{best_height:.2f}" in row
    assert ("class='learnt'" in row) == (best_height >= 0.10)
    assert "class='learnt'" not in page.split("<td>has_handle</td>")[1].split("</tr>")[0]  # nothing beats 1.0
    assert run_training_html(out).count("<svg") == 2
    assert run_training_html(out.parent) == ""  # no summary: no curves, no failure


def gallery_page(tmp_path: Path, run, missing: bool = False) -> Path:
    out, _ = run
    rng = np.random.default_rng(0)
    names = ("sketch", "cloud", "gt", "pc", "sketch_pred", "pc_fit")
    (tmp_path / DOMAIN).mkdir()
    for name in names:
        save_png(cloud_image(rng.normal(size=(200, 3))), tmp_path / DOMAIN / f"a_{name}.png")
    if missing:
        (tmp_path / DOMAIN / "a_pc.png").unlink()
    row = dict(id="a", chamfer_pc=0.01, chamfer_sketch=0.02, chamfer_fit=0.005,
               **{n: f"{DOMAIN}/a_{n}.png" for n in names})
    index = write_report(tmp_path, "report", "test",
                         [{"domain": DOMAIN, "rows": [row], "training": run_training_html(out)}])
    index.write_text(index.read_text() + IMAGE_CHECK)
    return index


def open_in_chromium(index: Path, screenshot: Path) -> str:
    """The page's DOM after load; a screenshot of it beside."""
    flags = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--window-size=1300,1100"]
    url = index.resolve().as_uri()
    subprocess.run([*flags, f"--screenshot={screenshot}", url], check=True, capture_output=True, timeout=120)
    return subprocess.run([*flags, "--dump-dom", url], check=True, capture_output=True, text=True, timeout=120).stdout


@pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium (scripts/setup.sh installs it as root)")
@pytest.mark.parametrize("missing", [False, True])
def test_page_loads_every_image_in_chromium(run, tmp_path, missing):
    index = gallery_page(tmp_path, run, missing)
    shot = tmp_path / "page.png"
    dom = open_in_chromium(index, shot)
    assert ('data-images="5/6"' if missing else 'data-images="6/6"') in dom
    assert "from the point cloud, fitted" in dom and "CD fitted 0.00500" in dom
    assert dom.count("<polyline") == 8  # both charts drew their four curves
    pixels = np.asarray(Image.open(shot).convert("L"))
    assert pixels.shape == (1100, 1300) and pixels.min() < 100  # something dark was drawn
