"""Shape programs: load `programs/<domain>.py`, list its parameters, evaluate it to a mesh,
infer its visibility rules (docs/design.md, "Programs").

A program module defines `build(g: geocode.nodes.Graph) -> None`: it declares every
parameter with `g.input(name, kind, default=, min=, max=, description=)` and connects the
final mesh with `g.output("Geometry", "geometry", mesh)`. The module is imported, and its
graph built, only when `Program.load` is called; importing this module does no Blender work
beyond importing bpy lazily.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import io
import math
import os
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType

import numpy as np
import trimesh

from geocode.config import registry
from geocode.errors import UserError
from geocode.expr import Expr
from geocode.paths import program_path, recipe_path
from geocode.recipe import Parameter

AXES = ("x", "y", "z")
_KINDS = {"NodeSocketBool": "bool", "NodeSocketInt": "int", "NodeSocketFloat": "float",
          "NodeSocketVector": "vector"}
MAX_DRAWS = 1000  # random_values: draws of a shape before the constraints are declared unmet
_UNBOUNDED = 1e30  # Blender's default socket range is +-3.4e38: treat as "not given"
_LOADED: dict[str, Program] = {}  # by program file: one build per process


def _import_program(domain: str) -> ModuleType:
    path = program_path(domain)
    if not path.exists():
        known = ", ".join(registry()) or "none"
        raise UserError(f"{path}: no such program; known domains: {known}")
    spec = importlib.util.spec_from_file_location(f"geocode_programs.{domain}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if not callable(getattr(module, "build", None)):
        raise UserError(f"{path}: defines no build(g) function; add one")
    return module


class Program:
    """One domain's program, built as a node tree on one object in this Blender session."""

    def __init__(self, domain: str, module: ModuleType):
        self.domain = domain
        self._module = module
        self.hangs = bool(getattr(module, "HANGS", False))  # no drop test (a ceiling lamp)
        self._build()

    @classmethod
    def load(cls, domain: str) -> Program:
        """The program of `domain`; loaded once per process and rebuilt after a reset."""
        key = str((program_path(domain)).resolve())
        program = _LOADED.get(key)
        if program is None:
            program = _LOADED[key] = cls(domain, _import_program(domain))
        program._ensure_alive()
        return program

    # -- building -----------------------------------------------------------------------------

    def _build(self) -> None:
        from geocode.nodes import Evaluator, Graph

        graph = Graph.new(f"GeoCode {self.domain}")
        self._module.build(graph)
        graph.arrange()
        self._tree_name = graph.tree.name
        self._evaluator = Evaluator(graph.tree, name=f"GeoCode {self.domain}")
        self._inputs = _program_inputs(graph.tree, self.domain)
        self.parameters: list[Parameter] = [p for spec in self._inputs for p in spec.parameters]
        self._by_name = {p.name: p for p in self.parameters}
        self._visibility: dict[str, Expr | None] | None = None
        self._recipe_for_drawing = None

    def _ensure_alive(self) -> None:
        if not self._evaluator.alive():  # a factory reset removed our object and tree
            self._build()

    @property
    def tree(self):
        import bpy

        self._ensure_alive()
        return bpy.data.node_groups[self._tree_name]

    # -- evaluation -----------------------------------------------------------------------------

    def check(self, values: Mapping[str, float]) -> dict[str, float]:
        """All parameter values, defaults filled in; ValueError (one line) for an unknown
        name or a value outside its parameter's range."""
        full = {p.name: p.default for p in self.parameters}
        for name, value in values.items():
            parameter = self._by_name.get(name)
            if parameter is None:
                raise UserError(f"unknown parameter {name!r} for program {self.domain!r}; "
                                f"see `geocode program show {self.domain}`")
            full[name] = _checked(parameter, value)
        return full

    def evaluate(self, values: Mapping[str, float]) -> trimesh.Trimesh:
        """The mesh for `values` (missing names take their defaults), with
        `mesh.metadata["part"]`: one integer part label per face."""
        full = self.check(values)
        self._ensure_alive()
        inputs = {spec.name: spec.socket_value(full) for spec in self._inputs}
        return self._evaluator.mesh(inputs)

    def random_values(self, rng: np.random.Generator) -> dict[str, float]:
        """A random shape of the kind the dataset holds: every recipe parameter drawn uniformly
        over its recipe range (ints and bools: every value equally likely), the others at their
        defaults, redrawn until the recipe's constraints hold (at most MAX_DRAWS draws)."""
        recipe = self._drawing_recipe()
        for _ in range(MAX_DRAWS):
            values = {**self.check({}), **{p.name: _uniform(p, rng) for p in recipe.parameters}}
            if recipe.satisfies(values):
                return values
        raise UserError(recipe.source, f"no random shape in {MAX_DRAWS} draws satisfies the constraints",
                        "relax the constraints, or narrow the ranges of the parameters they compare")

    def _drawing_recipe(self):
        """The recipe, read once per build of the program (random_values draws many shapes)."""
        if self._recipe_for_drawing is None:
            self._recipe_for_drawing = self.recipe()
        return self._recipe_for_drawing

    # -- description ----------------------------------------------------------------------------

    def visibility(self) -> dict[str, Expr | None]:
        """Per parameter, the condition under which it affects the shape (None = always),
        inferred from the Switch / Index Switch / Menu Switch nodes of the graph."""
        if self._visibility is None:
            from geocode.nodes.visibility import infer_visibility

            rules = infer_visibility(self.tree)
            self._visibility = {p.name: rules.get(_input_of(p.name, self._inputs))
                                for p in self.parameters}
        return dict(self._visibility)

    def recipe(self):
        """The recipe `<programs>/<domain>.yaml`, checked against this program's parameters."""
        from geocode.recipe import Recipe

        return Recipe.load(recipe_path(self.domain), self.parameters, self.visibility())

    def manifest(self) -> dict:
        """What the steps without Blender know of the program: its parameters, their visibility
        rules, whether it hangs, and the fingerprint of its geometry (a changed program has
        another manifest, so training starts afresh: `geocode.paths.program_key`)."""
        rules = self.visibility()
        return {"domain": self.domain, "hangs": self.hangs, "geometry": self.fingerprint(), "parameters": [
            {"name": p.name, "kind": p.kind, "min": p.min, "max": p.max, "default": p.default,
             "description": p.description,
             "visible_if": None if rules[p.name] is None else str(rules[p.name])}
            for p in self.parameters]}

    def fingerprint(self) -> str:
        """A hash of the meshes at the defaults and at the all-min and all-max corners
        (vertices rounded to 1e-5, faces, part labels): three evaluations, and a change to
        the geometry almost always shows in one of them."""
        digest = hashlib.sha256()
        for values in ({}, {p.name: p.min for p in self.parameters}, {p.name: p.max for p in self.parameters}):
            mesh = self.evaluate(values)
            digest.update((np.round(mesh.vertices, 5) + 0.0).tobytes())   # + 0.0 turns -0.0 into 0.0
            digest.update(np.asarray(mesh.faces, dtype=np.int64).tobytes())
            digest.update(np.asarray(mesh.metadata["part"], dtype=np.int64).tobytes())
        return digest.hexdigest()[:16]

    def save_blend(self, path: str | os.PathLike) -> None:
        """Write the session (this program's object, its node tree and blocks) as a .blend
        that opens in Blender's Geometry Nodes editor."""
        import bpy

        from geocode.blender.scene import quiet_stdout

        self._ensure_alive()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        partial = path.parent / f".{path.stem}.partial.blend"
        try:
            # Blender's 'Info: Saved copy as' (at C level, or through sys.stdout when Python's
            # own stdout is captured) would break --json output
            with quiet_stdout(), contextlib.redirect_stdout(io.StringIO()):
                bpy.ops.wm.save_as_mainfile(filepath=str(partial), copy=True, check_existing=False)
            os.replace(partial, path)
        finally:
            partial.unlink(missing_ok=True)


class _Input:
    """One group input and the parameter(s) it stands for (a vector gives one per axis)."""

    def __init__(self, item, domain: str):
        self.name = item.name
        self.kind = _KINDS.get(item.socket_type)
        if self.kind is None:
            raise ValueError(f"programs/{domain}.py: input {item.name!r} has type "
                             f"{item.socket_type}; use bool, int, float or vector")
        self.parameters = self._parameters(item, domain)

    def _parameters(self, item, domain: str) -> list[Parameter]:
        if self.kind == "bool":
            return [Parameter(self.name, "bool", 0.0, 1.0, float(item.default_value),
                              item.description)]
        low, high = _decimal(item.min_value), _decimal(item.max_value)
        if abs(low) >= _UNBOUNDED or abs(high) >= _UNBOUNDED:
            raise ValueError(f"programs/{domain}.py: input {self.name!r} needs min= and max=")
        if self.kind == "vector":
            return [Parameter(f"{self.name}_{axis}", "float", low, high, _decimal(default),
                              item.description)
                    for axis, default in zip(AXES, item.default_value, strict=True)]
        return [Parameter(self.name, self.kind, low, high, _decimal(item.default_value),
                          item.description)]

    def socket_value(self, values: Mapping[str, float]):
        if self.kind == "vector":
            return tuple(float(values[f"{self.name}_{axis}"]) for axis in AXES)
        value = values[self.name]
        return {"bool": bool, "int": int, "float": float}[self.kind](value)


def _uniform(parameter, rng: np.random.Generator) -> float:
    """A value drawn uniformly over the parameter's range; ints and bools: each value alike."""
    if parameter.kind == "float":
        return float(rng.uniform(parameter.min, parameter.max))
    return float(rng.integers(round(parameter.min), round(parameter.max) + 1))


def _decimal(value: float) -> float:
    """Blender keeps socket ranges as float32 (0.6 -> 0.6000000238); give back the shortest
    decimal that rounds to the same float32 (0.6), the number the program was written with."""
    return float(np.format_float_positional(np.float32(value), unique=True, trim="-"))


def _program_inputs(tree, domain: str) -> list[_Input]:
    items = [item for item in tree.interface.items_tree
             if item.item_type == "SOCKET" and item.in_out == "INPUT"]
    return [_Input(item, domain) for item in items]


def _input_of(parameter: str, inputs: list[_Input]) -> str:
    for spec in inputs:
        if any(p.name == parameter for p in spec.parameters):
            return spec.name
    raise KeyError(parameter)


def _checked(parameter: Parameter, value) -> float:
    """The value as a float, or ValueError naming the parameter and its range."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    tolerance = 1e-9 * max(1.0, abs(parameter.max - parameter.min))
    in_range = parameter.min - tolerance <= number <= parameter.max + tolerance
    whole = parameter.kind == "float" or abs(number - round(number)) < 1e-6
    if not (in_range and whole):
        what = {"float": "a number", "int": "an integer", "bool": "0 or 1"}[parameter.kind]
        raise UserError(f"{parameter.name}={value!r} is invalid: give {what} in "
                        f"[{parameter.min:g}, {parameter.max:g}]")
    number = min(max(number, parameter.min), parameter.max)
    return number if parameter.kind == "float" else float(round(number))


def part_mesh(mesh: trimesh.Trimesh, *labels: int) -> trimesh.Trimesh:
    """The sub-mesh of the faces of an evaluated `mesh` labelled with any of `labels`."""
    faces = np.flatnonzero(np.isin(mesh.metadata["part"], labels))
    return mesh.submesh([faces], append=True)
