"""Recipes: which program parameters a dataset varies, their classes and normalised labels (no bpy).

A program exposes `Parameter`s (through its manifest, see `load_manifest`); a recipe
(`programs/<domain>.yaml`) picks some of them, narrows their ranges and sets the number of
classes of each continuous one. Labels follow SPEC §2: float (v-min)/(max-min), int v-min,
bool 0/1, and -1 where the parameter is invisible. A parameter with a visibility rule gets one
extra class, the existence class, at the last index.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from geocode.errors import UserError
from geocode.expr import Expr, ExprError, parse

__all__ = [
    "KINDS",
    "Parameter",
    "RecipeError",
    "RecipeParameter",
    "Recipe",
    "load_manifest",
    "parse_manifest",
    "load_recipe",
    "manifest_path",
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
    entries = data.get("parameters") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        _fail(source, "parameters", "missing or not a list", "rebuild the program's manifest")
    parameters = [_manifest_parameter(entry, i, source) for i, entry in enumerate(entries)]
    names = [p.name for p in parameters]
    if len(set(names)) != len(names):
        duplicate = next(n for n in names if names.count(n) > 1)
        _fail(source, f"parameters.{duplicate}", "appears twice", "give every parameter one entry")
    visibility = {}
    for entry, parameter in zip(entries, parameters, strict=True):
        rule = entry.get("visible_if")
        visibility[parameter.name] = (
            None
            if rule is None
            else _parse_rule(
                rule,
                names,
                source,
                f"parameters.{parameter.name}.visible_if",
                "fix the program's Switch inputs",
            )
        )
    return parameters, visibility


def _manifest_parameter(entry, index: int, source) -> Parameter:
    where = f"parameters[{index}]"
    if not isinstance(entry, dict):
        _fail(source, where, "not a mapping", "rebuild the program's manifest")
    for key in ("name", "kind", "min", "max", "default"):
        if key not in entry:
            _fail(source, f"{where}.{key}", "missing", "rebuild the program's manifest")
    name, kind = entry["name"], entry["kind"]
    if not isinstance(name, str) or not name.isidentifier():
        _fail(source, f"{where}.name", f"{name!r} is not an identifier", "rename the program input")
    if kind not in KINDS:
        _fail(
            source, f"parameters.{name}.kind", f"{kind!r} unknown", f"use one of {', '.join(KINDS)}"
        )
    numbers = {}
    for key in ("min", "max", "default"):
        value = entry[key]
        if isinstance(value, bool):
            value = float(value)
        if not isinstance(value, (int, float)) or not np.isfinite(value):
            _fail(
                source,
                f"parameters.{name}.{key}",
                f"{value!r} is not a finite number",
                "fix the program input",
            )
        numbers[key] = float(value)
    if not numbers["min"] <= numbers["default"] <= numbers["max"]:
        _fail(
            source,
            f"parameters.{name}",
            f"default {numbers['default']:g} outside [{numbers['min']:g}, {numbers['max']:g}]",
            "fix the program input's range or default",
        )
    return Parameter(
        name,
        kind,
        numbers["min"],
        numbers["max"],
        numbers["default"],
        str(entry.get("description") or ""),
    )


def _parse_rule(text, names: Iterable[str], source, field_name: str, fix: str) -> Expr:
    if not isinstance(text, str):
        _fail(source, field_name, f"{text!r} is not a string", fix)
    try:
        return parse(text, names=names)
    except ExprError as exc:
        _fail(source, field_name, str(exc), fix)


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())


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
        """Raw values -> labels of visible shapes (SPEC §2)."""
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


# ---------------------------------------------------------------- the recipe

ENTRY_KEYS = {"min", "max", "samples"}
TOP_KEYS = {"parameters", "constraints"}


class Recipe:
    """The learned parameters of one program, in program order, with the dataset's constraints."""

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
            data = yaml.load(
                text, Loader=_UniqueKeyLoader
            )  # a safe loader that also rejects duplicate keys
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
        if not isinstance(data, dict):
            _fail(
                source,
                "(top level)",
                "not a mapping",
                "write `parameters:` and optional `constraints:`",
            )
        unknown = sorted(set(map(str, data)) - TOP_KEYS)
        if unknown:
            _fail(source, unknown[0], "unknown key", "use only `parameters` and `constraints`")
        entries = data.get("parameters")
        if not isinstance(entries, dict) or not entries:
            _fail(
                source,
                "parameters",
                "missing, empty or not a mapping",
                "map at least one program parameter to {min, max[, samples]}",
            )
        program = {p.name: p for p in parameters}
        for name in entries:
            if name not in program:
                _fail(
                    source,
                    f"parameters.{name}",
                    "unknown parameter",
                    f"use one of the program's: {_some(program)}",
                )
        learned = [
            _recipe_parameter(program[p.name], entries[p.name], visibility.get(p.name), source)
            for p in parameters
            if p.name in entries
        ]
        constraints = _constraints(data.get("constraints"), list(program), source)
        return cls(learned, constraints, list(parameters), source)

    # -------------------------------------------------------- one shape at a time (dicts)

    def full_values(self, values: Mapping[str, float]) -> dict[str, float]:
        """Every program parameter: the given values over the defaults."""
        unknown = [name for name in values if name not in self.defaults]
        if unknown:
            raise UserError(
                f"unknown parameter {unknown[0]!r}", f"the program has {_some(self.defaults)}",
                "rerun the sample step if the program changed",
            )
        return {**self.defaults, **{name: float(v) for name, v in values.items()}}

    def visible(self, values: Mapping[str, float]) -> dict[str, bool]:
        """Visibility of each recipe parameter, evaluated on the full values."""
        full = self.full_values(values)
        return {
            p.name: p.visible_if is None or bool(p.visible_if.evaluate(full))
            for p in self.parameters
        }

    def labels(self, values: Mapping[str, float]) -> dict[str, float]:
        """Normalised labels, -1 where invisible."""
        full = self.full_values(values)
        visible = self.visible(values)
        return {
            p.name: float(p.normalise(full[p.name])) if visible[p.name] else INVISIBLE
            for p in self.parameters
        }

    def class_indices(self, values: Mapping[str, float]) -> dict[str, int]:
        """Nearest value class, or the existence class where invisible."""
        full = self.full_values(values)
        visible = self.visible(values)
        return {
            p.name: int(p.nearest_class(full[p.name])) if visible[p.name] else p.existence_class
            for p in self.parameters
        }

    def values_from_classes(self, indices: Mapping[str, int]) -> dict[str, float]:
        """Raw values of the recipe parameters; the existence class gives the default."""
        row = np.array([[indices[name] for name in self.names]], dtype=np.int64)
        return dict(zip(self.names, self.classes_to_values(row)[0].tolist(), strict=True))

    def satisfies(self, values: Mapping[str, float]) -> bool:
        full = self.full_values(values)
        return all(bool(c.evaluate(full)) for c in self.constraints)

    # -------------------------------------------------------- batches: (n, P) arrays, P = len(self)

    def columns(
        self, frame: pd.DataFrame | Mapping[str, np.ndarray]
    ) -> dict[str, np.ndarray | float]:
        """Columns for `Expr.evaluate_array`: recipe parameters from `frame`, defaults for the rest."""
        missing = [name for name in self.names if name not in frame]
        if missing:
            raise UserError(f"recipe parameter {missing[0]!r}", "no column for it", "rerun the sample step")
        given = {name: np.asarray(frame[name], dtype=np.float64) for name in self.names}
        return {**self.defaults, **given}

    def visibility_matrix(self, frame) -> np.ndarray:
        """(n, P) bool: is each recipe parameter visible in each row."""
        columns = self.columns(frame)
        n = len(columns[self.names[0]])
        out = np.ones((n, len(self)), dtype=bool)
        for j, p in enumerate(self.parameters):
            if p.visible_if is not None:
                out[:, j] = np.broadcast_to(p.visible_if.evaluate_array(columns).astype(bool), (n,))
        return out

    def constraint_mask(self, frame) -> np.ndarray:
        """(n,) bool: do all constraints hold in each row."""
        columns = self.columns(frame)
        n = len(columns[self.names[0]])
        ok = np.ones(n, dtype=bool)
        for constraint in self.constraints:
            ok &= np.broadcast_to(constraint.evaluate_array(columns).astype(bool), (n,))
        return ok

    def value_matrix(self, frame) -> np.ndarray:
        """(n, P) float64 raw values of the recipe parameters, in recipe order."""
        return np.column_stack([np.asarray(frame[name], dtype=np.float64) for name in self.names])

    def label_matrix(self, frame) -> np.ndarray:
        """(n, P) float64 normalised labels, -1 where invisible."""
        values = self.value_matrix(frame)
        labels = np.column_stack([p.normalise(values[:, j]) for j, p in enumerate(self.parameters)])
        return np.where(self.visibility_matrix(frame), labels, INVISIBLE)

    def class_matrix(self, frame) -> np.ndarray:
        """(n, P) int64 class indices, the existence class where invisible."""
        values = self.value_matrix(frame)
        visible = self.visibility_matrix(frame)
        out = np.empty(values.shape, dtype=np.int64)
        for j, p in enumerate(self.parameters):
            nearest = p.nearest_class(values[:, j])
            out[:, j] = (
                nearest
                if p.existence_class is None
                else np.where(visible[:, j], nearest, p.existence_class)
            )
        return out

    def labels_to_classes(self, labels: np.ndarray) -> np.ndarray:
        """Normalised labels (n, P) or (P,) -> class indices of the same shape (int64)."""
        labels = np.asarray(labels, dtype=np.float64)
        out = np.empty(labels.shape, dtype=np.int64)
        for j, p in enumerate(self.parameters):
            column = labels[..., j]
            nearest = p.nearest_class(p.denormalise(column))
            if p.has_existence:
                nearest = np.where(column < -0.5, p.existence_class, nearest)
            out[..., j] = nearest
        return out

    def classes_to_labels(self, classes: np.ndarray) -> np.ndarray:
        """Class indices (n, P) or (P,) -> normalised labels (-1 for the existence class)."""
        classes = self._check_classes(classes)
        out = np.empty(classes.shape, dtype=np.float64)
        for j, p in enumerate(self.parameters):
            column = classes[..., j]
            is_value = column < p.n_values
            raw = p.classes[np.where(is_value, column, 0)]
            out[..., j] = np.where(is_value, p.normalise(raw), INVISIBLE)
        return out

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


# ---------------------------------------------------------------- validation of one entry


def _recipe_parameter(
    program: Parameter, entry, visible_if: Expr | None, source
) -> RecipeParameter:
    where = f"parameters.{program.name}"
    if entry is None and program.kind == "bool":
        entry = {}  # `flag:` alone learns both values
    if not isinstance(entry, dict):
        _fail(source, where, f"{entry!r} is not a mapping", "write {min: ..., max: ...}")
    unknown = sorted(set(map(str, entry)) - ENTRY_KEYS)
    if unknown:
        _fail(
            source, f"{where}.{unknown[0]}", "unknown key", "use min, max and (floats only) samples"
        )
    low = _bound(program, entry, "min", source)
    high = _bound(program, entry, "max", source)
    if low > high:
        _fail(
            source, f"{where}.min", f"{low:g} is greater than max {high:g}", "swap them or fix one"
        )
    samples = _samples(program, entry, source)
    if program.kind == "float" and low == high:
        _fail(
            source,
            f"{where}.max",
            "equals min, so every class is the same value",
            "widen the range, or drop the parameter to keep it at its default",
        )
    classes = make_classes(program.kind, low, high, samples)
    return RecipeParameter(
        program.name, program.kind, low, high, program.default, samples, classes, visible_if
    )


def _bound(program: Parameter, entry: dict, key: str, source) -> float:
    where = f"parameters.{program.name}.{key}"
    program_bound = program.min if key == "min" else program.max
    if key not in entry:
        if program.kind == "bool":
            return program_bound
        _fail(
            source,
            where,
            "missing",
            f"give it (the program allows [{program.min:g}, {program.max:g}])",
        )
    value = entry[key]
    if isinstance(value, bool):
        if program.kind != "bool":
            _fail(
                source,
                where,
                f"{value!r} is a bool, the parameter is {program.kind}",
                "give a number",
            )
        value = int(value)
    if not isinstance(value, (int, float)) or not np.isfinite(value):
        _fail(source, where, f"{value!r} is not a finite number", "give a number")
    if program.kind != "float" and value != round(value):
        _fail(
            source,
            where,
            f"{value!r} is not a whole number, the parameter is {program.kind}",
            "give an integer",
        )
    tolerance = RANGE_TOLERANCE * max(1.0, abs(program.min), abs(program.max))
    if value < program.min - tolerance or value > program.max + tolerance:
        _fail(
            source,
            where,
            f"{value:g} is outside the program's range [{program.min:g}, {program.max:g}]",
            "a recipe may narrow the range, never widen it",
        )
    return float(min(max(value, program.min), program.max))


def _samples(program: Parameter, entry: dict, source) -> int | None:
    where = f"parameters.{program.name}.samples"
    if program.kind != "float":
        if "samples" in entry:
            _fail(
                source,
                where,
                f"given for a {program.kind} parameter",
                "remove it: int and bool parameters have one class per value",
            )
        return None
    if "samples" not in entry:
        _fail(
            source, where, "missing for a float parameter", "give the number of classes (2 or more)"
        )
    samples = entry["samples"]
    if isinstance(samples, bool) or not isinstance(samples, int):
        _fail(
            source,
            where,
            f"{samples!r} is not an integer",
            "give the number of classes (2 or more)",
        )
    if samples < 2:
        _fail(
            source, where, f"{samples} is below 2", "give 2 or more: the classes include both ends"
        )
    return samples


def _constraints(entries, names: list[str], source) -> list[Expr]:
    if entries is None:
        return []
    if not isinstance(entries, list):
        _fail(source, "constraints", "not a list", 'write a list of strings such as - "a <= b"')
    return [
        _parse_rule(
            text,
            names,
            source,
            f"constraints[{i}]",
            "use parameter names, numbers, + - * /, comparisons, and/or/not",
        )
        for i, text in enumerate(entries)
    ]


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


def manifest_path(cfg, domain: str) -> Path:
    """The manifest that `geocode program build` writes for `domain` under the build folder."""
    return Path(cfg.paths.build) / "programs" / f"{domain}.manifest.json"


def load_recipe(cfg) -> Recipe:
    """The recipe of cfg.domain (`domain.recipe`, relative to the repository), checked against
    the parameters in its program's manifest."""
    from geocode.config import repo_root

    parameters, visibility = load_manifest(manifest_path(cfg, cfg.domain.name))
    return Recipe.load(repo_root() / cfg.domain.recipe, parameters, visibility)
