"""Recipes: manifest loading, validation messages, classes, labels and their round trips."""

import json

import numpy as np
import pandas as pd
import pytest

from geocode.expr import parse
from geocode.recipe import Parameter, Recipe, RecipeError, load_manifest

PARAMETERS = [
    Parameter("height", "float", 0.5, 2.0, 1.0, "overall height"),
    Parameter("width", "float", 0.2, 1.0, 0.6),
    Parameter("has_handle", "bool", 0, 1, 0),
    Parameter("handle_size", "float", 0.0, 0.3, 0.1),
    Parameter("legs", "int", 0, 6, 4),
    Parameter("leg_thickness", "float", 0.01, 0.1, 0.05),
]
VISIBILITY = {
    "height": None,
    "width": None,
    "has_handle": None,
    "handle_size": parse("has_handle"),
    "legs": None,
    "leg_thickness": parse("legs > 0"),
}
GOOD = """\
parameters:
  legs: {min: 0, max: 4}
  height: {min: 0.5, max: 1.5, samples: 5}
  has_handle:
  handle_size: {min: 0.0, max: 0.3, samples: 4}
  leg_thickness: {min: 0.02, max: 0.1, samples: 3}
constraints:
  - "width >= 0.3 * height"
"""


def write(tmp_path, text, name="vase.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture
def recipe(tmp_path):
    return Recipe.load(write(tmp_path, GOOD), PARAMETERS, VISIBILITY)


def test_load_keeps_program_order_and_builds_classes(recipe):
    assert recipe.names == ["height", "has_handle", "handle_size", "legs", "leg_thickness"]
    height = recipe["height"]
    assert np.allclose(height.classes, [0.5, 0.75, 1.0, 1.25, 1.5])  # both ends included
    assert height.n_classes == 5 and not height.has_existence
    assert list(recipe["legs"].classes) == [0, 1, 2, 3, 4]
    assert list(recipe["has_handle"].classes) == [0, 1]
    size = recipe["handle_size"]
    assert size.has_existence and size.n_classes == 5 and size.existence_class == 4
    assert [str(c) for c in recipe.constraints] == ["width >= 0.3 * height"]


def test_describe_and_to_dict(recipe):
    shown = {p["name"]: p for p in recipe.describe()}
    assert shown["handle_size"] == {
        "name": "handle_size",
        "kind": "float",
        "min": 0.0,
        "max": 0.3,
        "default": 0.1,
        "classes": 5,
        "visible_if": "has_handle",
    }
    assert json.loads(json.dumps(recipe.to_dict()))["constraints"] == ["width >= 0.3 * height"]


def test_labels_classes_and_values(recipe):
    values = {"height": 1.25, "has_handle": 0, "handle_size": 0.2, "legs": 3, "leg_thickness": 0.06}
    full = recipe.full_values(values)
    assert full["width"] == 0.6 and full["height"] == 1.25
    labels = recipe.labels(values)
    assert labels == pytest.approx(
        {"height": 0.75, "has_handle": 0.0, "handle_size": -1.0, "legs": 3.0, "leg_thickness": 0.5}
    )
    indices = recipe.class_indices(values)
    assert indices == {
        "height": 3,
        "has_handle": 0,
        "handle_size": 4,
        "legs": 3,
        "leg_thickness": 1,
    }
    back = recipe.values_from_classes(indices)
    assert back["handle_size"] == 0.1  # existence class -> the default
    assert back["height"] == 1.25 and back["legs"] == 3
    assert recipe.labels({"legs": 0})["leg_thickness"] == -1.0
    with pytest.raises(ValueError, match="unknown parameter 'colour'"):
        recipe.full_values({"colour": 1})


def test_normalisation_round_trip_every_class(recipe):
    """values -> labels -> classes -> values, over every combination of a few classes."""
    rng = np.random.default_rng(0)
    classes = np.column_stack([rng.integers(0, p.n_values, 300) for p in recipe.parameters])
    values = recipe.classes_to_values(classes)
    frame = pd.DataFrame(values, columns=recipe.names)
    labels = recipe.label_matrix(frame)
    visible = recipe.visibility_matrix(frame)
    expected = np.where(visible, classes, [p.existence_class or 0 for p in recipe.parameters])
    assert np.array_equal(recipe.labels_to_classes(labels), expected)
    assert np.array_equal(recipe.class_matrix(frame), expected)
    assert np.allclose(recipe.classes_to_labels(expected), labels)
    back = recipe.classes_to_values(expected)
    assert np.allclose(back[visible], values[visible])
    for i in range(0, 300, 37):  # the dict versions agree with the matrices
        row = dict(zip(recipe.names, values[i], strict=True))
        assert list(recipe.labels(row).values()) == pytest.approx(labels[i])
        assert list(recipe.class_indices(row).values()) == list(expected[i])
    assert 0.0 <= labels[visible].min() and labels.max() <= 4.0


def test_constraint_mask(recipe):
    frame = pd.DataFrame({n: [2.5, 1.0] if n == "height" else [0, 0] for n in recipe.names})
    assert list(recipe.constraint_mask(frame)) == [False, True]  # width defaults to 0.6
    assert recipe.satisfies({"height": 1.0}) and not recipe.satisfies({"height": 2.5})


def test_class_index_checks(recipe):
    with pytest.raises(ValueError, match="handle_size"):
        recipe.classes_to_values([0, 0, 5, 0, 0])
    with pytest.raises(ValueError, match="class columns"):
        recipe.classes_to_values([0, 0])


BAD = [
    (
        "parameters:\n  height: {min: 1.6, max: 1.0, samples: 3}\n",
        "parameters.height.min",
        "greater than max",
    ),
    (
        "parameters:\n  height: {min: 0.5, max: 1.0, samples: 1}\n",
        "parameters.height.samples",
        "below 2",
    ),
    ("parameters:\n  height: {min: 0.5, max: 1.0}\n", "parameters.height.samples", "missing"),
    (
        "parameters:\n  height: {min: 0.5, max: 1.0, samples: 2.5}\n",
        "parameters.height.samples",
        "not an integer",
    ),
    (
        "parameters:\n  hieght: {min: 0.5, max: 1.0, samples: 3}\n",
        "parameters.hieght",
        "unknown parameter",
    ),
    (
        "parameters:\n  height: {min: 0.1, max: 1.0, samples: 3}\n",
        "parameters.height.min",
        "outside the program",
    ),
    ("parameters:\n  legs: {min: 0, max: 9}\n", "parameters.legs.max", "outside the program"),
    ("parameters:\n  legs: {min: 7}\n", "parameters.legs.min", "outside the program"),
    ("parameters:\n  height:\n", "parameters.height.samples", "missing for a float"),
    ("parameters:\n  legs: {min: 0, max: 2.5}\n", "parameters.legs.max", "whole number"),
    (
        "parameters:\n  legs: {min: 0, max: 3, samples: 4}\n",
        "parameters.legs.samples",
        "int parameter",
    ),
    ("parameters:\n  legs: {min: '0', max: 3}\n", "parameters.legs.min", "not a finite number"),
    ("parameters:\n  legs: {min: true, max: 3}\n", "parameters.legs.min", "is a bool"),
    ("parameters:\n  legs: {min: 0, max: 3, step: 1}\n", "parameters.legs.step", "unknown key"),
    ("parameters:\n  legs: [0, 3]\n", "parameters.legs", "not a mapping"),
    (
        "parameters:\n  height: {min: 1.0, max: 1.0, samples: 3}\n",
        "parameters.height.max",
        "equals min",
    ),
    ("parameters: {}\n", "parameters", "missing, empty"),
    ("constraints: []\n", "parameters", "missing, empty"),
    ("- a\n- b\n", "(top level)", "not a mapping"),
    ("parameters:\n  legs: {min: 0, max: 3}\nconstrains: []\n", "constrains", "unknown key"),
    (
        "parameters:\n  legs: {min: 0, max: 3}\nconstraints: 'legs > 1'\n",
        "constraints",
        "not a list",
    ),
    (
        "parameters:\n  legs: {min: 0, max: 3}\nconstraints: ['legs >']\n",
        "constraints[0]",
        "not valid syntax",
    ),
    (
        "parameters:\n  legs: {min: 0, max: 3}\nconstraints: ['lges > 1']\n",
        "constraints[0]",
        "unknown name 'lges'",
    ),
    (
        "parameters:\n  legs: {min: 0, max: 3}\nconstraints: ['__import__(\"os\")']\n",
        "constraints[0]",
        "function calls",
    ),
    ("parameters:\n  legs: {min: 0, max: 3}\nconstraints: [3]\n", "constraints[0]", "not a string"),
    (
        "parameters:\n  legs: {min: 0, max: 3}\n  legs: {min: 0, max: 2}\n",
        "not valid YAML",
        "given twice",
    ),
    ("parameters:\n  legs: {min: 0, max: 3\n", "not valid YAML", "fix the syntax"),
]


@pytest.mark.parametrize("text, field, problem", BAD)
def test_bad_recipe_one_line_message(tmp_path, text, field, problem):
    path = write(tmp_path, text)
    with pytest.raises(RecipeError) as info:
        Recipe.load(path, PARAMETERS, VISIBILITY)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert field in message and problem in message
    assert "; " in message  # every message ends with the fix


def test_missing_recipe_file(tmp_path):
    with pytest.raises(RecipeError, match="file not found"):
        Recipe.load(tmp_path / "none.yaml", PARAMETERS, VISIBILITY)


def test_recipe_may_repeat_program_range_with_rounding(tmp_path):
    path = write(tmp_path, "parameters:\n  height: {min: 0.4999999999999, max: 2.0, samples: 2}\n")
    assert Recipe.load(path, PARAMETERS, VISIBILITY)["height"].min == 0.5


def test_ranges_come_from_the_program(tmp_path):
    """A recipe entry without min/max takes the program's range; min alone narrows one end."""
    text = "parameters:\n  height: {samples: 4}\n  legs: {min: 2}\n  has_handle:\n"
    recipe = Recipe.load(write(tmp_path, text), PARAMETERS, VISIBILITY)
    assert np.allclose(recipe["height"].classes, [0.5, 1.0, 1.5, 2.0])
    assert list(recipe["legs"].classes) == [2, 3, 4, 5, 6]
    assert list(recipe["has_handle"].classes) == [0, 1]


def test_wider_range_says_how_to_fix_it(tmp_path):
    path = write(tmp_path, "parameters:\n  height: {max: 3.0, samples: 4}\n")
    with pytest.raises(RecipeError) as info:
        Recipe.load(path, PARAMETERS, VISIBILITY)
    assert str(info.value) == (
        f"{path}: parameters.height.max: 3 is outside the program's range [0.5, 2]; a recipe may "
        "narrow the range, never widen it: give a max inside it, or leave max out to take the "
        "program's (widen the range in the program itself)"
    )


def manifest(parameters, visibility):
    return {
        "domain": "vase",
        "parameters": [
            {
                "name": p.name,
                "kind": p.kind,
                "min": p.min,
                "max": p.max,
                "default": p.default,
                "description": p.description,
                "visible_if": None if visibility[p.name] is None else str(visibility[p.name]),
            }
            for p in parameters
        ],
    }


def test_load_manifest(tmp_path):
    path = tmp_path / "vase.manifest.json"
    path.write_text(json.dumps(manifest(PARAMETERS, VISIBILITY)))
    parameters, visibility = load_manifest(path)
    assert parameters == PARAMETERS
    assert visibility == VISIBILITY


@pytest.mark.parametrize(
    "change, field",
    [
        (lambda m: m["parameters"][0].update(kind="vector"), "parameters.height.kind"),
        (lambda m: m["parameters"][0].update(default=5.0), "parameters.height"),
        (lambda m: m["parameters"][1].pop("max"), "parameters.width.max"),
        (lambda m: m["parameters"][1].pop("name"), "parameters[1].name"),
        (
            lambda m: m["parameters"][3].update(visible_if="has_handel"),
            "parameters.handle_size.visible_if",
        ),
        (lambda m: m["parameters"].append(dict(m["parameters"][0])), "parameters.height"),
        (lambda m: m.pop("parameters"), "parameters"),
    ],
)
def test_bad_manifest(tmp_path, change, field):
    data = manifest(PARAMETERS, VISIBILITY)
    change(data)
    path = tmp_path / "vase.manifest.json"
    path.write_text(json.dumps(data))
    with pytest.raises(RecipeError) as info:
        load_manifest(path)
    assert str(info.value).startswith(f"{path}: {field}") and "\n" not in str(info.value)


def test_missing_manifest(tmp_path):
    with pytest.raises(RecipeError, match="build the program"):
        load_manifest(tmp_path / "none.json")
