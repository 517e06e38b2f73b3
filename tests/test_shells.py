"""StyleShell: a sweep open at its path's start, closed at its end, with a wall."""

import numpy as np
import pytest

from geocode.nodes import Evaluator, Graph, rectangle_fillet, shell

pytestmark = pytest.mark.blender


def _cup(thickness=0.05, start=0.0, end=1.0):
    """A cone-like cup along the Z axis from z=start to z=end, half-width 1 -> 0.5."""
    g = Graph.new("probe")
    path = g.line((0, 0, start), (0, 0, end), count=9)
    profile = rectangle_fillet(g, width=2.0, height=2.0, roundness=1.0, resolution=3)["Curve"]
    mesh = shell(g, curve=path, profile_curve=profile, scale=1.0 - g.spline_factor() * 0.5,
                 thickness=thickness, label=3)["Mesh"]
    g.output("Geometry", "geometry", mesh)
    return Evaluator(g.tree).mesh()


@pytest.mark.parametrize("start, end", [(0.0, 1.0), (1.0, 0.0)])
def test_shell_is_open_at_the_start_and_closed_at_the_end(blender, start, end):
    cup = _cup(start=start, end=end)
    assert cup.is_watertight and set(cup.metadata["part"]) == {3}
    solid = np.pi / 3 * (1 + 0.5 + 0.25)  # the frustum's volume
    assert cup.volume < 0.25 * solid  # a wall around a cavity
    # the end is closed by a plate across the axis; nothing spans the opening at the start
    centres = cup.triangles_center
    radius = np.hypot(centres[:, 0], centres[:, 1])
    assert radius[np.abs(centres[:, 2] - end) < 0.07].min() < 0.25
    assert radius[np.abs(centres[:, 2] - start) < 0.07].min() > 0.8


def test_shell_wall_has_the_given_thickness(blender):
    thin, thick = _cup(thickness=0.02), _cup(thickness=0.06)
    assert thick.volume / thin.volume == pytest.approx(3.0, rel=0.1)
