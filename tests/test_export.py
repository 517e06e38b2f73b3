"""Export of a shard: four files per shape, skip/redo behaviour, the done file; first with a
trimesh test double of the Program/Recipe contract, then with the real vase program."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import trimesh
import yaml

from geocode import meshio
from geocode.blender import export
from geocode.recipe import save_recipes
from geocode.steps.dataset import save_split_recipes


class Param:
    def __init__(self, name, kind, lo, hi, default):
        self.name, self.kind, self.min, self.max, self.default = name, kind, lo, hi, default


class TowerDouble:
    """Test double of a Program: a box on `legs` cylinders; part 0 = top, 1 = legs."""

    domain = "tower"
    parameters = [Param("height", "float", 0.5, 2.0, 1.0), Param("legs", "int", 1, 4, 1),
                  Param("round", "bool", 0, 1, 0)]

    def evaluate(self, values):
        v = {p.name: p.default for p in self.parameters} | dict(values)
        top = trimesh.creation.box((1.0, 1.0, 0.1)).apply_translation((0, 0, v["height"]))
        legs = [trimesh.creation.cylinder(0.05, v["height"], sections=8 + 8 * int(v["round"]))
                .apply_translation((0.4 * i - 0.6, 0, v["height"] / 2)) for i in range(int(v["legs"]))]
        mesh = trimesh.util.concatenate([top, *legs])
        mesh.metadata["part"] = np.repeat([0, 1], [len(top.faces), len(mesh.faces) - len(top.faces)])
        return mesh

    def random_values(self, rng):
        return {"height": float(rng.uniform(0.5, 2.0)), "legs": float(rng.integers(1, 5))}


class RecipeDouble:
    """Test double of a Recipe: learns height and legs; round stays at its default."""

    def full_values(self, values):
        return {"height": 1.0, "legs": 1.0, "round": 0.0} | dict(values)

    def labels(self, values):
        return {"height": (values["height"] - 0.5) / 1.5, "legs": values["legs"] - 1}


def _recipes(split_dir, rows):
    frame = pd.DataFrame(rows)
    frame.insert(0, "forced_class", 0)
    frame.insert(0, "forced", "height")
    frame.insert(0, "shard", [i % 2 for i in range(len(frame))])
    frame.insert(0, "id", [f"train-{i:06d}" for i in range(len(frame))])
    save_recipes(frame, split_dir / "recipes.parquet")
    return frame


def _check_shape(shapes, shape_id, program_parameters):
    mesh = meshio.read_obj(shapes / f"{shape_id}.obj")
    parts = np.load(shapes / f"{shape_id}.parts.npy")
    assert parts.dtype == np.int16 and parts.shape == (len(mesh.faces),)
    radius = np.linalg.norm(mesh.vertices, axis=1)
    assert radius.max() == pytest.approx(1.0, abs=1e-5)
    centre = (mesh.vertices.min(0) + mesh.vertices.max(0)) / 2
    assert np.abs(centre).max() < 1e-5
    raw = yaml.safe_load((shapes / f"{shape_id}.yaml").read_text())
    assert set(raw) == {p.name for p in program_parameters}
    return mesh, parts, raw, yaml.safe_load((shapes / f"{shape_id}.labels.yaml").read_text())


def test_export_shard_with_a_double(tmp_path):
    _recipes(tmp_path, [{"height": 0.5 + 0.3 * i, "legs": 1.0 + i % 4} for i in range(5)])
    done = export.export_shard(tmp_path, 0, "tower", program=TowerDouble(), recipe=RecipeDouble())
    ids = done.read_text().split()
    assert ids == ["train-000000", "train-000002", "train-000004"]
    shapes = tmp_path / "shapes"
    assert sorted(p.name for p in shapes.iterdir()) == sorted(
        f"{i}{s}" for i in ids for s in export.SUFFIXES)                   # shard 0 only, no temps
    mesh, parts, raw, labels = _check_shape(shapes, "train-000002", TowerDouble.parameters)
    assert raw == {"height": pytest.approx(1.1), "legs": 3, "round": False}
    assert labels == {"height": pytest.approx(0.4), "legs": 2.0}
    assert (parts == 1).sum() == len(mesh.faces) - 12

    # A rerun skips complete shapes and redoes a partial one.
    keep = shapes / "train-000000.obj"
    stamp = keep.stat().st_mtime_ns
    (shapes / "train-000004.parts.npy").unlink()
    export.export_shard(tmp_path, 0, "tower", program=TowerDouble(), recipe=RecipeDouble())
    assert keep.stat().st_mtime_ns == stamp
    assert export.is_complete(shapes, "train-000004")


def test_a_changed_program_or_recipe_clears_the_split(tmp_path):
    """The shard jobs keep what they find finished, so new recipes or another version of the
    program (its key) must clear the shapes, drawings, clouds and done-files made before."""
    frame = _recipes(tmp_path, [{"height": 0.5 + 0.3 * i, "legs": 1.0} for i in range(3)])
    save_split_recipes(tmp_path, frame, "key-a")
    export.export_shard(tmp_path, 0, "tower", program=TowerDouble(), recipe=RecipeDouble())
    (tmp_path / "sketches").mkdir()
    kept = tmp_path / "shapes" / "train-000000.obj"

    save_split_recipes(tmp_path, frame, "key-a")            # the same: everything kept
    assert kept.exists() and (tmp_path / "sketches").exists()
    save_split_recipes(tmp_path, frame, "key-b")            # another program
    assert not any((tmp_path / name).exists() for name in ("shapes", "sketches", "done"))
    assert (tmp_path / "program.txt").read_text().strip() == "key-b"

    export.export_shard(tmp_path, 0, "tower", program=TowerDouble(), recipe=RecipeDouble())
    save_split_recipes(tmp_path, frame.assign(legs=2.0), "key-b")   # other recipes
    assert not kept.exists()


def test_export_is_deterministic(tmp_path):
    _recipes(tmp_path / "a", [{"height": 1.3, "legs": 2.0}])
    _recipes(tmp_path / "b", [{"height": 1.3, "legs": 2.0}])
    for d in ("a", "b"):
        export.export_shard(tmp_path / d, 0, "tower", program=TowerDouble(), recipe=RecipeDouble())
    for suffix in export.SUFFIXES:
        name = f"shapes/train-000000{suffix}"
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


def test_bad_part_labels_fail_and_leave_no_done_file(tmp_path):
    class NoParts(TowerDouble):
        def evaluate(self, values):
            mesh = super().evaluate(values)
            mesh.metadata["part"] = mesh.metadata["part"][:-1]
            return mesh

    _recipes(tmp_path, [{"height": 1.0, "legs": 1.0}])
    with pytest.raises(ValueError, match="part labels"):
        export.export_shard(tmp_path, 0, "tower", program=NoParts(), recipe=RecipeDouble())
    assert not (tmp_path / "done").exists()


def test_missing_columns_named(tmp_path):
    pd.DataFrame({"id": ["train-000000"]}).to_parquet(tmp_path / "recipes.parquet")
    with pytest.raises(ValueError, match="'shard'.*sample step"):
        list(export.shard_rows(tmp_path / "recipes.parquet", 0))


def _vase():
    """The real vase program and its recipe."""
    program = export.load_program("vase")
    return program, program.recipe()


@pytest.mark.blender
def test_export_real_vase(tmp_path):
    program, recipe = _vase()
    rows = export.random_rows(program, 3, seed=3)
    learned = [p.name for p in recipe.parameters]
    _recipes(tmp_path, [{k: v[k] for k in learned} for _, v in rows])
    done = export.export_shard(tmp_path, 0, "vase", program=program, recipe=recipe)
    for shape_id in done.read_text().split():
        mesh, parts, raw, labels = _check_shape(tmp_path / "shapes", shape_id, program.parameters)
        assert set(labels) == set(learned)
        assert all(-1 <= x <= max(1, p.max - p.min) for p, x in
                   zip(recipe.parameters, labels.values(), strict=True))
