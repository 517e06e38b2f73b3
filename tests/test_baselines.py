"""The nearest-training-shape baseline of the tables (`steps.evaluate.nearest_rows`): test
shapes stand in the program's frame, as the network's answers do, so the baseline may not turn
a training shape onto them (a real shape's retrieval may: its front is unknown)."""

from __future__ import annotations

import math

import numpy as np
import trimesh

from geocode import paths
from geocode.config import compose
from geocode.meshio import write_obj
from geocode.points import make_clouds, save_clouds
from geocode.reconstruct.retrieval import TrainingShapes
from geocode.steps.evaluate import NEAREST, nearest_rows


def long_box(turn: float) -> trimesh.Trimesh:
    box = trimesh.creation.box(extents=(1.6, 0.4, 0.3))
    box.apply_transform(trimesh.transformations.rotation_matrix(turn, (0, 0, 1)))
    return box


def test_the_tables_nearest_shape_is_not_turned_onto_a_test_shape(tmp_path):
    cfg = compose(["profile=smoke", "domain=vase", f"paths.data={tmp_path}"])
    train = paths.split_dir(cfg, "vase", "train")
    turned = long_box(math.pi / 2)                    # the only training shape: the test box, turned
    write_obj(paths.shape_file(paths.shapes_dir(train), "t0"), turned)
    save_clouds(paths.cloud_file(train, "t0"), make_clouds(turned, surface=3000, fps=300, random=300,
                                                           rng=np.random.default_rng(0)))
    test = long_box(0.0)

    [row] = nearest_rows(cfg, "vase", {"s0": test})
    turned_match = TrainingShapes.from_split(train).nearest(test, n=2000)   # what a real shape gets

    assert row["condition"] == row["modality"] == NEAREST and row["id"] == "s0"
    assert turned_match.turn != 0.0 and turned_match.chamfer < 1e-3       # a quarter-turn finds the box
    assert row["chamfer"] > 20 * turned_match.chamfer                      # the tables' baseline may not
