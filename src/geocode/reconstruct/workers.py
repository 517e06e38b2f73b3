"""A folder's inputs spread over processes: each worker process has its own Blender, program and
network (a `run.Reconstructor`) and reconstructs whole files, writing their outputs, so that a
folder's throughput grows with the cores; the main process gathers their page entries and
summaries in input order. Every input is seeded on its own, so the results are those of one
process.

Stopping: Ctrl-C or SIGTERM stops the main process (`geocode.errors`), which then stops every
worker with SIGTERM; a worker in the middle of a file removes that file's temporary outputs
(`geocode.outputs`) before it ends, an idle one ends at once. A worker's set-up error (a
checkpoint that does not fit) stops the run with its one line before any file is begun.
"""

from __future__ import annotations

import logging
import os
import signal
import sys
from pathlib import Path

from geocode.errors import STOP_SIGNALS, Interrupted

_WORKER: dict = {}   # in a worker process: its Reconstructor (or the error of its set-up) and its state


def spread(cfg, settings: dict, plan, processes: int, fit_workers: int, make, work):
    """(page entry, summary) of each of the plan's inputs, in order, reconstructed by
    `processes` worker processes, each fit with `fit_workers` processes (itself included):
    each worker builds `make(cfg, **settings, workers=fit_workers)` (`run.Reconstructor`) once
    and runs `work(that, job, out_dir)` (`run.reconstruct_file`) for each of its files."""
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    threads = max(1, len(os.sched_getaffinity(0)) // processes)
    pool = ProcessPoolExecutor(processes, mp_context=get_context("spawn"), initializer=_start,
                               initargs=(cfg, settings, fit_workers, threads, logging.getLogger().level, make))
    try:
        for ready in [pool.submit(_ready) for _ in range(processes)]:   # every worker starts now
            ready.result()               # the set-up's errors, before the record or any file
        plan.write_record()
        futures = [pool.submit(_reconstruct, work, job, plan.out_dir) for job in plan.jobs]
        for future in futures:
            yield future.result()
    except BaseException:                # an error, Ctrl-C, or the caller done early
        stop(pool)
        raise
    pool.shutdown()


def stop(pool) -> None:
    """Cancel what has not begun and stop every worker (a busy one removes its temporary files
    first), waiting until they have ended."""
    processes = list(pool._processes.values())   # ProcessPoolExecutor stops no running work itself
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join()


# -- in a worker process ------------------------------------------------------------------------

def _start(cfg, settings: dict, fit_workers: int, threads: int, level: int, make) -> None:
    import torch

    from geocode.errors import import_blender

    for sig in STOP_SIGNALS:
        signal.signal(sig, _on_signal)
    logging.basicConfig(level=level, format="%(asctime)s %(name)s: %(message)s", datefmt="%H:%M:%S")
    torch.set_num_threads(threads)
    # A spawned process gets the sys.path of its parent, where Blender, once imported, put
    # its scripts/modules: their Python-side `bpy` package would shadow the module itself.
    sys.path[:] = [p for p in sys.path if not (Path(p) / "bpy" / "__init__.py").exists()]
    try:
        import_blender()
        _WORKER["run"] = make(cfg, **settings, workers=fit_workers)
    except Exception as exc:     # said by the first task, in the main process
        _WORKER["error"] = exc


def _on_signal(signum, _frame) -> None:
    """Busy: unwind the file (its temporary outputs removed), once; idle: end now."""
    state = _WORKER.get("state", "idle")
    if state == "busy":
        _WORKER["state"] = "stopping"
        raise Interrupted(signum)
    if state == "idle":
        _end(signum)


def _end(signum: int) -> None:
    """End this worker now, and the processes of its fit (`fit.helper_pool`) with it."""
    import multiprocessing

    for child in multiprocessing.active_children():
        child.terminate()
    os._exit(128 + signum)


def _ready() -> bool:
    if "error" in _WORKER:
        raise _WORKER["error"]
    return True


def _reconstruct(work, job, out_dir: Path):
    _ready()
    _WORKER["state"] = "busy"
    try:
        return work(_WORKER["run"], job, out_dir)
    except Interrupted as stopped:
        _end(stopped.signum)     # its files are removed; the main process stops the run
    finally:
        _WORKER["state"] = "idle"
