"""The fit to a drawing (`geocode.sketchfit`): its camera coordinates and framing, and the
search recovering a known camera and parameter from drawings rendered by `linedraw`."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from geocode.fit import Start
from geocode.linedraw import Outline, View, drawing_distance, render, strokes
from geocode.sketchfit import CameraSpace, bounding_box, fit_drawing, framed, mean_curve

DOMAIN = "table"


def test_camera_space_starts_at_its_view_and_spans_the_ranges():
    start = View(40.0, 30.0, 0.0, 1.2, (3.0, -2.0))
    space = CameraSpace(start)
    assert space.view(space.x0()) == View(40.0, 30.0, 0.0, pytest.approx(1.2), (3.0, -2.0))
    low, high = space.view(np.zeros(6)), space.view(np.ones(6))
    assert (low.azimuth, high.azimuth) == (-20.0, 100.0)
    assert (low.elevation, high.elevation) == (0.0, 60.0)
    assert (low.roll, high.roll) == (-10.0, 10.0)
    assert low.scale == pytest.approx(1.2 / 1.4) and high.scale == pytest.approx(1.2 * 1.4)


def test_framing_puts_the_strokes_on_the_targets_box():
    box = trimesh.creation.box((0.8, 0.6, 1.0))
    outline = Outline(box.vertices, box.faces)
    target = strokes(outline, View(30.0, 20.0, scale=0.8, offset=(10.0, -6.0)))
    guess = View(30.0, 20.0)
    view = framed(guess, strokes(outline, guess), target)
    assert view.scale == pytest.approx(0.8, abs=0.02)
    assert view.offset == pytest.approx((10.0, -6.0), abs=1.0)
    (c0, e0), (c1, e1) = bounding_box(strokes(outline, view)), bounding_box(target)
    assert np.abs(c0 - c1).max() <= 1 and np.abs(e0 - e1).max() <= 2


def test_mean_curve_holds_each_fits_last_value():
    assert mean_curve([[3.0, 2.0, 1.0], [4.0]], points=(1, 3)) == {1: 3.5, 3: 2.5}


def shape_values(program, recipe, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    while True:
        values = program.random_values(rng)
        if recipe.satisfies(values):
            return values


def drawing_of(program, values, view: View) -> np.ndarray:
    from geocode.meshio import normalise_unit_sphere

    return render(normalise_unit_sphere(program.evaluate(values)), view)


@pytest.mark.blender
def test_fit_recovers_a_known_camera(program):
    """The true shape, drawn from an unguessed view (azimuth 50, elevation 22, scaled and
    shifted): the fit, from the camera guesses, finds that view to a few degrees and draws
    within a pixel of the drawing."""
    recipe = program.recipe()
    values = shape_values(program, recipe, 5)
    truth = View(50.0, 22.0, 0.0, 1.1, (4.0, -3.0))
    drawing = drawing_of(program, values, truth)
    fixed = {p.name: [values[p.name]] for p in recipe.parameters if p.kind != "float"}
    result = fit_drawing(program, recipe, [Start(values, fixed)], drawing, budget=160, seed=0,
                         guesses=((35.0, 30.0), (-35.0, 30.0), (90.0, 10.0)))
    assert result.after < 1.0 < result.before
    assert abs(result.camera.azimuth - 50.0) < 6 and abs(result.camera.elevation - 22.0) < 6
    assert result.camera.scale == pytest.approx(1.1, abs=0.08)
    assert result.evaluations <= 160 and len(result.curve) == result.evaluations


@pytest.mark.blender
def test_fit_recovers_a_changed_parameter(program):
    """The true camera, one continuous parameter of the start moved by a third of its range:
    the fit moves it back most of the way and the drawing distance falls."""
    recipe = program.recipe()
    values = shape_values(program, recipe, 7)
    view = View(35.0, 30.0)
    drawing = drawing_of(program, values, view)
    reference = strokes(Outline(*_mesh(program, values)), view)
    chosen = None
    for p in recipe.parameters:   # the first float parameter whose change shows in the drawing
        if p.kind != "float":
            continue
        moved = dict(values, **{p.name: _moved(values[p.name], p)})
        if recipe.satisfies(moved) and drawing_distance(_drawing(program, moved, view), reference) > 1.0:
            chosen = p
            break
    assert chosen is not None
    fixed = {q.name: [values[q.name]] for q in recipe.parameters if q.kind != "float"}
    result = fit_drawing(program, recipe, [Start(moved, fixed)], drawing, budget=200, seed=0,
                         guesses=((35.0, 30.0),))
    assert result.after < 0.5 * result.before
    error = abs(result.values[chosen.name] - values[chosen.name])
    assert error < 0.5 * abs(moved[chosen.name] - values[chosen.name])


def _moved(value: float, p) -> float:
    third = (p.max - p.min) / 3
    return value + third if value + third <= p.max else value - third


def _mesh(program, values):
    from geocode.meshio import normalise_unit_sphere

    mesh = normalise_unit_sphere(program.evaluate(values))
    return mesh.vertices, mesh.faces


def _drawing(program, values, view):
    return strokes(Outline(*_mesh(program, values)), view)
