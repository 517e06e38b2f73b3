"""The table builder on a small, hand-made metrics frame whose means are known."""

import numpy as np
import pandas as pd

from geocode.tables import build_tables, write_tables

CAMERAS = [{"name": "az35", "train": True}, {"name": "az55", "train": True}, {"name": "az15", "train": False}]


def row(modality, chamfer, *, variant="joint", source="test", camera="", noise=0.0, sparse=0, stable=np.nan, i=0):
    return dict(domain="vase", variant=variant, id=f"test-{i:06d}", modality=modality, source=source,
                camera=camera, noise=noise, sparse=sparse, chamfer=chamfer, stable=stable)


def metrics() -> pd.DataFrame:
    rows = [
        row("pc", 0.001, stable=1.0, i=0), row("pc", 0.003, stable=0.0, i=1),
        row("sketch", 0.002, camera="az35", stable=1.0), row("sketch", 0.004, camera="az55", stable=1.0),
        row("sketch", 0.010, camera="az15"),
        row("gt", np.nan, stable=1.0, i=0), row("gt", np.nan, stable=1.0, i=1),
        row("pc", 0.005, noise=0.02), row("pc", 0.007, sparse=512),
        row("pc", 0.0015, source="s10"), row("sketch", 0.0035, source="s10", camera="az35"),
        row("baseline", 0.02),
    ]
    return pd.DataFrame(rows)


def test_tables_hold_the_means_beside_the_paper():
    tables = build_tables(metrics(), CAMERAS)
    t = tables["pc_vs_sketch"]
    assert t.loc["vase", "pc"] == 0.002                       # mean of 0.001, 0.003
    assert abs(t.loc["vase", "sketch"] - 0.003) < 1e-12       # trained cameras only
    assert t.loc["vase", "pc (paper)"] == 0.00264
    assert t.loc["vase mean-shape baseline", "pc"] == 0.02
    assert tables["camera_angles"].loc["vase", "novel"] == 0.010
    assert tables["noise"].loc["vase", "0.02"] == 0.005
    assert tables["noise"].loc["vase", "0"] == 0.002
    assert tables["sparse"].loc["vase", "512"] == 0.007
    assert tables["simplified"].loc["vase pc", "1/10"] == 0.0015
    s = tables["stability"]
    assert s.loc["vase", "GT"] == 100.0 and s.loc["vase", "PC pred"] == 50.0
    assert "ablations" not in tables                           # one variant: nothing to compare


def test_write_tables_writes_every_format_and_an_index(tmp_path):
    names = write_tables(metrics(), CAMERAS, tmp_path, "profile smoke, config abc123")
    assert "pc_vs_sketch" in names
    for name in names:
        for ext in ("csv", "md", "tex"):
            text = (tmp_path / f"{name}.{ext}").read_text()
            assert "profile smoke, config abc123" in text
    csv = pd.read_csv(tmp_path / "pc_vs_sketch.csv", comment="#", index_col=0)
    assert csv.loc["vase", "pc"] == 0.002
    assert "[" in (tmp_path / "README.md").read_text()
    assert not list(tmp_path.glob(".*tmp"))                    # no temporary files left


def test_ablations_compare_the_variants_that_were_trained():
    rows = [row("pc", 0.001), row("sketch", 0.002, camera="az35"),
            row("pc", 0.004, variant="regression"), row("sketch", 0.006, camera="az55", variant="regression"),
            row("sketch", 0.5, camera="az15", variant="regression")]          # novel camera: not counted
    table = build_tables(pd.DataFrame(rows), CAMERAS)["ablations"]
    assert table.loc["vase joint (cls)", "pc"] == 0.001
    assert table.loc["vase regression", "sketch"] == 0.006
    assert np.isnan(table.loc["vase regression", "pc (paper)"])             # the paper's rows are the chair's


def test_stability_of_a_domain_that_hangs_is_not_applicable(tmp_path):
    """A hanging program's metrics carry no drop test (NaN): its row says n/a, not 0%."""
    lamp = metrics().assign(domain="ceiling_lamp", stable=np.nan)
    frame = pd.concat([metrics(), lamp])
    s = build_tables(frame, CAMERAS)["stability"]
    assert s.loc["vase", "GT"] == 100.0
    assert list(s.loc["ceiling_lamp", ["GT", "PC pred", "sketch pred"]]) == ["n/a"] * 3
    write_tables(frame, CAMERAS, tmp_path, "smoke")
    assert "| ceiling_lamp | n/a |" in (tmp_path / "stability.md").read_text()
