"""Clocks for long loops and benchmarks (no bpy): progress lines with rate and ETA, a
stopwatch, the time per call of a function, and where a workflow run spent its time."""

from __future__ import annotations

import base64
import json
import logging
import re
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd


class Stopwatch:
    """`with Stopwatch() as clock: ...`; then `clock.seconds` is the time the block took."""

    def __enter__(self) -> Stopwatch:
        self.start = time.perf_counter()
        self.seconds = float("nan")
        return self

    def __exit__(self, *exc) -> None:
        self.seconds = time.perf_counter() - self.start


def seconds_per_call(fn: Callable[[], object], repeats: int, best: bool = False) -> float:
    """Seconds per call of `fn` after one untimed warm-up call: the median of `repeats` timed
    calls, or with `best` the fastest (the least disturbed run on a busy machine)."""
    fn()
    times = []
    for _ in range(repeats):
        with Stopwatch() as clock:
            fn()
        times.append(clock.seconds)
    return float(min(times) if best else np.median(times))


class Progress:
    """Call `step()` once per finished item; logs count, rate and ETA at most once every
    `every` seconds, and a last line at `finish()`."""

    def __init__(self, label: str, total: int, logger: logging.Logger, every: float = 5.0):
        self.label, self.total, self.log, self.every = label, total, logger, every
        self.done = 0
        self.start = self.last = time.perf_counter()

    def step(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if now - self.last >= self.every:
            self.last = now
            self._emit()

    def rate(self) -> float:
        elapsed = time.perf_counter() - self.start
        return self.done / elapsed if elapsed > 0 else 0.0

    def finish(self) -> float:
        """Log the final line and return the rate (items per second)."""
        self._emit()
        return self.rate()

    def _emit(self) -> None:
        rate = self.rate()
        left = (self.total - self.done) / rate if rate > 0 else float("nan")
        self.log.info("%s: %d/%d, %.2f/s, ETA %.0f s", self.label, self.done, self.total, rate, left)


def run_times(metadata: str | Path, profile: str, domains: list[str], variants: list[str]) -> pd.DataFrame:
    """Seconds per job of the last Snakemake run of a profile, from Snakemake's record of each
    output (`.snakemake/metadata/`: rule, start and end time): one row per job with its rule,
    domain ("-" for a job of every domain), model variant ("-" for the data), start, end and
    seconds. A job is the profile's when the profile names a folder of its output or log path;
    the program builds, shared by every profile, are no profile's."""
    jobs = {}
    for path in Path(metadata).glob("*"):
        try:
            record = json.loads(path.read_text())
            output = base64.b64decode(path.name).decode()
        except (ValueError, UnicodeDecodeError, OSError):
            continue   # not a record of an output
        places = [output, *(record.get("log") or [])]
        if "starttime" not in record or not any(profile in Path(p).parts for p in places):
            continue
        parts = [piece for p in places for part in Path(p).parts for piece in re.split(r"[.-]", part)]
        domain = next((d for d in parts if d in domains), "-")
        variant = next((v for v in parts if v in variants), "-")
        start, end = float(record["starttime"]), float(record["endtime"])
        jobs[(record["rule"], record.get("job_hash"), start)] = dict(
            rule=record["rule"], domain=domain, variant=variant, start=start, end=end, seconds=end - start)
    return pd.DataFrame(list(jobs.values()), columns=["rule", "domain", "variant", "start", "end", "seconds"])


def run_summary(jobs: pd.DataFrame) -> str:
    """Markdown: minutes of job time per stage (rows, in the order they ran) and domain
    (columns), and the run's wall-clock span."""
    if jobs.empty:
        return "no finished jobs recorded for this profile\n"
    order = jobs.groupby("rule").start.min().sort_values().index
    minutes = jobs.pivot_table(index="rule", columns="domain", values="seconds", aggfunc="sum", fill_value=0) / 60
    minutes = minutes.reindex(order)
    minutes["all"] = minutes.sum(axis=1)
    minutes.loc["all"] = minutes.sum()
    span = (jobs.end.max() - jobs.start.min()) / 60
    per_variant = jobs.groupby("variant").seconds.sum() / 60
    head = "| stage | " + " | ".join(minutes.columns) + " |"
    lines = [f"Wall clock, first job's start to last job's end: {span:.1f} min over {len(jobs)} jobs.",
             "Minutes of job time (jobs overlap: with -j2 two run at once):", "", head,
             "|---" * (len(minutes.columns) + 1) + "|"]
    lines += [f"| {r} | " + " | ".join(f"{v:.1f}" for v in row) + " |" for r, row in minutes.iterrows()]
    lines += ["", "Per model variant (training and evaluation; '-': data and tables): "
              + ", ".join(f"{v} {m:.1f}" for v, m in per_variant.items()) + " min"]
    return "\n".join(lines) + "\n"
