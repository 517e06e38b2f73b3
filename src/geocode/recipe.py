"""Recipes: which program parameters a dataset learns, their classes and normalised labels (no bpy).

A program declares every parameter's range once, and its manifest carries it here (see
`load_manifest`). A recipe (`programs/<domain>.yaml`) names the parameters a dataset learns and
says only what it changes: the number of classes of each continuous parameter, optionally a
narrower range, and constraints (docs/design.md, "Recipe"). Labels (docs/paper-numbers.md#labels):
float (v-min)/(max-min), int v-min, bool 0/1, and -1 where the parameter is invisible. A
parameter with a visibility rule gets one extra class, the existence class, at the last index.

Both files are checked against a schema (pydantic); every problem is one line
`file: field: problem; fix`.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from geocode.errors import UserError
from geocode.expr import Expr, ExprError, parse
from geocode.meshio import read_parquet, write_parquet
from geocode.paths import manifest_path, recipe_path

__all__ = [
    "KINDS",
    "Parameter",
    "RecipeError",
    "RecipeParameter",
    "Recipe",
    "load_manifest",
    "parse_manifest",
    "load_recipe",
    "META_COLUMNS",
    "save_recipes",
    "load_recipes",
]

KINDS = ("bool", "int", "float")
INVISIBLE = -1.0
RANGE_TOLERANCE = 1e-9  # a recipe may repeat the program's float range written with rounding


class RecipeError(UserError):
    """A bad recipe or manifest; the message is one line naming the file, the field and the fix."""


def _fail(source, field_name: str, problem: str, fix: str):
    raise RecipeError(f"{source}: {field_name}: {problem}; {fix}")


@dataclass(frozen=True)
class Parameter:
    name: str  # a vector input "seat_size" becomes seat_size_x, seat_size_y, seat_size_z
    kind: str  # "bool" | "int" | "float"
    min: float
    max: float
    default: float
    description: str = ""


# ---------------------------------------------------------------- schemas


class _Schema(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class _ManifestEntry(_Schema):
    model_config = ConfigDict(strict=False)  # the manifest is JSON we wrote: 1 may stand for 1.0
    name: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")
    kind: Literal["bool", "int", "float"]
    min: float
    max: float
    default: float
    description: str | None = ""
    visible_if: str | None = None

    @model_validator(mode="after")
    def _default_in_range(self):
        if not self.min <= self.default <= self.max:
            raise ValueError(f"default {self.default:g} outside [{self.min:g}, {self.max:g}]")
        return self


class _Manifest(_Schema):
    model_config = ConfigDict(extra="ignore", strict=False)
    parameters: list[_ManifestEntry]


class _RecipeEntry(_Schema):
    """One learned parameter; min and max default to the program's range."""

    min: float | None = None
    max: float | None = None
    samples: int | None = Field(None, ge=2)


class _RecipeFile(_Schema):
    parameters: dict[str, _RecipeEntry | None] = Field(min_length=1)
    constraints: list[str] | None = None


_MANIFEST_FIX = "rebuild the program's manifest (geocode program build)"
_ENTRY_FIX = "write {samples: n} for a float, nothing for an int or bool, and min/max only to narrow"


def _fix(where: str, error_type: str) -> str:
    """What to do about a problem in a recipe, by the field it is in."""
    if error_type == "extra_forbidden":
        return ("use only `parameters` and `constraints`" if "." not in where
                else "use min, max and (floats only) samples")
    if where == "(top level)":
        return "write `parameters:` and optional `constraints:`"
    if where == "parameters":
        return "map at least one program parameter to {samples: n} (floats) or nothing (int, bool)"
    if where.startswith("constraints"):
        return 'write a list of strings such as - "a <= b"'
    if where.endswith(".samples"):
        return "give the number of classes (2 or more): the classes include both ends"
    if where.endswith((".min", ".max")):
        return "give a number, or leave it out to take the program's"
    return _ENTRY_FIX


def _validated(schema: type[BaseModel], data, source, manifest: bool = False):
    """`data` checked against `schema`; the first problem as a one-line RecipeError."""
    try:
        return schema.model_validate(data)
    except ValidationError as exc:
        error = exc.errors()[0]
    where = _where(error["loc"], data)
    _fail(source, where, _problem(error, where),
          _MANIFEST_FIX if manifest else _fix(where, error["type"]))


def _where(loc: tuple, data) -> str:
    """A pydantic location as a YAML path: parameters.height.min, constraints[0]; list items
    that have a name are shown by name (parameters.width.max)."""
    if not loc:
        return "(top level)"
    parts, node = [], data
    for key in loc:
        node = _child(node, key)
        if isinstance(key, int):
            name = node.get("name") if isinstance(node, dict) else None
            parts.append(f".{name}" if isinstance(name, str) else f"[{key}]")
        else:
            parts.append(f".{key}")
    return "".join(parts).lstrip(".")


def _child(node, key):
    if isinstance(node, dict):
        return node.get(key)
    if isinstance(node, list) and isinstance(key, int) and key < len(node):
        return node[key]
    return None


def _problem(error: dict, where: str) -> str:
    kind, value = error["type"], error.get("input")
    if where == "parameters" and kind in ("missing", "too_short", "dict_type"):
        return "missing, empty or not a mapping"
    if kind in ("float_type", "int_type") and isinstance(value, bool):
        return f"{value!r} is a bool"
    problems = {
        "missing": "missing",
        "extra_forbidden": "unknown key",
        "model_type": f"{_short(value)} is not a mapping",
        "dict_type": f"{_short(value)} is not a mapping",
        "list_type": "not a list",
        "string_type": f"{_short(value)} is not a string",
        "string_pattern_mismatch": f"{_short(value)} is not an identifier",
        "int_type": f"{_short(value)} is not an integer",
        "int_from_float": f"{_short(value)} is not an integer",
        "float_type": f"{_short(value)} is not a finite number",
        "float_parsing": f"{_short(value)} is not a finite number",
        "finite_number": f"{_short(value)} is not a finite number",
        "greater_than_equal": f"{_short(value)} is below 2",
        "literal_error": f"{_short(value)} unknown, use one of {', '.join(KINDS)}",
    }
    if kind == "value_error":
        return str(error["ctx"]["error"])
    return problems.get(kind, _one_line(error["msg"]))


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _one_line(exc) -> str:
    return " ".join(str(exc).split())


# ---------------------------------------------------------------- manifest


def load_manifest(path: str | os.PathLike) -> tuple[list[Parameter], dict[str, Expr | None]]:
    """Read `build/programs/<domain>.manifest.json` (written by `geocode.program`)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise RecipeError(
            f"{path}: file not found; build the program first (geocode program build)"
        ) from None
    except (OSError, ValueError) as exc:
        raise RecipeError(
            f"{path}: not readable JSON ({_one_line(exc)}); rebuild the program"
        ) from None
    return parse_manifest(data, source=path)


def parse_manifest(data, source="<manifest>") -> tuple[list[Parameter], dict[str, Expr | None]]:
    """The manifest's parameters and visibility rules (None = always visible), validated."""
    entries = _validated(_Manifest, data, source, manifest=True).parameters
    names = [e.name for e in entries]
    duplicate = next((n for n in names if names.count(n) > 1), None)
    if duplicate:
        _fail(source, f"parameters.{duplicate}", "appears twice", "give every parameter one entry")
    parameters = [
        Parameter(e.name, e.kind, e.min, e.max, e.default, e.description or "") for e in entries
    ]
    visibility = {
        e.name: None
        if e.visible_if is None
        else _parse_rule(e.visible_if, names, source, f"parameters.{e.name}.visible_if",
                         "fix the program's Switch inputs")
        for e in entries
    }
    return parameters, visibility


def _parse_rule(text: str, names: Iterable[str], source, field_name: str, fix: str) -> Expr:
    try:
        return parse(text, names=names)
    except ExprError as exc:
        _fail(source, field_name, str(exc), fix)


# ---------------------------------------------------------------- recipe parameters


@dataclass(frozen=True)
class RecipeParameter:
    """One learned parameter: its recipe range and its classes (raw values, ends included)."""

    name: str
    kind: str
    min: float
    max: float
    default: float
    samples: int | None  # number of float classes; None for int and bool
    classes: np.ndarray = field(compare=False, repr=False)  # raw value of each value class
    visible_if: Expr | None = None

    @property
    def has_existence(self) -> bool:
        return self.visible_if is not None

    @property
    def n_values(self) -> int:
        """Value classes only (the classes sampling forces)."""
        return len(self.classes)

    @property
    def n_classes(self) -> int:
        """Value classes plus the existence class (last index) when the parameter can hide."""
        return len(self.classes) + int(self.has_existence)

    @property
    def existence_class(self) -> int | None:
        return len(self.classes) if self.has_existence else None

    def normalise(self, values: np.ndarray | float) -> np.ndarray:
        """Raw values -> labels of visible shapes (docs/paper-numbers.md#labels)."""
        values = np.asarray(values, dtype=np.float64)
        if self.kind == "float":
            return (values - self.min) / (self.max - self.min)
        if self.kind == "int":
            return values - self.min
        return values

    def denormalise(self, labels: np.ndarray | float) -> np.ndarray:
        labels = np.asarray(labels, dtype=np.float64)
        if self.kind == "float":
            return self.min + labels * (self.max - self.min)
        if self.kind == "int":
            return labels + self.min
        return labels

    def nearest_class(self, values: np.ndarray | float) -> np.ndarray:
        """Index of the value class nearest each raw value."""
        values = np.asarray(values, dtype=np.float64)
        return np.abs(values[..., None] - self.classes).argmin(axis=-1).astype(np.int64)

    def describe(self) -> dict:
        return {
            "name": self.name,
            "kind": self.kind,
            "min": self.min,
            "max": self.max,
            "default": self.default,
            "classes": self.n_classes,
            "visible_if": None if self.visible_if is None else str(self.visible_if),
        }


def make_classes(kind: str, low: float, high: float, samples: int | None) -> np.ndarray:
    """Float: `samples` values spread uniformly over [low, high], both ends included;
    int and bool: every integer value in [low, high]."""
    if kind == "float":
        return np.linspace(low, high, samples)
    return np.arange(round(low), round(high) + 1, dtype=np.float64)


def _learned(program: Parameter, entry: _RecipeEntry, visible_if: Expr | None, source):
    """The recipe's entry for one program parameter, checked against the program's range."""
    where = f"parameters.{program.name}"
    if program.kind == "float" and entry.samples is None:
        _fail(source, f"{where}.samples", "missing for a float parameter",
              f"give its number of classes: `{program.name}: {{samples: 4}}`")
    if program.kind != "float" and entry.samples is not None:
        _fail(source, f"{where}.samples", f"given for the {program.kind} parameter",
              "remove it: int and bool parameters have one class per value")
    low = _bound(program, entry.min, "min", source)
    high = _bound(program, entry.max, "max", source)
    if low > high:
        _fail(source, f"{where}.min", f"{low:g} is greater than max {high:g}",
              "swap them or fix one")
    if program.kind == "float" and low == high:
        _fail(source, f"{where}.max", "equals min, so every class is the same value",
              "widen the range, or drop the parameter to keep it at its default")
    classes = make_classes(program.kind, low, high, entry.samples)
    return RecipeParameter(program.name, program.kind, low, high, program.default,
                           entry.samples, classes, visible_if)


def _bound(program: Parameter, value: float | None, key: str, source) -> float:
    """A recipe bound: the program's where not given; inside the program's range."""
    if value is None:
        return program.min if key == "min" else program.max
    where = f"parameters.{program.name}.{key}"
    if program.kind != "float" and value != round(value):
        _fail(source, where, f"{value!r} is not a whole number, the parameter is {program.kind}",
              "give an integer")
    tolerance = RANGE_TOLERANCE * max(1.0, abs(program.min), abs(program.max))
    if not program.min - tolerance <= value <= program.max + tolerance:
        _fail(source, where,
              f"{value:g} is outside the program's range [{program.min:g}, {program.max:g}]",
              f"a recipe may narrow the range, never widen it: give a {key} inside it, or "
              f"leave {key} out to take the program's (widen the range in the program itself)")
    return float(min(max(value, program.min), program.max))


# ---------------------------------------------------------------- the recipe


class Recipe:
    """The learned parameters of one program, in program order, with the dataset's constraints.

    Every rule (visibility, labels, classes, constraints) is written once, over batches: an
    (n, P) array or a frame of n rows, P = len(self). The one-shape methods (`labels`,
    `class_indices`, `satisfies`) run the batch versions on one row."""

    def __init__(
        self,
        parameters: list[RecipeParameter],
        constraints: list[Expr],
        program_parameters: list[Parameter],
        source: str = "<recipe>",
    ):
        self.parameters = parameters
        self.constraints = constraints
        self.program_parameters = program_parameters
        self.source = source
        self.names = [p.name for p in parameters]
        self.defaults = {p.name: p.default for p in program_parameters}
        self._by_name = {p.name: p for p in parameters}
        self._n_values = np.array([p.n_values for p in parameters], dtype=np.int64)

    def __getitem__(self, name: str) -> RecipeParameter:
        return self._by_name[name]

    def __len__(self) -> int:
        return len(self.parameters)

    # -------------------------------------------------------- loading

    @classmethod
    def load(
        cls,
        path: str | os.PathLike,
        parameters: list[Parameter],
        visibility: Mapping[str, Expr | None],
    ) -> Recipe:
        """Read and validate a recipe YAML against the program's parameters and visibility."""
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise RecipeError(
                f"{path}: file not found; write the recipe beside the program"
            ) from None
        except UnicodeDecodeError as exc:
            raise RecipeError(path, f"not UTF-8 text (byte {exc.start})", "save it as UTF-8") from None
        except OSError as exc:
            raise RecipeError(path, f"cannot be read ({exc.strerror})", "give a readable YAML file") from None
        try:
            data = yaml.load(text, Loader=_UniqueKeyLoader)  # safe, and refuses repeated keys
        except yaml.YAMLError as exc:
            raise RecipeError(
                f"{path}: not valid YAML ({_one_line(exc)}); fix the syntax"
            ) from None
        return cls.from_dict(data, parameters, visibility, source=str(path))

    @classmethod
    def from_dict(
        cls,
        data,
        parameters: list[Parameter],
        visibility: Mapping[str, Expr | None],
        source: str = "<recipe>",
    ) -> Recipe:
        spec = _validated(_RecipeFile, data, source)
        program = {p.name: p for p in parameters}
        unknown = next((name for name in spec.parameters if name not in program), None)
        if unknown is not None:
            _fail(source, f"parameters.{unknown}", "unknown parameter",
                  f"use one of the program's: {_some(program)}")
        learned = [
            _learned(p, spec.parameters[p.name] or _RecipeEntry(), visibility.get(p.name), source)
            for p in parameters
            if p.name in spec.parameters
        ]
        constraints = [
            _parse_rule(text, program, source, f"constraints[{i}]",
                        "use parameter names, numbers, + - * /, comparisons, and/or/not")
            for i, text in enumerate(spec.constraints or [])
        ]
        return cls(learned, constraints, list(parameters), source)

    # -------------------------------------------------------- one shape (one row of the batch rules)

    def full_values(self, values: Mapping[str, float]) -> dict[str, float]:
        """Every program parameter: the given values over the defaults."""
        unknown = [name for name in values if name not in self.defaults]
        if unknown:
            raise UserError(
                f"unknown parameter {unknown[0]!r}", f"the program has {_some(self.defaults)}",
                "rerun the sample step if the program changed",
            )
        return {**self.defaults, **{name: float(v) for name, v in values.items()}}

    def _row(self, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        return {name: np.array([v]) for name, v in self.full_values(values).items()}

    def labels(self, values: Mapping[str, float]) -> dict[str, float]:
        """Normalised labels, -1 where invisible."""
        return dict(zip(self.names, self.label_matrix(self._row(values))[0].tolist(), strict=True))

    def class_indices(self, values: Mapping[str, float]) -> dict[str, int]:
        """Nearest value class, or the existence class where invisible."""
        return dict(zip(self.names, self.class_matrix(self._row(values))[0].tolist(), strict=True))

    def shown(self, values: Mapping[str, float]) -> dict[str, bool]:
        """Is each recipe parameter visible (does it change the shape) at these values."""
        return dict(zip(self.names, self.visibility_matrix(self._row(values))[0].tolist(), strict=True))

    def satisfies(self, values: Mapping[str, float]) -> bool:
        return bool(self.constraint_mask(self._row(values))[0])

    def values_from_classes(self, indices: Mapping[str, int]) -> dict[str, float]:
        """Raw values of the recipe parameters; the existence class gives the default."""
        row = np.array([[indices[name] for name in self.names]], dtype=np.int64)
        return dict(zip(self.names, self.classes_to_values(row)[0].tolist(), strict=True))

    # -------------------------------------------------------- batches: (n, P) arrays

    def columns(
        self, frame: pd.DataFrame | Mapping[str, np.ndarray]
    ) -> dict[str, np.ndarray | float]:
        """Columns for `Expr.evaluate_array`: program parameters from `frame` where it has
        them (every recipe parameter must be there), defaults for the rest."""
        missing = [name for name in self.names if name not in frame]
        if missing:
            raise UserError(f"recipe parameter {missing[0]!r}", "no column for it", "rerun the sample step")
        given = {n: np.asarray(frame[n], dtype=np.float64) for n in self.defaults if n in frame}
        return {**self.defaults, **given}

    def _rows(self, frame) -> int:
        return len(np.asarray(frame[self.names[0]]))

    def visibility_matrix(self, frame) -> np.ndarray:
        """(n, P) bool: is each recipe parameter visible in each row."""
        columns, n = self.columns(frame), self._rows(frame)
        out = np.ones((n, len(self)), dtype=bool)
        for j, p in enumerate(self.parameters):
            if p.visible_if is not None:
                out[:, j] = np.broadcast_to(p.visible_if.evaluate_array(columns).astype(bool), (n,))
        return out

    def constraint_mask(self, frame) -> np.ndarray:
        """(n,) bool: do all constraints hold in each row."""
        columns, n = self.columns(frame), self._rows(frame)
        ok = np.ones(n, dtype=bool)
        for constraint in self.constraints:
            ok &= np.broadcast_to(constraint.evaluate_array(columns).astype(bool), (n,))
        return ok

    def value_matrix(self, frame) -> np.ndarray:
        """(n, P) float64 raw values of the recipe parameters, in recipe order."""
        return np.column_stack([np.asarray(frame[name], dtype=np.float64) for name in self.names])

    def _normalised(self, values: np.ndarray) -> np.ndarray:
        """Raw values (..., P) -> labels of visible shapes (..., P)."""
        return np.stack([p.normalise(values[..., j]) for j, p in enumerate(self.parameters)], -1)

    def _existence(self) -> np.ndarray:
        """(P,) the existence class of each parameter (-1 where it has none)."""
        return np.array([-1 if p.existence_class is None else p.existence_class
                         for p in self.parameters], dtype=np.int64)

    def label_matrix(self, frame) -> np.ndarray:
        """(n, P) float64 normalised labels, -1 where invisible."""
        labels = self._normalised(self.value_matrix(frame))
        return np.where(self.visibility_matrix(frame), labels, INVISIBLE)

    def class_matrix(self, frame) -> np.ndarray:
        """(n, P) int64 class indices, the existence class where invisible."""
        values = self.value_matrix(frame)
        nearest = np.column_stack(
            [p.nearest_class(values[:, j]) for j, p in enumerate(self.parameters)]
        )
        return np.where(self.visibility_matrix(frame), nearest, self._existence())

    def labels_to_classes(self, labels: np.ndarray) -> np.ndarray:
        """Normalised labels (n, P) or (P,) -> class indices of the same shape (int64)."""
        labels = np.asarray(labels, dtype=np.float64)
        nearest = np.stack([p.nearest_class(p.denormalise(labels[..., j]))
                            for j, p in enumerate(self.parameters)], -1)
        hidden = (labels < -0.5) & (self._existence() >= 0)
        return np.where(hidden, self._existence(), nearest).astype(np.int64)

    def classes_to_labels(self, classes: np.ndarray) -> np.ndarray:
        """Class indices (n, P) or (P,) -> normalised labels (-1 for the existence class)."""
        classes = self._check_classes(classes)
        labels = self._normalised(self.classes_to_values(classes))
        return np.where(classes < self._n_values, labels, INVISIBLE)

    def classes_to_values(self, classes: np.ndarray) -> np.ndarray:
        """Class indices (n, P) or (P,) -> raw values; the existence class gives the default."""
        classes = self._check_classes(classes)
        out = np.empty(classes.shape, dtype=np.float64)
        for j, p in enumerate(self.parameters):
            column = classes[..., j]
            is_value = column < p.n_values
            out[..., j] = np.where(is_value, p.classes[np.where(is_value, column, 0)], p.default)
        return out

    def _check_classes(self, classes) -> np.ndarray:
        classes = np.asarray(classes, dtype=np.int64)
        if classes.shape[-1] != len(self):
            raise ValueError(f"expected {len(self)} class columns, got {classes.shape[-1]}")
        for j, p in enumerate(self.parameters):
            column = classes[..., j]
            if column.size and (column.min() < 0 or column.max() >= p.n_classes):
                raise ValueError(f"class index of {p.name!r} outside [0, {p.n_classes - 1}]")
        return classes

    # -------------------------------------------------------- describing

    def describe(self) -> list[dict]:
        """Per parameter: name, kind, min, max, default, classes (= n_classes), visible_if."""
        return [p.describe() for p in self.parameters]

    def to_dict(self) -> dict:
        return {"parameters": self.describe(), "constraints": [str(c) for c in self.constraints]}


def _some(names: Iterable[str], limit: int = 8) -> str:
    names = list(names)
    shown = ", ".join(names[:limit])
    return shown + (f", ... ({len(names)} in all)" if len(names) > limit else "")


class _UniqueKeyLoader(yaml.SafeLoader):
    """yaml.SafeLoader that refuses a key given twice (safe_load silently keeps the last)."""


def _mapping_without_duplicates(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if not isinstance(key, str | int | float | bool | None):
            raise yaml.constructor.ConstructorError(
                None, None, f"key {key!r} is not a name", key_node.start_mark
            )
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"key {key!r} given twice", key_node.start_mark
            )
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


_UniqueKeyLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _mapping_without_duplicates
)


def load_recipe(cfg) -> Recipe:
    """The recipe of cfg.domain (`<programs>/<domain>.yaml`), checked against the parameters
    in its program's manifest."""
    parameters, visibility = load_manifest(manifest_path(cfg, cfg.domain.name))
    return Recipe.load(recipe_path(cfg.domain.name), parameters, visibility)


# -- a split's recipes table: one row per shape, its recipe values and the sampler's columns --

META_COLUMNS = ("id", "shard", "forced", "forced_class")


def save_recipes(frame: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write a split's `recipes.parquet` atomically (a crash never leaves a partial file)."""
    missing = [c for c in META_COLUMNS if c not in frame]
    if missing:
        raise ValueError(f"recipes frame lacks column {missing[0]!r}")
    write_parquet(path, frame.reset_index(drop=True))


def load_recipes(path: str | os.PathLike) -> pd.DataFrame:
    """Read `recipes.parquet`; a missing or broken file raises ValueError naming it."""
    frame = read_parquet(path, "run the sample step")
    missing = [c for c in META_COLUMNS if c not in frame]
    if missing:
        raise UserError(path, f"no column {missing[0]!r}", "rerun the sample step")
    return frame
