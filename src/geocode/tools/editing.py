"""Editing in a program's parameter space: read a shape's values, mix two shapes, interpolate
between them (the paper's shape editing and mixing: every parameter keeps its meaning, so a
part of one shape can be given to another by copying the values that describe it).

A shape is a YAML mapping of raw parameter values, as the dataset's `shapes/<id>.yaml` and
`geocode reconstruct` write it; missing parameters take the program's defaults.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import yaml

from geocode.errors import UserError


def read_values(path: str | Path, program) -> dict[str, float]:
    """Every parameter value of the shape file `path` (defaults filled in), checked against
    the program's ranges; ValueError (one line, naming the file) otherwise."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UserError(f"{path}: no such shape file; give a YAML of parameter values "
                                "(e.g. data/<profile>/<domain>/test/shapes/<id>.yaml)") from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        problem = str(exc).splitlines()[0]
        raise UserError(f"{path}: not a readable YAML file ({problem}); give a mapping "
                         "name: value") from None
    if not isinstance(data, Mapping) or not data:
        raise UserError(f"{path}: holds no parameter values; give a mapping name: value")
    try:
        return program.check(data)
    except ValueError as exc:
        raise UserError(f"{path}: {exc}") from None


def select(program, tokens: Sequence[str]) -> list[str]:
    """The parameter names that `tokens` name: a token is a parameter name, or the first
    word(s) of a group of names (`handle` takes handle_count, handle_top, ...)."""
    names = [p.name for p in program.parameters]
    chosen: list[str] = []
    for token in tokens:
        group = [n for n in names if n == token or n.startswith(f"{token.rstrip('_')}_")]
        if not group:
            raise UserError(f"--take {token}: no parameter of {program.domain!r} is or starts "
                             f"with {token!r}; see `geocode program show {program.domain}`")
        chosen += [n for n in group if n not in chosen]
    return chosen


def mix(a: Mapping[str, float], b: Mapping[str, float], take: Sequence[str]) -> dict[str, float]:
    """Shape `a` with the values of the parameters `take` copied from shape `b`."""
    return {**a, **{name: b[name] for name in take}}


def interpolate(program, a: Mapping[str, float], b: Mapping[str, float],
                steps: int) -> list[dict[str, float]]:
    """`steps` shapes from `a` to `b` (both included): continuous parameters blend linearly,
    discrete ones (int, bool) switch from a's value to b's at the midpoint."""
    if steps < 2:
        raise UserError(f"--steps {steps}: give at least 2 (the two end shapes)")
    kinds = {p.name: p.kind for p in program.parameters}
    sequence = []
    for t in np.linspace(0.0, 1.0, steps).tolist():
        sequence.append({
            name: (1.0 - t) * a[name] + t * b[name] if kinds[name] == "float"
            else (a[name] if t < 0.5 else b[name])
            for name in a})
    return sequence
