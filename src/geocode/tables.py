"""Per-sample metrics -> the paper's tables (docs/paper-numbers.md#tables) as CSV, Markdown and LaTeX, with the
paper's values beside ours (no bpy, no torch).

The metrics frame has one row per (domain, variant, condition, id) with the columns
`modality` (pc | sketch | gt | baseline), `source` (test | s10 | s100: the test meshes or
their simplifications), `camera`, `noise`, `sparse`, `chamfer` and `stable` (bool, or NaN
where the drop test was not run).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from geocode.meshio import write_text

DOMAIN_ORDER = ["chair", "vase", "table", "ceiling_lamp", "cabinet"]

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
    "ablations": {
        ("chair joint (cls)", "pc"): 0.00040, ("chair joint (cls)", "sketch"): 0.00106,
        ("chair regression", "pc"): 0.00198, ("chair regression", "sketch"): 0.00364,
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
    "ablations": "Decoder ablations: mean Chamfer distance",
}


def _mean(frame: pd.DataFrame, column: str = "chamfer") -> float:
    values = frame[column].dropna()
    return float(values.mean()) if len(values) else np.nan


def _trained(frame: pd.DataFrame, trained_cameras: list[str]) -> pd.DataFrame:
    return frame[frame.camera.isin(trained_cameras)]


def pc_vs_sketch(m: pd.DataFrame, trained: list[str]) -> dict[tuple[str, str], float]:
    """Ours on clean inputs, plus the mean-shape baseline as its own row per domain."""
    out = {}
    clean = m[(m.variant == "joint") & (m.source == "test") & (m.noise == 0) & (m["sparse"] == 0)]
    for domain, d in clean.groupby("domain"):
        out[(domain, "pc")] = _mean(d[d.modality == "pc"])
        out[(domain, "sketch")] = _mean(_trained(d[d.modality == "sketch"], trained))
        base = m[(m.domain == domain) & (m.modality == "baseline")]
        if len(base):
            out[(f"{domain} mean-shape baseline", "pc")] = _mean(base)
            out[(f"{domain} mean-shape baseline", "sketch")] = _mean(base)
    return out


def camera_angles(m: pd.DataFrame, trained: list[str], novel: list[str]) -> dict:
    sketches = m[(m.variant == "joint") & (m.modality == "sketch") & (m.source == "test")]
    names = {**{c: f"angle {i + 1}" for i, c in enumerate(trained)}, **{c: "novel" for c in novel}}
    return {(domain, names[cam]): _mean(g) for (domain, cam), g in sketches.groupby(["domain", "camera"])
            if cam in names}


def simplified(m: pd.DataFrame, trained: list[str]) -> dict:
    columns = {"test": "full", "s10": "1/10", "s100": "1/100"}
    base = m[(m.variant == "joint") & (m.noise == 0) & (m["sparse"] == 0) & m.source.isin(columns)]
    out = {}
    for (domain, modality, source), g in base.groupby(["domain", "modality", "source"]):
        if modality == "sketch":
            g = _trained(g, trained)
        if modality in ("pc", "sketch"):
            out[(f"{domain} {modality}", columns[source])] = _mean(g)
    return out


def sparse(m: pd.DataFrame) -> dict:
    rows = m[(m.variant == "joint") & (m.modality == "pc") & (m["sparse"] > 0)]
    return {(domain, str(int(n))): _mean(g) for (domain, n), g in rows.groupby(["domain", "sparse"])}


def noise(m: pd.DataFrame) -> dict:
    rows = m[(m.variant == "joint") & (m.modality == "pc") & (m.source == "test") & (m["sparse"] == 0)]
    return {(domain, f"{s:g}"): _mean(g) for (domain, s), g in rows.groupby(["domain", "noise"])}


def stability(m: pd.DataFrame, trained: list[str]) -> dict:
    clean = m[m.stable.notna() & (m.source == "test") & (m.noise == 0) & (m["sparse"] == 0)]
    clean = clean[(clean.variant == "joint") | (clean.modality == "gt")]
    labels = {"gt": "GT", "pc": "PC pred", "sketch": "sketch pred"}
    out = {}
    for (domain, modality), g in clean.groupby(["domain", "modality"]):
        if modality == "sketch":
            g = _trained(g, trained)
        if modality in labels and len(g):
            out[(domain, labels[modality])] = 100.0 * float(g.stable.astype(float).mean())
    return out


def ablations(m: pd.DataFrame, trained: list[str]) -> dict:
    names = {"joint": "joint (cls)", "regression": "regression", "separate": "separate", "huang": "Huang et al. 2017"}
    clean = m[(m.source == "test") & (m.noise == 0) & (m["sparse"] == 0) & m.variant.isin(names)]
    if clean.variant.nunique() < 2:
        return {}
    out = {}
    for (domain, variant), g in clean.groupby(["domain", "variant"]):
        out[(f"{domain} {names[variant]}", "pc")] = _mean(g[g.modality == "pc"])
        out[(f"{domain} {names[variant]}", "sketch")] = _mean(_trained(g[g.modality == "sketch"], trained))
    return out


def to_frame(name: str, ours: dict[tuple[str, str], float]) -> pd.DataFrame:
    """Rows x columns of ours, each column followed by the paper's value where it has one."""
    rows = sorted({r for r, _ in ours}, key=_row_order)
    columns = list(dict.fromkeys(c for _, c in ours))
    paper = PAPER.get(name, {})
    frame = pd.DataFrame(index=pd.Index(rows, name=""))
    for c in columns:
        frame[c] = [ours.get((r, c), np.nan) for r in rows]
        frame[f"{c} (paper)"] = [paper.get((r, c), np.nan) for r in rows]
    return frame


def _row_order(row: str) -> tuple[int, str]:
    domain = row.split(" ")[0]
    return (DOMAIN_ORDER.index(domain) if domain in DOMAIN_ORDER else len(DOMAIN_ORDER), row)


def _format(value: float, percent: bool) -> str:
    if not np.isfinite(value):
        return "-"
    return f"{value:.2f}" if percent else f"{value:.5f}"


def markdown(frame: pd.DataFrame, title: str, header: str, percent: bool) -> str:
    cells = [[str(r)] + [_format(v, percent) for v in frame.loc[r]] for r in frame.index]
    lines = [f"# {title}", "", header, "",
             "| | " + " | ".join(frame.columns) + " |",
             "|---" * (len(frame.columns) + 1) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in cells]
    return "\n".join(lines) + "\n"


def latex(frame: pd.DataFrame, title: str, header: str, percent: bool) -> str:
    escape = lambda s: str(s).replace("_", r"\_").replace("%", r"\%")  # noqa: E731
    lines = [f"% {header}", r"\begin{tabular}{l" + "r" * len(frame.columns) + "}", r"\toprule",
             " & ".join([""] + [escape(c) for c in frame.columns]) + r" \\", r"\midrule"]
    lines += [" & ".join([escape(r)] + [_format(v, percent) for v in frame.loc[r]]) + r" \\"
              for r in frame.index]
    lines += [r"\bottomrule", r"\end{tabular}", f"% {title}"]
    return "\n".join(lines) + "\n"


def build_tables(metrics: pd.DataFrame, cameras: list[dict]) -> dict[str, pd.DataFrame]:
    """Every table the metrics allow; a table with no rows is left out."""
    trained = [c["name"] for c in cameras if c["train"]]
    novel = [c["name"] for c in cameras if not c["train"]]
    makers: dict[str, Callable[[], dict]] = {
        "pc_vs_sketch": lambda: pc_vs_sketch(metrics, trained),
        "camera_angles": lambda: camera_angles(metrics, trained, novel),
        "simplified": lambda: simplified(metrics, trained),
        "sparse": lambda: sparse(metrics),
        "noise": lambda: noise(metrics),
        "stability": lambda: stability(metrics, trained),
        "ablations": lambda: ablations(metrics, trained),
    }
    tables = {}
    for name, make in makers.items():
        ours = make()
        if ours:
            tables[name] = to_frame(name, ours)
    return tables


def write_tables(metrics: pd.DataFrame, cameras: list[dict], out_dir: Path, header: str) -> list[str]:
    """Write <name>.csv/.md/.tex for each table and an index README.md; return the names."""
    out_dir = Path(out_dir)
    tables = build_tables(metrics, cameras)
    for name, frame in tables.items():
        percent = name == "stability"
        write_text(out_dir / f"{name}.csv", f"# {header}\n" + frame.to_csv(float_format="%.6g"))
        write_text(out_dir / f"{name}.md", markdown(frame, TITLES[name], header, percent))
        write_text(out_dir / f"{name}.tex", latex(frame, TITLES[name], header, percent))
    index = ["# Results", "", header, "", "Each table: `.csv`, `.md`, `.tex`; the paper's values in the"
             " `(paper)` columns. Chamfer distances: lower is better.", ""]
    index += [f"- [{TITLES[n]}]({n}.md)" for n in tables]
    index += ["", "Figures of inputs, ground truth and predictions: [../report/index.html](../report/index.html)"]
    write_text(out_dir / "README.md", "\n".join(index) + "\n")
    return list(tables)
