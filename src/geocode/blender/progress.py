"""Progress lines for long batched loops: count, rate and ETA every few seconds."""

from __future__ import annotations

import logging
import os
import sys
import time
from contextlib import contextmanager


class Progress:
    """Call `step()` once per finished item; logs at most once every `every` seconds."""

    def __init__(self, label: str, total: int, logger: logging.Logger, every: float = 5.0):
        self.label, self.total, self.log, self.every = label, total, logger, every
        self.done = 0
        self.start = self.last = time.perf_counter()

    def step(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if now - self.last >= self.every:
            self.last = now
            self._emit(now)

    def rate(self) -> float:
        elapsed = time.perf_counter() - self.start
        return self.done / elapsed if elapsed > 0 else 0.0

    def finish(self) -> float:
        """Log the final line and return the rate (items per second)."""
        self._emit(time.perf_counter())
        return self.rate()

    def _emit(self, now: float) -> None:
        rate = self.rate()
        left = (self.total - self.done) / rate if rate > 0 else float("nan")
        self.log.info("%s: %d/%d, %.2f/s, ETA %.0f s", self.label, self.done, self.total, rate, left)


@contextmanager
def quiet_stdout():
    """Silence C-level stdout (Blender's per-render 'Fra:'/'Saved:' lines) for the block,
    so shard logs hold only our progress lines; stderr, where errors go, stays."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)
