"""The dataset steps (workflow/rules/dataset.smk): sample, then export, sketch and points per
shard. Sampling is here, in pure Python; the other three run the blender/ and points modules.

Which shapes a dataset holds (docs/paper-numbers.md#programs-and-datasets): per-class
variations, constraints, visibility, dedup, seeds, and the sampling step that writes each
split's recipes.parquet (no bpy).

For every recipe parameter and every one of its value classes, N shapes per split: the other
recipe parameters are drawn uniformly over their value classes, this one is forced to its
class. A draw is rejected, and that shape redrawn, where a constraint fails, where the forced
parameter is invisible (its choice must take effect), where `accept` says no (e.g. a geometry
validator), or where the shape equals one already taken in any split (compared on the class
vector, invisible = -1, which is one-to-one with the label vector).

Randomness is counter-based: the draw of shape (domain, split, parameter, class, index) at
attempt `a` is a hash of those keys, the seed and the drawn parameter's name. So the same seed
gives the same dataset, a shape keeps its draw when other splits, variations or parameters
change (only its own recipe entry and dedup collisions matter), and the whole batch of a split
is drawn with a few vectorised numpy passes instead of one generator per shape.

Splits are sampled in the order test, val, train (then any other names, sorted): the test set
comes first so that it does not change when the training set grows.
"""

from __future__ import annotations

import hashlib
import logging
import shutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import DictConfig

from geocode import paths
from geocode.config import sketched_draws, split_variations
from geocode.meshio import write_text
from geocode.recipe import Recipe, load_recipe, load_recipes, save_recipes
from geocode.seeds import key_word

log = logging.getLogger("geocode.sample")

__all__ = [
    "SPLIT_ORDER",
    "SamplingError",
    "sample_dataset",
    "split_order",
    "assign_shards",
    "shape_hashes",
    "spread_subset",
    "split_sizes",
    "first_draws",
    "sample_step",
    "export_step",
    "sketch_step",
    "points_step",
]

SPLIT_ORDER = ("test", "val", "train")
REASONS = ("constraint", "invisible", "duplicate", "accept")
GOLDEN = np.uint64(0x9E3779B97F4A7C15)
MIX_1 = np.uint64(0xBF58476D1CE4E5B9)
MIX_2 = np.uint64(0x94D049BB133111EB)


class SamplingError(ValueError):
    """A (parameter, class) that cannot be sampled; one line naming it and the fix."""


def split_order(names) -> list[str]:
    known = [s for s in SPLIT_ORDER if s in names]
    return known + sorted(set(names) - set(SPLIT_ORDER))


def sample_dataset(
    recipe: Recipe,
    variations: Mapping[str, int],
    seed: int,
    domain: str,
    accept: Callable[[dict], bool] | None = None,
    max_tries: int = 1000,
) -> dict[str, pd.DataFrame]:
    """Recipes of every split, keyed in sampling order (see `split_order`).

    Columns: id (`<split>-<6 digits>`), shard (0; see `assign_shards`), forced (parameter name),
    forced_class (int), then one float64 column per recipe parameter (raw value). `accept`
    receives {recipe parameter: raw value} (others at their defaults) and may veto a shape.
    Each shape gets `max_tries` draws; a shape that exhausts them raises SamplingError.
    """
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    seen: set[bytes] = set()  # class vectors taken so far, across all splits
    out = {}
    for split in split_order(variations):
        count = variations[split]
        if not isinstance(count, (int, np.integer)) or count < 0:
            raise ValueError(f"variations.{split} must be a non-negative integer, got {count!r}")
        plan = _plan(recipe, split, int(count), int(seed), domain)
        out[split] = _SplitSampler(recipe, plan, accept, max_tries, seen).run()
    return out


# ---------------------------------------------------------------- counter-based randomness


def _mix64(z: np.ndarray) -> np.ndarray:
    """SplitMix64's finaliser: a bijection on uint64 with full avalanche (wraps by design)."""
    z = (z ^ (z >> np.uint64(30))) * MIX_1
    z = (z ^ (z >> np.uint64(27))) * MIX_2
    return z ^ (z >> np.uint64(31))


def _uniform_classes(
    shape_words: np.ndarray, name_keys: np.ndarray, n_values: np.ndarray
) -> np.ndarray:
    """(m,) shape words x (P, 2) per-parameter keys -> (m, P) class indices, uniform per column."""
    words = _mix64(_mix64(shape_words[:, None] ^ name_keys[None, :, 0]) ^ name_keys[None, :, 1])
    unit = (words >> np.uint64(11)).astype(np.float64) * 2.0**-53  # [0, 1)
    return np.minimum((unit * n_values).astype(np.int64), n_values - 1)


# ---------------------------------------------------------------- the plan of one split


@dataclass
class _Plan:
    split: str
    domain: str
    forced: np.ndarray  # (n,) column of the forced parameter
    forced_class: np.ndarray  # (n,)
    index: np.ndarray  # (n,) variation index within its (parameter, class)
    group_key: np.ndarray  # (n,) uint64 from (seed, domain, split, parameter, class)
    name_keys: np.ndarray  # (P, 2) uint64 from (seed, parameter name)


def _plan(recipe: Recipe, split: str, count: int, seed: int, domain: str) -> _Plan:
    groups = [(j, c) for j, p in enumerate(recipe.parameters) for c in range(p.n_values)]
    forced, forced_class = np.array(groups, dtype=np.int64).reshape(-1, 2).T
    group_key = [key_word(seed, domain, split, recipe.parameters[j].name, c) for j, c in groups]
    name_keys = [[key_word(seed, "draw", p.name, k) for k in range(2)] for p in recipe.parameters]
    return _Plan(
        split=split,
        domain=domain,
        forced=np.repeat(forced, count),
        forced_class=np.repeat(forced_class, count),
        index=np.tile(np.arange(count, dtype=np.int64), len(groups)),
        group_key=np.repeat(np.array(group_key, dtype=np.uint64), count),
        name_keys=np.array(name_keys, dtype=np.uint64),
    )


# ---------------------------------------------------------------- rejection sampling


class _SplitSampler:
    """Draws every planned shape of one split; failed shapes are redrawn with the next attempt."""

    def __init__(self, recipe: Recipe, plan: _Plan, accept, max_tries: int, seen: set[bytes]):
        self.recipe, self.plan, self.accept, self.max_tries, self.seen = (
            recipe,
            plan,
            accept,
            max_tries,
            seen,
        )
        n, width = len(plan.forced), len(recipe)
        self.values = np.full((n, width), np.nan)
        self.rejections = np.zeros((n, len(REASONS)), dtype=np.int64)
        self.n_values = np.array([p.n_values for p in recipe.parameters], dtype=np.int64)

    def run(self) -> pd.DataFrame:
        pending = np.arange(len(self.plan.forced))
        for attempt in range(self.max_tries):
            if len(pending) == 0:
                break
            pending = self._attempt(pending, attempt)
        if len(pending):
            raise self._failure(pending[0])
        return self._frame()

    def _attempt(self, rows: np.ndarray, attempt: int) -> np.ndarray:
        """Draw `rows` once; return the rows still without a shape."""
        classes = self._draw(rows, attempt)
        values = self._values(classes)
        frame = dict(zip(self.recipe.names, values.T, strict=True))
        visible = self.recipe.visibility_matrix(frame)
        constraint_ok = self.recipe.constraint_mask(frame)
        forced_visible = visible[np.arange(len(rows)), self.plan.forced[rows]]
        self.rejections[rows[~constraint_ok], 0] += 1
        self.rejections[rows[constraint_ok & ~forced_visible], 1] += 1
        # Canonical vector: class indices with -1 where invisible (one-to-one with the labels).
        keys = np.where(visible, classes, -1)
        still_pending = []
        for k in np.flatnonzero(constraint_ok & forced_visible):
            if not self._take(rows[k], keys[k].tobytes(), values[k]):
                still_pending.append(rows[k])
        failed = rows[~(constraint_ok & forced_visible)]
        return np.sort(np.concatenate([failed, np.array(still_pending, dtype=np.int64)]))

    def _draw(self, rows: np.ndarray, attempt: int) -> np.ndarray:
        plan = self.plan
        counter = (plan.index[rows].astype(np.uint64) << np.uint64(32)) | np.uint64(attempt)
        shape_words = _mix64(plan.group_key[rows] + counter * GOLDEN)
        classes = _uniform_classes(shape_words, plan.name_keys, self.n_values)
        classes[np.arange(len(rows)), plan.forced[rows]] = plan.forced_class[rows]
        return classes

    def _values(self, classes: np.ndarray) -> np.ndarray:
        return np.column_stack(
            [p.classes[classes[:, j]] for j, p in enumerate(self.recipe.parameters)]
        )

    def _take(self, row: int, key: bytes, values: np.ndarray) -> bool:
        if key in self.seen:
            self.rejections[row, 2] += 1
            return False
        if self.accept is not None and not self.accept(
            dict(zip(self.recipe.names, values.tolist(), strict=True))
        ):
            self.rejections[row, 3] += 1
            return False
        self.seen.add(key)
        self.values[row] = values
        return True

    def _frame(self) -> pd.DataFrame:
        plan, names = self.plan, self.recipe.names
        n = len(plan.forced)
        frame = pd.DataFrame(
            {
                "id": [f"{plan.split}-{i:06d}" for i in range(n)],
                "shard": np.zeros(n, dtype=np.int64),
                "forced": pd.Series(
                    np.array(names, dtype=object)[plan.forced] if n else [], dtype=object
                ),
                "forced_class": plan.forced_class.astype(np.int64),
            }
        )
        for j, name in enumerate(names):
            frame[name] = self.values[:, j].astype(np.float64)
        return frame

    def _failure(self, row: int) -> SamplingError:
        plan, recipe = self.plan, self.recipe
        parameter = recipe.parameters[plan.forced[row]]
        c = plan.forced_class[row]
        group = (plan.forced == plan.forced[row]) & (plan.forced_class == c)
        counts = self.rejections[group].sum(axis=0)
        detail = ", ".join(
            f"{count} {reason}" for reason, count in zip(REASONS, counts, strict=True) if count
        )
        return SamplingError(
            f"{plan.domain} {plan.split}: no shape with {parameter.name} = {parameter.classes[c]:g} "
            f"(class {c}, variation {plan.index[row]}) within {self.max_tries} tries (rejected: {detail}); "
            f"{_advice(REASONS[int(counts.argmax())], parameter, self.recipe)}"
        )


def _advice(reason: str, parameter, recipe: Recipe) -> str:
    if reason == "invisible":
        return (
            f"its visibility rule `{parameter.visible_if}` rarely or never holds: widen the recipe "
            f"ranges of {', '.join(sorted(parameter.visible_if.names()))} or drop {parameter.name}"
        )
    if reason == "constraint":
        return (
            "the constraints exclude this value: relax them or narrow the range of "
            + parameter.name
        )
    if reason == "duplicate":
        return "the recipe has too few distinct shapes for this many variations: lower data.variations or add classes"
    return "the shape validator rejects these shapes: narrow the range of " + parameter.name


# ---------------------------------------------------------------- after sampling


def assign_shards(frame: pd.DataFrame, n: int) -> pd.DataFrame:
    """A copy with `shard` = row position % n (neighbouring rows, often the same forced
    parameter, land on different shards, which balances the work)."""
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"number of shards must be a positive integer, got {n!r}")
    out = frame.copy()
    out["shard"] = np.arange(len(out), dtype=np.int64) % int(n)
    return out


def shape_hashes(recipe: Recipe, frame: pd.DataFrame) -> list[str]:
    """Hex digest of each row's canonical label vector (class indices, invisible = -1)."""
    classes = recipe.class_matrix(frame)
    existence = np.array(
        [-2 if p.existence_class is None else p.existence_class for p in recipe.parameters]
    )
    keys = np.where(classes == existence, -1, classes).astype(np.int64)
    return [hashlib.blake2b(row.tobytes(), digest_size=16).hexdigest() for row in keys]


def spread_subset(frame: pd.DataFrame, keep: int | None) -> pd.DataFrame:
    """At most `keep` rows, evenly spread over the frame so every forced parameter shows up."""
    if keep is None or len(frame) <= keep:
        return frame
    rows = np.unique(np.linspace(0, len(frame) - 1, keep).round().astype(int))
    return frame.iloc[rows].reset_index(drop=True)


def first_draws(ids: Sequence[str], sketched: tuple[int, int] | None) -> np.ndarray:
    """The positions in `ids` of the shapes drawn as sketches, `config.sketched_draws`: the first
    `first` of the `draws` draws of each (forced parameter, class). A shape's draw is its id's
    number modulo `draws`: the sample numbers each class's draws one after the other, and a
    subset (data.max_shapes) keeps the ids. All positions where None."""
    if sketched is None:
        return np.arange(len(ids))
    first, draws = sketched
    return np.flatnonzero([int(i.rsplit("-", 1)[-1]) % draws < first for i in ids])


def split_sizes(cfg: DictConfig, recipe: Recipe, domain: str, clouds: bool = True) -> dict[str, int]:
    """The shapes of each split as the sample step writes them, without sampling: one per
    variation of every parameter class, at most data.max_shapes (`clouds` false: the training
    shapes drawn as sketches)."""
    classes = sum(p.n_values for p in recipe.parameters)
    sizes = {split: classes * int(v) for split, v in split_variations(cfg, domain, clouds).items()}
    return {split: n if cfg.data.max_shapes.get(split) is None else min(n, cfg.data.max_shapes[split])
            for split, n in sizes.items()}


def sample_step(cfg: DictConfig) -> str:
    """The recipes of every split of cfg.domain: recipes.parquet, shards assigned."""
    domain = cfg.domain.name
    recipe = load_recipe(cfg)
    splits = sample_dataset(recipe, split_variations(cfg, domain), seed=cfg.seed, domain=domain)
    counts = []
    for split in paths.SPLITS:
        frame = spread_subset(splits[split], cfg.data.max_shapes[split])
        frame = assign_shards(frame, cfg.data.shards)
        save_split_recipes(paths.split_dir(cfg, domain, split), frame, paths.program_key(cfg, domain))
        counts.append(f"{split} {len(frame)}")
    summary = f"{domain}: " + ", ".join(counts) + " shapes"
    log.info(summary)
    return summary


def save_split_recipes(split_dir: Path, frame: pd.DataFrame, program: str) -> None:
    """Write a split's recipes and the key of the program they are for (`paths.program_stamp`).
    The shard jobs keep the shapes, drawings and clouds they find finished, so where the
    split's are from other recipes or another version of the program (its stamp), they are
    deleted first: a changed program is exported, drawn and sampled afresh."""
    recipes, stamp = paths.recipes_file(split_dir), paths.program_stamp(split_dir)
    same_program = not stamp.exists() or stamp.read_text().strip() == program
    same_recipes = recipes.exists() and load_recipes(recipes).equals(frame.reset_index(drop=True))
    if not (same_program and same_recipes):
        for name in paths.DERIVED:
            shutil.rmtree(split_dir / name, ignore_errors=True)
    save_recipes(frame, recipes)
    write_text(stamp, program + "\n")


def export_step(cfg: DictConfig, split: str, shard: int) -> None:
    """One shard of a split: the program's meshes, values, labels and part labels."""
    from geocode.blender.export import export_shard

    domain = cfg.domain.name
    export_shard(paths.split_dir(cfg, domain, paths.check_split(cfg, split)), shard, domain,
                 recipe=load_recipe(cfg))


def sketch_step(cfg: DictConfig, split: str, shard: int) -> None:
    """One shard of a split: a Freestyle sketch per shape and camera of `split_cameras`."""
    from geocode.blender.sketch import sketch_shard

    s = cfg.data.sketch
    split_dir = paths.split_dir(cfg, cfg.domain.name, paths.check_split(cfg, split))
    sketch_shard(split_dir, shard, cameras=split_cameras(s.cameras, split), size=s.size, elevation=s.elevation,
                 seed=cfg.seed, jitter=s.jitter, only=sketched_shapes(cfg, split))


def sketched_shapes(cfg: DictConfig, split: str):
    """Which of a split's shapes are drawn as sketches, as `sketch_shard`'s `only` takes it: the
    training split's first draws of each class (`config.sketched_draws`); None (all) for the
    other splits."""
    sketched = sketched_draws(cfg, cfg.domain.name) if split == "train" else None
    return None if sketched is None else (lambda ids: [ids[k] for k in first_draws(ids, sketched)])


def split_cameras(cameras, split: str) -> list:
    """The cameras a split is drawn from: all of them for the test split, the training cameras
    for the others (training and validation read no other view, and the simplified test
    copies are tested from the training cameras only: a third fewer drawings to render)."""
    return list(cameras) if split == "test" else [c for c in cameras if c.get("train", True)]


def points_step(cfg: DictConfig, split: str, shard: int) -> None:
    """One shard of a split: the farthest-point and random clouds of each shape."""
    from geocode.points import points_shard

    points_shard(paths.split_dir(cfg, cfg.domain.name, paths.check_split(cfg, split)), shard,
                 cfg.data.points, cfg.seed)
