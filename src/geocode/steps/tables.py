"""The tables step (workflow/rules/tables.smk): per-sample metrics -> the paper's tables
(docs/paper-numbers.md#tables) as CSV, Markdown and LaTeX, with the paper's values beside ours
(no bpy, no torch).

The metrics frame has one row per (domain, variant, condition, id) with the columns
`modality` (pc | sketch | gt | baseline), `source` (test | s10 | s100: the test meshes or
their simplifications), `camera`, `noise`, `sparse`, `chamfer` and `stable` (bool, or NaN
where the drop test was not run).

Every cell is a mean over test shapes (a shape's sketches from several cameras are averaged
first) with its 95% bootstrap confidence interval (percentile, BOOTSTRAP resamples of the
shapes, seeded) and the number of shapes. The comparison tables (vs Huang et al., the
decoder ablations) add a paired Wilcoxon signed-rank test on per-shape Chamfer distances.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from geocode.conditions import FITTED, SKETCH_FITTED
from geocode.meshio import write_text

DOMAIN_ORDER = ["chair", "vase", "table", "ceiling_lamp", "cabinet"]
NOT_APPLICABLE = "n/a"  # the stability of a shape that hangs (a ceiling lamp)

# The paper's values (docs/paper-numbers.md#tables), keyed by table, then by (row, column).
PAPER: dict[str, dict[tuple[str, str], float]] = {
    "pc_vs_sketch": {
        ("chair", "pc"): 0.00040, ("chair", "sketch"): 0.00106,
        ("vase", "pc"): 0.00264, ("vase", "sketch"): 0.00488,
        ("table", "pc"): 0.00044, ("table", "sketch"): 0.00250,
        ("ceiling_lamp", "pc"): 0.00411, ("ceiling_lamp", "sketch"): 0.01403,
    },
    "camera_angles": {
        ("chair", "angle 1"): 0.00108, ("chair", "angle 2"): 0.00103, ("chair", "novel"): 0.00807,
        ("vase", "angle 1"): 0.00484, ("vase", "angle 2"): 0.00491, ("vase", "novel"): 0.00979,
        ("table", "angle 1"): 0.00246, ("table", "angle 2"): 0.00254, ("table", "novel"): 0.00853,
    },
    "simplified": {
        ("chair pc", "full"): 0.00040, ("chair pc", "1/10"): 0.00041, ("chair pc", "1/100"): 0.00133,
        ("chair sketch", "full"): 0.00106, ("chair sketch", "1/10"): 0.00117, ("chair sketch", "1/100"): 0.00227,
        ("vase pc", "full"): 0.00264, ("vase pc", "1/10"): 0.00280, ("vase pc", "1/100"): 0.00613,
        ("vase sketch", "full"): 0.00488, ("vase sketch", "1/10"): 0.00517, ("vase sketch", "1/100"): 0.01160,
        ("table pc", "full"): 0.00043, ("table pc", "1/10"): 0.00044, ("table pc", "1/100"): 0.00149,
        ("table sketch", "full"): 0.00222, ("table sketch", "1/10"): 0.00308, ("table sketch", "1/100"): 0.00520,
    },
    "sparse": {
        ("chair", "2048"): 0.00062, ("chair", "1024"): 0.00311, ("chair", "512"): 0.01972,
        ("vase", "2048"): 0.00361, ("vase", "1024"): 0.00770, ("vase", "512"): 0.01914,
        ("table", "2048"): 0.00053, ("table", "1024"): 0.00135, ("table", "512"): 0.00536,
    },
    "noise": {
        ("chair", "0"): 0.00040, ("chair", "0.01"): 0.0007, ("chair", "0.02"): 0.00125, ("chair", "0.05"): 0.00534,
        ("vase", "0"): 0.00264, ("vase", "0.01"): 0.00346, ("vase", "0.02"): 0.00492, ("vase", "0.05"): 0.01116,
        ("table", "0"): 0.00044, ("table", "0.01"): 0.00076, ("table", "0.02"): 0.00155, ("table", "0.05"): 0.00577,
    },
    "stability": {
        ("chair", "GT"): 91.01, ("chair", "PC pred"): 90.28, ("chair", "sketch pred"): 91.54,
        ("vase", "GT"): 100.0, ("vase", "PC pred"): 99.79, ("vase", "sketch pred"): 99.57,
        ("table", "GT"): 99.84, ("table", "PC pred"): 96.33, ("table", "sketch pred"): 97.24,
    },
    "vs_huang": {
        ("chair Huang et al. 2017", "trained cameras"): 2.142e-3, ("chair Huang et al. 2017", "novel camera"): 8.030e-3,
        ("chair ours", "trained cameras"): 1.057e-3, ("chair ours", "novel camera"): 8.075e-3,
        ("vase Huang et al. 2017", "trained cameras"): 4.328e-3, ("vase Huang et al. 2017", "novel camera"): 9.271e-3,
        ("vase ours", "trained cameras"): 4.875e-3, ("vase ours", "novel camera"): 9.788e-3,
        ("table Huang et al. 2017", "trained cameras"): 4.051e-3, ("table Huang et al. 2017", "novel camera"): 9.667e-3,
        ("table ours", "trained cameras"): 2.497e-3, ("table ours", "novel camera"): 8.533e-3,
        ("ceiling_lamp Huang et al. 2017", "trained cameras"): 1.361e-2,
        ("ceiling_lamp Huang et al. 2017", "novel camera"): 2.236e-2,
        ("ceiling_lamp ours", "trained cameras"): 1.403e-2, ("ceiling_lamp ours", "novel camera"): 2.272e-2,
    },
    "cls_vs_reg": {
        ("chair classification (ours)", "pc"): 0.00040, ("chair classification (ours)", "sketch"): 0.00106,
        ("chair regression", "pc"): 0.00198, ("chair regression", "sketch"): 0.00364,
    },
    "joint_vs_separate": {
        ("chair joint (ours)", "pc"): 0.00040, ("chair joint (ours)", "sketch"): 0.00106,
        ("chair separate", "pc"): 0.00037, ("chair separate", "sketch"): 0.00098,
    },
}

TITLES = {
    "pc_vs_sketch": "Point cloud vs sketch: mean Chamfer distance on the test set",
    "camera_angles": "Sketches from each camera: mean Chamfer distance",
    "simplified": "Inputs from simplified meshes (quadric decimation): mean Chamfer distance",
    "sparse": "Sparse uniform point clouds (no FPS): mean Chamfer distance",
    "noise": "Gaussian noise on the point cloud: mean Chamfer distance",
    "stability": "Structural stability: % of shapes that stand (drop test, no loose parts)",
    "vs_huang": "Ours vs Huang et al. 2017 on sketches: mean Chamfer distance",
    "cls_vs_reg": "Classification vs regression of the continuous parameters: mean Chamfer distance",
    "joint_vs_separate": "Joint vs separate decoders for point clouds and sketches: mean Chamfer distance",
}

FIT_NOTE = ("pc + fit (not the paper's method): each point-cloud prediction refined by a derivative-free "
            "search (CMA-ES, eval.fit_budget program evaluations) for the shape nearest the input cloud.")
SKETCH_FIT_NOTE = ("+ fit on sketches (not the paper's method): each sketch's prediction refined by a search "
                   "of the parameters and the camera (eval.sketch_fit_budget program evaluations) for the "
                   "shape whose line drawing is nearest the sketch's strokes.")
NOTES = {   # a fit's note where its column is in the table
    "pc_vs_sketch": {"pc + fit": FIT_NOTE, "sketch + fit": SKETCH_FIT_NOTE},
    "camera_angles": {"+ fit": SKETCH_FIT_NOTE},
    "vs_huang": "Huang et al. 2017 as the paper describes it: sketches only, one network classifying the "
                "discrete parameters and a separate one regressing the continuous ones, trained from scratch "
                "on our training split (no pretrained weights are reachable here). p: paired Wilcoxon "
                "signed-rank test of ours against Huang et al. on the same test shapes.",
    "cls_vs_reg": "Regression: the continuous parameters regressed as (value, existence) with MSE; the "
                  "discrete ones classified. p: paired Wilcoxon signed-rank test against classification.",
    "joint_vs_separate": "Separate: a set of decoders per modality. p: paired Wilcoxon signed-rank test "
                         "against the joint decoders.",
}

# Columns in the paper's order; the noise and sparse tables sort theirs by value.
COLUMNS = {
    "pc_vs_sketch": ["pc", "sketch", "pc + fit", "sketch + fit"],
    "camera_angles": ["angle 1", "angle 2", "novel", "angle 1 + fit", "angle 2 + fit", "novel + fit"],
    "simplified": ["full", "1/10", "1/100"],
    "stability": ["GT", "PC pred", "sketch pred"],
    "vs_huang": ["trained cameras", "novel camera"],
    "cls_vs_reg": ["pc", "sketch"],
    "joint_vs_separate": ["pc", "sketch"],
}

BOOTSTRAP = 2000  # resamples for a 95% percentile interval
STAT_SUFFIXES = (" CI low", " CI high", " n", " p", " (paper)")

# A cell: the per-shape values (indexed by test shape id) whose mean the table shows.
Cells = dict[tuple[str, str], pd.Series]


# ---------------------------------------------------------------- statistics


def bootstrap_ci(*samples, statistic: Callable = np.mean, resamples: int = BOOTSTRAP,
                 seed: int = 0) -> tuple[float, float]:
    """95% percentile bootstrap interval (`scipy.stats.bootstrap`, seeded) of `statistic`
    (called as statistic(*samples, axis=...)), the shapes resampled: one value per shape in
    each sample, paired by position; by default the mean of one sample. NaN for no shapes,
    the statistic itself for one."""
    samples = [np.asarray(sample, dtype=float) for sample in samples]
    if len(samples[0]) < 2:
        value = float(statistic(*samples, axis=-1)) if len(samples[0]) else np.nan
        return value, value
    interval = stats.bootstrap(samples, statistic, paired=True, vectorized=True, method="percentile",
                               n_resamples=resamples, rng=np.random.default_rng(seed)).confidence_interval
    return float(interval.low), float(interval.high)


def wilcoxon_p(a: pd.Series, b: pd.Series) -> float:
    """Two-sided paired Wilcoxon signed-rank p-value of a against b over the shapes (index)
    both have; 1 where every difference is zero, NaN where none is shared."""
    a, b = a.align(b, join="inner")
    if not len(a):
        return np.nan
    if (a == b).all():
        return 1.0
    return float(stats.wilcoxon(a.to_numpy(), b.to_numpy()).pvalue)


def per_shape(frame: pd.DataFrame, column: str = "chamfer") -> pd.Series:
    """The mean of `column` per test shape (over its cameras), indexed by shape id."""
    return frame.dropna(subset=[column]).groupby("id")[column].mean()


# ---------------------------------------------------------------- the tables' cells


def _trained(frame: pd.DataFrame, trained_cameras: list[str]) -> pd.DataFrame:
    return frame[frame.camera.isin(trained_cameras)]


def _clean(m: pd.DataFrame) -> pd.DataFrame:
    return m[(m.source == "test") & (m.noise == 0) & (m["sparse"] == 0)]


def pc_vs_sketch(m: pd.DataFrame, trained: list[str]) -> tuple[Cells, dict[str, str]]:
    """Ours on clean inputs, plus two baselines as rows of their own per domain, each compared
    with ours (paired test): the mean shape, and the nearest training shape (retrieval)."""
    out, against = {}, {}
    clean = _clean(m[m.variant == "joint"])
    for domain, d in clean.groupby("domain"):
        out[(domain, "pc")] = per_shape(d[d.modality == "pc"])
        out[(domain, "sketch")] = per_shape(_trained(d[d.modality == "sketch"], trained))
        if (d.modality == FITTED).any():
            out[(domain, "pc + fit")] = per_shape(d[d.modality == FITTED])
        if (d.modality == SKETCH_FITTED).any():
            out[(domain, "sketch + fit")] = per_shape(_trained(d[d.modality == SKETCH_FITTED], trained))
        for modality, row in (("baseline", "mean-shape baseline"), ("nearest", "nearest training shape")):
            base = d[d.modality == modality]
            if len(base):
                for column in [c for r, c in out if r == domain]:
                    out[(f"{domain} {row}", column)] = per_shape(base)
                against[f"{domain} {row}"] = domain
    return out, against


def camera_angles(m: pd.DataFrame, trained: list[str], novel: list[str]) -> Cells:
    sketches = _clean(m[(m.variant == "joint") & m.modality.isin(["sketch", SKETCH_FITTED])])
    names = {**{c: f"angle {i + 1}" for i, c in enumerate(trained)}, **{c: "novel" for c in novel}}
    suffix = {"sketch": "", SKETCH_FITTED: " + fit"}
    return {(domain, names[cam] + suffix[modality]): per_shape(g)
            for (domain, cam, modality), g in sketches.groupby(["domain", "camera", "modality"]) if cam in names}


def simplified(m: pd.DataFrame, trained: list[str]) -> Cells:
    columns = {"test": "full", "s10": "1/10", "s100": "1/100"}
    base = m[(m.variant == "joint") & (m.noise == 0) & (m["sparse"] == 0) & m.source.isin(columns)]
    out = {}
    for (domain, modality, source), g in base.groupby(["domain", "modality", "source"]):
        if modality in ("sketch", SKETCH_FITTED):
            g = _trained(g, trained)
        if modality in ("pc", "sketch", FITTED, SKETCH_FITTED):
            out[(f"{domain} {_label(modality)}", columns[source])] = per_shape(g)
    return out


def _label(modality: str) -> str:
    return {FITTED: "pc + fit", SKETCH_FITTED: "sketch + fit"}.get(modality, modality)


def _clouds(m: pd.DataFrame) -> pd.DataFrame:
    """The joint model's point-cloud rows, the fitted ones included."""
    return m[(m.variant == "joint") & m.modality.isin(["pc", FITTED])]


def _row(domain: str, modality: str) -> str:
    return f"{domain} + fit" if modality == FITTED else domain


def sparse(m: pd.DataFrame) -> Cells:
    rows = _clouds(m)
    rows = rows[rows["sparse"] > 0]
    return {(_row(domain, modality), str(int(n))): per_shape(g)
            for (domain, modality, n), g in rows.groupby(["domain", "modality", "sparse"])}


def noise(m: pd.DataFrame) -> Cells:
    rows = _clouds(m)
    rows = rows[(rows.source == "test") & (rows["sparse"] == 0)]
    return {(_row(domain, modality), f"{s:g}"): per_shape(g)
            for (domain, modality, s), g in rows.groupby(["domain", "modality", "noise"])}


def stability(m: pd.DataFrame, trained: list[str]) -> Cells:
    clean = _clean(m[m.stable.notna()])
    clean = clean[(clean.variant == "joint") | (clean.modality == "gt")]
    labels = {"gt": "GT", "pc": "PC pred", "sketch": "sketch pred"}
    out = {}
    for (domain, modality), g in clean.groupby(["domain", "modality"]):
        if modality == "sketch":
            g = _trained(g, trained)
        if modality in labels and len(g):
            out[(domain, labels[modality])] = 100.0 * per_shape(g.astype({"stable": float}), "stable")
    for domain in sorted(set(m.domain) - {domain for domain, _ in out}):  # they hang: no drop test
        out.update({(domain, label): NOT_APPLICABLE for label in labels.values()})
    return out


def comparison(m: pd.DataFrame, variants: tuple[str, str], labels: tuple[str, str],
               columns: dict[str, Callable[[pd.DataFrame], pd.DataFrame]]) -> tuple[Cells, dict[str, str]]:
    """Two variants on clean inputs, in the domains that trained both: a row per variant
    (`labels`), a column per input selector of `columns`; the second row is compared
    against the first (the reference)."""
    clean = _clean(m)
    out, against = {}, {}
    for domain, d in clean.groupby("domain"):
        if not set(variants) <= set(d.variant):
            continue
        for variant, label in zip(variants, labels, strict=True):
            for column, pick in columns.items():
                out[(f"{domain} {label}", column)] = per_shape(pick(d[d.variant == variant]))
        against[f"{domain} {labels[1]}"] = f"{domain} {labels[0]}"
    return out, against


def _columns(name: str, cells: Cells) -> list[str]:
    found = list(dict.fromkeys(c for _, c in cells))
    if name in COLUMNS:
        return [c for c in COLUMNS[name] if c in found] + [c for c in found if c not in COLUMNS[name]]
    return sorted(found, key=float, reverse=name == "sparse")  # 2048, 1024, 512; 0, 0.01, ...


def to_frame(name: str, cells: Cells, against: dict[str, str] | None = None) -> pd.DataFrame:
    """Rows x columns of ours: per column the mean, its 95% CI and the number of shapes, the
    p-value of the rows compared `against` another row (when given), and the paper's value."""
    rows = sorted({r for r, _ in cells}, key=_row_order)
    paper = PAPER.get(name, {})
    empty = pd.Series(dtype=float)
    frame = pd.DataFrame(index=pd.Index(rows, name=""))
    for c in _columns(name, cells):
        stats = [_summary(cells.get((r, c), empty)) for r in rows]
        for j, suffix in enumerate(("", " CI low", " CI high", " n")):
            frame[f"{c}{suffix}"] = [s[j] for s in stats]
        if against is not None:
            frame[f"{c} p"] = [wilcoxon_p(cells.get((r, c), empty), cells.get((against[r], c), empty))
                               if r in against else np.nan for r in rows]
        frame[f"{c} (paper)"] = [paper.get((r, c), np.nan) for r in rows]
    return frame


def _summary(values: pd.Series | str) -> tuple:
    """(mean, CI low, CI high, n) of per-shape values; a text cell (n/a) stands as it is."""
    if isinstance(values, str):
        return values, np.nan, np.nan, 0
    return (values.mean() if len(values) else np.nan, *bootstrap_ci(values), len(values))


def _with_ci(value, low, high, percent: bool) -> str:
    if isinstance(value, str):
        return value
    if not np.isfinite(value):
        return "-"
    return f"{_format(value, percent)} [{_format(low, percent)}, {_format(high, percent)}]"


def _row_order(row: str) -> tuple[int, str]:
    domain = row.split(" ")[0]
    return (DOMAIN_ORDER.index(domain) if domain in DOMAIN_ORDER else len(DOMAIN_ORDER), row)


def _format(value: float | str, percent: bool) -> str:
    if isinstance(value, str):
        return value
    if not np.isfinite(value):
        return "-"
    return f"{value:.2f}" if percent else f"{value:.5f}"


def display_cells(frame: pd.DataFrame, percent: bool) -> tuple[list[str], list[list[str]]]:
    """The frame as text for Markdown and LaTeX: per column `mean [low, high]`, then its
    n, p and paper columns."""
    heads, columns = [], []
    for c in [c for c in frame.columns if not c.endswith(STAT_SUFFIXES)]:
        heads.append(c)
        columns.append([_with_ci(v, lo, hi, percent)
                        for v, lo, hi in zip(frame[c], frame[f"{c} CI low"], frame[f"{c} CI high"], strict=True)])
        heads.append(f"{c} n")
        columns.append([str(int(n)) for n in frame[f"{c} n"]])
        if f"{c} p" in frame:
            heads.append(f"{c} p")
            columns.append([f"{p:.2g}" if np.isfinite(p) else "" for p in frame[f"{c} p"]])
        heads.append(f"{c} (paper)")
        columns.append([_format(v, percent) for v in frame[f"{c} (paper)"]])
    rows = [[str(r)] + [col[i] for col in columns] for i, r in enumerate(frame.index)]
    return heads, rows


def markdown(frame: pd.DataFrame, title: str, header: str, percent: bool, note: str = "") -> str:
    heads, rows = display_cells(frame, percent)
    lines = [f"# {title}", "", header, "", *([note, ""] if note else []),
             "Each value: the mean over test shapes [95% bootstrap confidence interval]; n: shapes.", "",
             "| | " + " | ".join(heads) + " |",
             "|---" * (len(heads) + 1) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def latex(frame: pd.DataFrame, title: str, header: str, percent: bool, note: str = "") -> str:
    escape = lambda s: str(s).replace("_", r"\_").replace("%", r"\%")  # noqa: E731
    heads, rows = display_cells(frame, percent)
    lines = [f"% {header}", *([f"% {note}"] if note else []),
             r"\begin{tabular}{l" + "r" * len(heads) + "}", r"\toprule",
             " & ".join([""] + [escape(c) for c in heads]) + r" \\", r"\midrule"]
    lines += [" & ".join(escape(v) for v in row) + r" \\" for row in rows]
    lines += [r"\bottomrule", r"\end{tabular}", f"% {title}"]
    return "\n".join(lines) + "\n"


def build_tables(metrics: pd.DataFrame, cameras: list[dict]) -> dict[str, pd.DataFrame]:
    """Every table the metrics allow; a table with no rows is left out."""
    trained = [c["name"] for c in cameras if c["train"]]
    novel = [c["name"] for c in cameras if not c["train"]]
    sketches = lambda cams: lambda g: _trained(g[g.modality == "sketch"], cams)  # noqa: E731
    pc_and_sketch = {"pc": lambda g: g[g.modality == "pc"], "sketch": sketches(trained)}
    makers: dict[str, Callable[[], Cells | tuple[Cells, dict]]] = {
        "pc_vs_sketch": lambda: pc_vs_sketch(metrics, trained),
        "camera_angles": lambda: camera_angles(metrics, trained, novel),
        "simplified": lambda: simplified(metrics, trained),
        "sparse": lambda: sparse(metrics),
        "noise": lambda: noise(metrics),
        "stability": lambda: stability(metrics, trained),
        "vs_huang": lambda: comparison(metrics, ("huang", "joint"), ("Huang et al. 2017", "ours"),
                                       {"trained cameras": sketches(trained), "novel camera": sketches(novel)}),
        "cls_vs_reg": lambda: comparison(metrics, ("joint", "regression"), ("classification (ours)", "regression"),
                                         pc_and_sketch),
        "joint_vs_separate": lambda: comparison(metrics, ("joint", "separate"), ("joint (ours)", "separate"),
                                                pc_and_sketch),
    }
    tables = {}
    for name, make in makers.items():
        made = make()
        cells, against = made if isinstance(made, tuple) else (made, None)
        if cells:
            tables[name] = to_frame(name, cells, against)
    return tables


# ---------------------------------------------------------------- the paper's trends

TRENDS = {  # trend -> (the better condition, the worse one), as the paper finds them
    "point clouds beat sketches": ("pc", "sketch (trained cameras)"),
    "the trained cameras beat the novel one": ("sketch (trained cameras)", "sketch (novel camera)"),
    "noise hurts": ("pc", "pc, most noise"),
    "sparsity hurts": ("pc, most points", "pc, fewest points"),
    "simplification hurts": ("pc", "pc, most simplified"),
}
ALPHA = 0.05
TRENDS_NOTE = (f"Each trend of the paper tested per domain on the same test shapes (paired Wilcoxon "
               f"signed-rank): 'holds' or 'reversed' where p < {ALPHA}, else no verdict at this sample size.")


def trend_pairs(m: pd.DataFrame, trained: list[str], novel: list[str]) -> dict[tuple[str, str], tuple]:
    """{(domain, trend): (per-shape CDs of the better condition, of the worse)} for the joint
    model, where the metrics hold both conditions."""
    joint = m[m.variant == "joint"]
    clean = _clean(joint)
    out = {}
    for domain, d in joint.groupby("domain"):
        c = clean[clean.domain == domain]
        pc = c[c.modality == "pc"]
        sketch = c[c.modality == "sketch"]
        clouds = d[d.modality == "pc"]
        noisy = clouds[(clouds.source == "test") & (clouds["sparse"] == 0) & (clouds.noise > 0)]
        sparse_ = clouds[clouds["sparse"] > 0]
        simple = clouds[(clouds.source != "test") & (clouds.noise == 0) & (clouds["sparse"] == 0)]
        picks = {
            "point clouds beat sketches": (pc, _trained(sketch, trained)),
            "the trained cameras beat the novel one": (_trained(sketch, trained), _trained(sketch, novel)),
            "noise hurts": (pc, noisy[noisy.noise == noisy.noise.max()]),
            "sparsity hurts": (sparse_[sparse_["sparse"] == sparse_["sparse"].max()],
                               sparse_[sparse_["sparse"] == sparse_["sparse"].min()]),
            "simplification hurts": (pc, simple[simple.source == max(simple.source, key=_factor, default="")]),
        }
        for trend, (better, worse) in picks.items():
            if len(better) and len(worse):
                out[(domain, trend)] = (per_shape(better), per_shape(worse))
    return out


def _factor(source: str) -> int:
    return int(source[1:]) if source[1:].isdigit() else 0


def trends(m: pd.DataFrame, trained: list[str], novel: list[str]) -> pd.DataFrame:
    """One row per domain and trend: the two means, n, the paired p-value and the verdict."""
    rows = []
    for (domain, trend), (better, worse) in sorted(trend_pairs(m, trained, novel).items(),
                                                   key=lambda kv: (_row_order(kv[0][0]), kv[0][1])):
        a, b = better.align(worse, join="inner")
        p = wilcoxon_p(a, b)
        verdict = "no verdict"
        if np.isfinite(p) and p < ALPHA:
            verdict = "holds" if a.mean() < b.mean() else "reversed"
        rows.append({"domain": domain, "trend": trend, "better (paper)": TRENDS[trend][0],
                     "worse (paper)": TRENDS[trend][1], "mean better": a.mean(), "mean worse": b.mean(),
                     "n": len(a), "p": p, "verdict": verdict})
    return pd.DataFrame(rows, columns=["domain", "trend", "better (paper)", "worse (paper)", "mean better",
                                       "mean worse", "n", "p", "verdict"])


def trends_markdown(frame: pd.DataFrame, header: str) -> str:
    lines = ["# The paper's trends in our results", "", header, "", TRENDS_NOTE, "",
             "| domain | trend | better (paper) | worse (paper) | mean better | mean worse | n | p | verdict |",
             "|---" * 9 + "|"]
    lines += [f"| {r.domain} | {r.trend} | {r['better (paper)']} | {r['worse (paper)']} | {r['mean better']:.5f} | "
              f"{r['mean worse']:.5f} | {r.n} | {r.p:.2g} | {r.verdict} |" for _, r in frame.iterrows()]
    return "\n".join(lines) + "\n"


def write_tables(metrics: pd.DataFrame, cameras: list[dict], out_dir: Path, header: str) -> list[str]:
    """Write <name>.csv/.md/.tex for each table and an index README.md; return the names."""
    out_dir = Path(out_dir)
    tables = build_tables(metrics, cameras)
    for name, frame in tables.items():
        percent = name == "stability"
        note = NOTES.get(name, "")
        if isinstance(note, dict):
            note = " ".join(text for column, text in note.items()
                            if any(c.endswith(column) for c in frame.columns))
        write_text(out_dir / f"{name}.csv", f"# {header}\n" + frame.to_csv(float_format="%.6g"))
        write_text(out_dir / f"{name}.md", markdown(frame, TITLES[name], header, percent, note))
        write_text(out_dir / f"{name}.tex", latex(frame, TITLES[name], header, percent, note))
    trained = [c["name"] for c in cameras if c["train"]]
    found = trends(metrics, trained, [c["name"] for c in cameras if not c["train"]])
    if len(found):
        write_text(out_dir / "trends.csv", f"# {header}\n" + found.to_csv(index=False, float_format="%.6g"))
        write_text(out_dir / "trends.md", trends_markdown(found, header))
    index = ["# Results", "", header, "", "Each table: `.csv`, `.md`, `.tex`; the paper's values in the"
             " `(paper)` columns; every mean with its 95% bootstrap confidence interval and number of"
             " test shapes. Chamfer distances: lower is better.", ""]
    index += [f"- [{TITLES[n]}]({n}.md)" for n in tables]
    if len(found):
        index.append("- [The paper's trends, tested per domain](trends.md)")
    index += ["", "Figures of inputs, ground truth and predictions: [../report/index.html](../report/index.html)"]
    write_text(out_dir / "README.md", "\n".join(index) + "\n")
    return list(tables)


def tables_step(cfg, metrics_files: list[Path], out_dir: Path) -> str:
    """Every metrics file of the run -> the tables, under a header naming the profile, the
    config's hash, the test shapes and each variant's epochs."""
    from geocode.config import config_hash
    from geocode.meshio import read_parquet

    metrics = pd.concat([read_parquet(p, "rerun the metrics step") for p in metrics_files], ignore_index=True)
    epochs = ", ".join(f"{v} {epochs_of(cfg, metrics, v)}" for v in sorted(metrics.variant.unique()))
    shapes = len(metrics[["domain", "id"]].drop_duplicates())    # ids repeat across domains
    header = (f"profile {cfg.profile_name}, config {config_hash(cfg)}, {shapes} test shapes in "
              f"{metrics.domain.nunique()} domains; max epochs: {epochs}")
    cameras = [dict(c) for c in cfg.data.sketch.cameras]
    names = write_tables(metrics, cameras, out_dir, header)
    return f"wrote {len(names)} tables to {out_dir}: {', '.join(names)}"


def epochs_of(cfg, metrics: pd.DataFrame, variant: str) -> str:
    """A variant's max epochs, "16" or "16 (vase 20)": the common count, then the domains that differ."""
    from geocode.config import max_epochs

    counts = {d: max_epochs(cfg, variant, d) for d in sorted(metrics[metrics.variant == variant].domain.unique())}
    common = max_epochs(cfg, variant, "")
    others = ", ".join(f"{d} {n}" for d, n in counts.items() if n != common)
    return f"{common}" + (f" ({others})" if others else "")
