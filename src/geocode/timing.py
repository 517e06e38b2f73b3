"""Clocks for long loops and benchmarks (no bpy): progress lines with rate and ETA, a
stopwatch, and the time per call of a function."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import numpy as np


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
