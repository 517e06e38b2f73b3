"""The recipes of the real programs: they list only what they change, and give the same
classes as the recipes that repeated every range (the form before one owner per fact)."""

from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("bpy")

from geocode.config import recipe_path  # noqa: E402
from geocode.program import Program, registry  # noqa: E402
from geocode.recipe import Recipe  # noqa: E402

pytestmark = pytest.mark.blender
BEFORE = Path(__file__).parent / "data" / "recipes-before"


@pytest.mark.parametrize("domain", ["vase", "chair"])
def test_same_class_grid_as_before(domain):
    program = Program.load(domain)
    new = program.recipe()
    old = Recipe.load(BEFORE / f"{domain}.yaml", program.parameters, program.visibility())
    assert new.names == old.names
    for a, b in zip(new.parameters, old.parameters, strict=True):
        assert (a.kind, a.min, a.max, a.n_classes) == (b.kind, b.min, b.max, b.n_classes), a.name
        assert np.array_equal(a.classes, b.classes), a.name
    assert [str(c) for c in new.constraints] == [str(c) for c in old.constraints]


def test_no_recipe_repeats_its_programs_range():
    """A recipe gives min/max only to narrow the program's range (the program owns it)."""
    for domain in registry():
        program = Program.load(domain)
        entries = yaml.safe_load(recipe_path(domain).read_text())["parameters"]
        for p in program.parameters:
            entry = entries.get(p.name) or {}
            assert entry.get("min", p.min - 1) != p.min, f"{domain}: {p.name}.min repeats the program"
            assert entry.get("max", p.max + 1) != p.max, f"{domain}: {p.name}.max repeats the program"
