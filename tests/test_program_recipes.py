"""The recipes of the real programs: they list only what they change, and give the same
classes as before ranges had one owner (digests of the class grids that the old recipes,
which repeated every range, gave; compared file against file when they were converted)."""

import hashlib

import numpy as np
import pytest
import yaml

from geocode.paths import recipe_path
from geocode.program import Program, registry

pytestmark = pytest.mark.blender
# table and chair re-recorded when they grew to real forms (issue 24: proportions, leg_style;
# sled base, casters, side panels; stretchers, thick side panels, a back post; an apron; a
# back curved in plan and an arched back; a D-shaped seat and a deeper crest rail)
GRID_BEFORE = {"vase": "8fe52aa2392fdc14", "chair": "0c8e34eef00a793f", "table": "356ab4314566b4b7"}


def grid_digest(recipe) -> str:
    """Names, kinds, class counts, class values and constraints, hashed."""
    h = hashlib.sha256()
    for p in recipe.parameters:
        h.update(f"{p.name}:{p.kind}:{p.n_classes}:".encode())
        h.update(np.round(p.classes, 9).tobytes())
    h.update(repr([str(c) for c in recipe.constraints]).encode())
    return h.hexdigest()[:16]


@pytest.mark.parametrize("domain", sorted(GRID_BEFORE))
def test_same_class_grid_as_before(domain):
    assert grid_digest(Program.load(domain).recipe()) == GRID_BEFORE[domain]


def test_no_recipe_repeats_its_programs_range():
    """A recipe gives min/max only to narrow the program's range (the program owns it)."""
    repeats = []
    for domain in registry():
        program = Program.load(domain)
        entries = yaml.safe_load(recipe_path(domain).read_text())["parameters"]
        for p in program.parameters:
            entry = entries.get(p.name) or {}
            repeats += [f"{domain}: {p.name}.{key}" for key, bound in (("min", p.min), ("max", p.max))
                        if entry.get(key) == bound]
    assert not repeats, f"remove what repeats the program's range: {', '.join(repeats)}"
