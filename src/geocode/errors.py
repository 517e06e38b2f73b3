"""What a user's input or environment can get wrong, and how a step stops when told to.

A `UserError` is one line, `<file or key>: <problem>; <fix>`: the command line prints it and
exits with 2. Anything else is a bug and keeps its traceback. Ctrl-C and SIGTERM raise
`Interrupted`, which unwinds the stack (temporary files are removed) and ends the command
with one line and exit code 128 + the signal's number (130, 143).
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class UserError(ValueError):
    """A mistake in a file, a name or a setting that the user can fix.

    `UserError(where, problem, fix)` reads `<where>: <problem>; <fix>`; a single argument is
    the whole line, already in that form.
    """

    def __init__(self, where, problem: str | None = None, fix: str | None = None):
        line = str(where) if problem is None else f"{where}: {problem}" + (f"; {fix}" if fix else "")
        super().__init__(" ".join(line.split()))  # one line, whatever a library put in `problem`


def one_line(exc: BaseException, limit: int = 160) -> str:
    """A library's error message on one line, shortened: the middle of a UserError."""
    return " ".join(str(exc).split())[:limit] or type(exc).__name__


class Interrupted(BaseException):
    """Ctrl-C or SIGTERM; `signum` says which. Not a KeyboardInterrupt: Lightning turns that
    into exit code 1, but lets any other BaseException through after its clean-up."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _interrupt(signum, _frame):
    raise Interrupted(signum)


def interruption(exc: BaseException) -> Interrupted | None:
    """The stop signal behind `exc`, if any: a signal that lands inside compiled code (numba's
    dispatcher) comes back as a SystemError whose cause is the `Interrupted` raised here."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, Interrupted):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


@contextmanager
def stop_signals_raise():
    """In the block, Ctrl-C and SIGTERM (how Snakemake stops a job) raise `Interrupted`."""
    previous = {sig: signal.signal(sig, _interrupt) for sig in STOP_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


@contextmanager
def signals_deferred():
    """Deliver SIGINT and SIGTERM only when the block ends, for C code that an exception
    raised half-way through would leave broken: Freestyle swallows a KeyboardInterrupt in its
    stroke shaders and 'finishes' a blank render; Blender's start-up, interrupted while it
    registers add-ons, crashes the process at exit. Outside the main thread Python runs no
    signal handler, so there is nothing to defer."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    previous = {sig: signal.signal(sig, lambda signum, _: caught.append(signum)) for sig in STOP_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        if caught:
            signal.raise_signal(caught[0])


def import_blender() -> None:
    """Import bpy (Blender's start-up, about a second) with stop signals held until it is done."""
    with signals_deferred():
        import bpy  # noqa: F401
