"""The paper's real-shape table for folders of real meshes a user names (workflow target
`results/real_shapes`, `--config real='{chair: path/to/chairs, vase: path/to/vases}'`).

Each domain's folder is a collection of `workflow/rules/reconstruct.smk` named
`real_shapes-<domain>`: its files reconstructed in batches as `geocode reconstruct` does them,
each batch's record holding every file's distances to the input (`reconstruct.run`, plain
Chamfer on the input's unit sphere, in the pose the tool found):

    network alone            the network's answer (its best turn and own feedback rounds)
    network + fit            the fit's answer
    nearest training shape   the training shape nearest the input, at its best quarter-turn
    program defaults         the program's default shape, at its best quarter-turn

This step reads the records and writes the table: per domain each mean with its 95% bootstrap
interval, the paired Wilcoxon p of each answer against the nearest training shape, and the
paper's rows beside (COSEG's 400 chairs and 300 vases, its own models and measurement).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from geocode.errors import UserError
from geocode.meshio import write_text
from geocode.steps.tables import DOMAIN_ORDER, bootstrap_ci, wilcoxon_p

COLUMNS = {   # the record's key -> the table's row
    "chamfer_before": "network alone",
    "chamfer_after": "network + fit",
    "chamfer_nearest": "nearest training shape",
    "chamfer_defaults": "program defaults",
}
AGAINST = "chamfer_nearest"   # the baseline every answer is tested against
PAPER = {  # the paper's table of real shapes (COSEG), mean Chamfer distance
    "GeoCode (paper)": {"chair": 0.0062, "vase": 0.0112},
    "StructureNet (paper)": {"chair": 0.0203, "vase": 0.0215},
    "ShapeAssembly (paper)": {"chair": 0.0134},
}
NOTE = ("Chamfer distance between each input and the answer: 10,000 surface points each on the input's "
        "unit sphere, squared, the mean of both directions / 2, in the pose the tool found (up axis, "
        "front). The paper's rows are the paper's numbers on COSEG's 400 chairs and 300 vases with its "
        "own models and measurement (the network fed 1,500 farthest + 800 random points): a reference, "
        "not a run of this table.")


def read_records(domain: str, files: list[Path]) -> pd.DataFrame:
    """One row per input of the domain's batch records: file, domain and the distances (NaN
    where the input failed, with its error)."""
    rows = []
    for path in files:
        try:
            record = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise UserError(path, f"not a batch record ({exc})", "rerun the workflow: it redoes the batch") from None
        for item in record:
            summary = item["summary"]
            rows.append({"domain": domain, "file": item["name"], "error": summary.get("error", ""),
                         **{key: summary.get(key, np.nan) for key in COLUMNS}})
    return pd.DataFrame(rows, columns=["domain", "file", "error", *COLUMNS])


def summarise(shapes: pd.DataFrame) -> pd.DataFrame:
    """Per (row, domain): mean, CI low, CI high, n (inputs measured), failed, p against the nearest
    training shape; then the paper's rows."""
    rows = []
    for domain, group in shapes.groupby("domain", sort=False):
        done = group[group.error == ""]
        for key, row in COLUMNS.items():
            values = done[key].dropna().to_numpy(float)
            low, high = bootstrap_ci(values)
            p = (wilcoxon_p(done[key].reset_index(drop=True), done[AGAINST].reset_index(drop=True))
                 if key != AGAINST and done[AGAINST].notna().any() else np.nan)
            rows.append({"row": row, "domain": domain, "mean": values.mean() if len(values) else np.nan,
                         "CI low": low, "CI high": high, "n": len(values), "failed": len(group) - len(done),
                         "p vs nearest": p})
    for row, values in PAPER.items():
        rows += [{"row": row, "domain": domain, "mean": value} for domain, value in values.items()]
    return pd.DataFrame(rows)


def ordered_domains(domains) -> list[str]:
    return sorted(set(domains), key=lambda d: (DOMAIN_ORDER.index(d) if d in DOMAIN_ORDER else len(DOMAIN_ORDER), d))


def markdown(summary: pd.DataFrame, header: str) -> str:
    measured = summary[summary["n"].notna()]
    domains = ordered_domains(measured.domain)
    lines = ["# Real shapes: the network, the fit and the baselines", "", header, "", NOTE, "",
             "Each value: the mean over the folder's inputs [95% bootstrap confidence interval]; p: paired "
             "Wilcoxon signed-rank test against the nearest training shape; n: inputs measured.", "",
             "| | " + " | ".join(f"{d} | {d} n | {d} p" for d in domains) + " |",
             "|---" * (1 + 3 * len(domains)) + "|"]
    for row in [*COLUMNS.values(), *PAPER]:
        cells = []
        for domain in domains:
            found = summary[(summary.row == row) & (summary.domain == domain)]
            if found.empty:
                cells += ["-", "", ""]
                continue
            r = found.iloc[0]
            if not np.isfinite(r["n"]):    # a paper row: its number alone
                cells += [f"{r['mean']:.4f}", "", ""]
                continue
            cells += [f"{r['mean']:.4f} [{r['CI low']:.4f}, {r['CI high']:.4f}]" if r["n"] else "-",
                      f"{int(r['n'])}" + (f" ({int(r['failed'])} failed)" if r["failed"] else ""),
                      f"{r['p vs nearest']:.2g}" if np.isfinite(r["p vs nearest"]) else ""]
        lines.append(f"| {row} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def real_shapes_step(cfg, records: list[list[str]], out_dir: Path) -> str:
    """`records`: per domain [domain, batch record, ...] -> <out_dir>/real_shapes.{csv,md} (the
    table) and shapes.csv (every input's distances)."""
    from geocode.config import config_hash

    if not records:
        raise UserError("--records", "no domain given", "give --records <domain> <batch record>...")
    frames = []
    for domain, *files in records:
        if not files:
            raise UserError(f"--records {domain}", "no batch record given", "name the domain's batch records")
        frames.append(read_records(domain, [Path(f) for f in files]))
    shapes = pd.concat(frames, ignore_index=True)
    summary = summarise(shapes)
    header = (f"profile {cfg.profile_name}, config {config_hash(cfg)}; each domain's joint model; the fit's "
              f"budget {cfg.eval.reconstruct_budget} evaluations unless the collection names another")
    out_dir = Path(out_dir)
    write_text(out_dir / "shapes.csv", f"# {header}\n" + shapes.to_csv(index=False, float_format="%.6g"))
    write_text(out_dir / "real_shapes.csv", f"# {header}\n" + summary.to_csv(index=False, float_format="%.6g"))
    write_text(out_dir / "real_shapes.md", markdown(summary, header))
    return f"wrote {out_dir}/real_shapes.md: {len(shapes)} inputs in {shapes.domain.nunique()} domains"
