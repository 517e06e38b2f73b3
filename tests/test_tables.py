"""The table builder on a small, hand-made metrics frame whose means are known."""

import numpy as np
import pandas as pd
import pytest

from geocode.steps.tables import (
    STAT_SUFFIXES,
    bootstrap_ci,
    build_tables,
    trends,
    wilcoxon_p,
    write_tables,
)

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
        row("baseline", 0.02), row("nearest", 0.004, i=0), row("nearest", 0.006, i=1),
    ]
    return pd.DataFrame(rows)


def test_tables_hold_the_means_beside_the_paper():
    tables = build_tables(metrics(), CAMERAS)
    t = tables["pc_vs_sketch"]
    assert t.loc["vase", "pc"] == 0.002                       # mean of 0.001, 0.003
    assert abs(t.loc["vase", "sketch"] - 0.003) < 1e-12       # trained cameras only
    assert t.loc["vase", "pc (paper)"] == 0.00264
    assert t.loc["vase mean-shape baseline", "pc"] == 0.02
    assert t.loc["vase nearest training shape", "pc"] == 0.005   # retrieval, beside ours
    assert "pc p" in t and np.isfinite(t.loc["vase nearest training shape", "pc p"])
    assert tables["camera_angles"].loc["vase", "novel"] == 0.010
    assert tables["noise"].loc["vase", "0.02"] == 0.005
    assert tables["noise"].loc["vase", "0"] == 0.002
    assert tables["sparse"].loc["vase", "512"] == 0.007
    assert tables["simplified"].loc["vase pc", "1/10"] == 0.0015
    s = tables["stability"]
    assert s.loc["vase", "GT"] == 100.0 and s.loc["vase", "PC pred"] == 50.0


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


def test_columns_follow_the_paper_and_every_mean_has_its_interval_and_count():
    extra = [row("sketch", 0.020, camera="az15", i=1), row("sketch", 0.006, camera="az35", i=1),
             row("pc", 0.004, source="s100"), row("pc", 0.006, sparse=2048), row("pc", 0.009, noise=0.05)]
    tables = build_tables(pd.concat([metrics(), pd.DataFrame(extra)]), CAMERAS)
    assert list(tables["camera_angles"].columns[:5]) == ["angle 1", "angle 1 CI low", "angle 1 CI high", "angle 1 n",
                                                         "angle 1 (paper)"]
    means = lambda t: [c for c in t.columns if not c.endswith(STAT_SUFFIXES)]  # noqa: E731
    assert means(tables["camera_angles"]) == ["angle 1", "angle 2", "novel"]
    assert means(tables["simplified"]) == ["full", "1/10", "1/100"]
    assert means(tables["sparse"]) == ["2048", "512"]
    assert means(tables["noise"]) == ["0", "0.02", "0.05"]
    angles = tables["camera_angles"].loc["vase"]
    assert angles["novel"] == pytest.approx(0.015) and angles["novel n"] == 2
    assert angles["novel CI low"] == pytest.approx(0.010) and angles["novel CI high"] == pytest.approx(0.020)
    # two cameras of one shape are one sample: its mean
    assert tables["pc_vs_sketch"].loc["vase", "sketch n"] == 2


def test_bootstrap_interval_of_a_known_sample():
    assert bootstrap_ci([0.3] * 50) == (pytest.approx(0.3), pytest.approx(0.3))
    coin = np.array([0.0, 1.0] * 200)                        # mean 0.5, standard error 0.025
    low, high = bootstrap_ci(coin)
    assert low == pytest.approx(0.5 - 1.96 * 0.025, abs=0.006) and high == pytest.approx(0.5 + 1.96 * 0.025, abs=0.006)
    assert bootstrap_ci(coin) == (low, high)                 # seeded
    skewed = np.r_[np.zeros(90), np.full(10, 10.0)]           # the percentile interval follows the skew
    low, high = bootstrap_ci(skewed)
    assert 0.0 < low < 1.0 < high and high - 1.0 > 1.0 - low


def test_wilcoxon_p_of_known_pairs():
    ids = [f"test-{i:06d}" for i in range(10)]
    a = pd.Series(np.arange(1.0, 11.0), index=ids)
    # every one of 10 differences positive: the exact two-sided p is 2 / 2**10
    assert wilcoxon_p(a * 1.5, a) == pytest.approx(2 / 2**10)
    # rank sums of the positive and negative differences equal (1 + 4 = 2 + 3): p = 1
    d = pd.Series([1.0, -2.0, -3.0, 4.0], index=ids[:4])
    assert wilcoxon_p(a[:4] + d, a[:4]) == pytest.approx(1.0)
    assert wilcoxon_p(a, a) == 1.0
    # only the 3 shapes both have are paired
    assert wilcoxon_p(a[:6] * 2, a[3:]) == pytest.approx(2 / 2**3)
    assert np.isnan(wilcoxon_p(a[:3], a[5:]))


def comparison_metrics(n=12):
    """Joint, Huang et al. and the ablations on n shapes; the joint model is better on every
    shape, by differences that grow with the shape's index (no ties: scipy's exact test)."""
    rows = []
    for i in range(n):
        for variant, extra in (("joint", 0.0), ("huang", 0.002), ("regression", 0.003), ("separate", 0.0)):
            if variant != "huang":
                rows.append(row("pc", 0.001 + extra * (1 + i / 50) + i * 1e-4, variant=variant, i=i))
            for cam, base in (("az35", 0.002), ("az55", 0.004), ("az15", 0.010)):
                rows.append(row("sketch", base + extra * (1 + i / 50) + i * 1e-4, camera=cam, variant=variant, i=i))
    return pd.DataFrame(rows)


def test_vs_huang_compares_sketches_of_trained_and_novel_cameras():
    t = build_tables(comparison_metrics(), CAMERAS)["vs_huang"]
    assert list(t.index) == ["vase Huang et al. 2017", "vase ours"]
    assert [c for c in t.columns if not c.endswith(STAT_SUFFIXES)] == ["trained cameras", "novel camera"]
    assert t.loc["vase ours", "trained cameras"] == pytest.approx(0.003 + 5.5e-4)
    assert t.loc["vase Huang et al. 2017", "novel camera"] == pytest.approx(0.010 + 0.002 * 1.11 + 5.5e-4)
    assert t.loc["vase ours", "trained cameras n"] == 12
    assert t.loc["vase ours", "trained cameras p"] == pytest.approx(2 / 2**12)  # better on all 12
    assert np.isnan(t.loc["vase Huang et al. 2017", "trained cameras p"])        # the reference row
    assert t.loc["vase ours", "trained cameras (paper)"] == 4.875e-3


def test_ablations_compare_each_variant_with_the_joint_model():
    tables = build_tables(comparison_metrics(), CAMERAS)
    reg = tables["cls_vs_reg"]
    assert list(reg.index) == ["vase classification (ours)", "vase regression"]
    assert reg.loc["vase regression", "pc"] == pytest.approx(0.001 + 0.003 * 1.11 + 5.5e-4)
    assert reg.loc["vase regression", "sketch"] == pytest.approx(0.003 + 0.003 * 1.11 + 5.5e-4)  # trained cameras
    assert reg.loc["vase regression", "pc p"] == pytest.approx(2 / 2**12)
    assert np.isnan(reg.loc["vase regression", "pc (paper)"])                   # the paper's rows are the chair's
    sep = tables["joint_vs_separate"]
    assert sep.loc["vase separate", "sketch p"] == 1.0                          # the same distances
    assert "pc_vs_sketch" in tables and tables["pc_vs_sketch"].loc["vase", "pc"] == pytest.approx(0.001 + 5.5e-4)


def test_one_variant_makes_no_comparison_tables():
    tables = build_tables(metrics(), CAMERAS)
    assert not {"vs_huang", "cls_vs_reg", "joint_vs_separate"} & set(tables)


def test_markdown_shows_intervals_counts_and_p_values(tmp_path):
    write_tables(comparison_metrics(), CAMERAS, tmp_path, "profile smoke")
    text = (tmp_path / "vs_huang.md").read_text()
    assert "| | trained cameras | trained cameras n | trained cameras p | trained cameras (paper) |" in text
    assert "| vase ours | 0.00355 [" in text and "| 12 | 0.00049 |" in text
    assert "no pretrained weights" in text
    assert "0.00049" in (tmp_path / "vs_huang.tex").read_text()


def test_stability_of_a_domain_that_hangs_is_not_applicable(tmp_path):
    """A hanging program's metrics carry no drop test (NaN): its row says n/a, not 0%."""
    lamp = metrics().assign(domain="ceiling_lamp", stable=np.nan)
    frame = pd.concat([metrics(), lamp])
    s = build_tables(frame, CAMERAS)["stability"]
    assert s.loc["vase", "GT"] == 100.0
    assert list(s.loc["ceiling_lamp", ["GT", "PC pred", "sketch pred"]]) == ["n/a"] * 3
    write_tables(frame, CAMERAS, tmp_path, "smoke")
    assert "| ceiling_lamp | n/a |" in (tmp_path / "stability.md").read_text()


def test_fitted_clouds_are_a_column_and_rows_apart_from_the_paper_method():
    fitted = [row("pc+fit", 0.0005, i=0), row("pc+fit", 0.0015, i=1), row("pc+fit", 0.004, noise=0.02),
              row("pc+fit", 0.006, sparse=512), row("pc+fit", 0.001, source="s10")]
    tables = build_tables(pd.concat([metrics(), pd.DataFrame(fitted)]), CAMERAS)
    t = tables["pc_vs_sketch"]
    assert t.loc["vase", "pc"] == 0.002 and t.loc["vase", "pc + fit"] == pytest.approx(0.001)
    assert t.loc["vase", "pc + fit n"] == 2 and np.isnan(t.loc["vase", "pc + fit (paper)"])
    assert tables["noise"].loc["vase", "0.02"] == 0.005 and tables["noise"].loc["vase + fit", "0.02"] == 0.004
    assert tables["sparse"].loc["vase + fit", "512"] == 0.006
    assert tables["simplified"].loc["vase pc + fit", "1/10"] == 0.001
    assert "pc + fit" not in build_tables(metrics(), CAMERAS)["pc_vs_sketch"]   # only where the run fitted


def test_trends_get_a_verdict_only_where_the_paired_test_allows_one(tmp_path):
    """12 shapes: pc below sketch on every shape (holds, p = 2/2^12), noise above 0 on none
    (reversed), the novel camera level with the trained ones on 6 of 12 (no verdict)."""
    rows = []
    for i in range(12):
        rows += [row("pc", 0.010 + i * 1e-4, i=i), row("pc", 0.005 + i * 1e-4, noise=0.05, i=i),
                 row("sketch", 0.020 + i * 1e-4, camera="az35", i=i),
                 row("sketch", 0.020 + i * 1e-4, camera="az55", i=i),
                 row("sketch", 0.020 + i * 1e-4 + (1e-3 if i % 2 else -1e-3), camera="az15", i=i)]
    t = trends(pd.DataFrame(rows), ["az35", "az55"], ["az15"]).set_index("trend")
    assert t.loc["point clouds beat sketches", "verdict"] == "holds"
    assert t.loc["point clouds beat sketches", "p"] == pytest.approx(2 / 2**12)
    assert t.loc["noise hurts", "verdict"] == "reversed" and t.loc["noise hurts", "n"] == 12
    assert t.loc["the trained cameras beat the novel one", "verdict"] == "no verdict"
    assert "sparsity hurts" not in t.index                 # no sparse clouds in these metrics
    write_tables(pd.DataFrame(rows), CAMERAS, tmp_path, "h")
    assert "| vase | noise hurts |" in (tmp_path / "trends.md").read_text()
    assert "trends.md" in (tmp_path / "README.md").read_text()


def test_tables_header_counts_shapes_per_domain(tmp_path):
    """Test ids repeat across domains (test-000000 in each): the header counts (domain, id)."""
    from geocode.cli import main

    paths = []
    for domain in ("vase", "chair"):
        paths.append(tmp_path / f"{domain}.parquet")
        metrics().assign(domain=domain).to_parquet(paths[-1])
    assert main(["tables", "--metrics", *map(str, paths), "-o", str(tmp_path / "out"), "profile=smoke"]) == 0
    assert "4 test shapes in 2 domains" in (tmp_path / "out" / "pc_vs_sketch.md").read_text()
