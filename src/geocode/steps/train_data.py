"""Training data: a split's clouds, sketches and class labels in memory, items, a DataModule.

Layout (docs/design.md): <root>/<split>/recipes.parquet, points/<id>.npz (fps, random),
sketches/<id>_<camera>.png. Labels are the recipe's class indices (the existence class where
the parameter is invisible), computed for the whole split at once (`Recipe.class_matrix`).

Sketch convention: float32 (1, H, W) in [0, 1], white background = 1, black strokes = 0
(the PNG / 255, not inverted). Stroke dilation is a min filter, erosion a max filter.
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytorch_lightning as pl
import torch
import torch.nn.functional as F
from PIL import Image
from torch.utils.data import DataLoader, Dataset

from geocode import paths
from geocode.errors import UserError, one_line
from geocode.models.module import MODALITIES
from geocode.points import eval_pick
from geocode.seeds import key_word

IO_THREADS = 8  # file reads release the GIL (zlib, PNG decoding)


# ---------------------------------------------------------------- files


def load_sketch(path: str | Path) -> np.ndarray:
    """A sketch PNG as float32 (1, H, W) in [0, 1] (white 1, strokes 0)."""
    return load_sketch_u8(path)[None].astype(np.float32) / 255.0


def load_sketch_u8(path: str | Path) -> np.ndarray:
    """A sketch PNG as uint8 (H, W); ValueError naming the file when missing or broken."""
    try:
        with Image.open(path) as im:
            return np.asarray(im.convert("L"), dtype=np.uint8)
    except (OSError, ValueError) as exc:
        raise UserError(path, f"not a readable sketch PNG ({one_line(exc)})",
                        "delete it and rerun the sketch step") from None


def _load_npz(path: Path) -> tuple[np.ndarray, np.ndarray]:
    from geocode.points import load_clouds

    clouds = load_clouds(path)
    missing = {"fps", "random"} - set(clouds)
    if missing:
        raise UserError(path, f"no {sorted(missing)[0]!r} cloud in it", "delete it and rerun the points step")
    return clouds["fps"].astype(np.float32), clouds["random"].astype(np.float32)


# ---------------------------------------------------------------- a split in memory


@dataclass
class SplitData:
    """One split, loaded once. Shapes: fps (n, F, 3), random (n, R, 3) float32,
    sketches {camera: (s, H, W) uint8} of the shapes at `sketch_rows` (s,), labels (n, P) int64."""

    ids: list[str]
    fps: np.ndarray
    random: np.ndarray
    sketches: dict[str, np.ndarray]
    labels: np.ndarray
    sketch_rows: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)


def load_split(split_dir: str | Path, recipe, cameras: Sequence[str],
               sketched: tuple[int, int] | None = None) -> SplitData:
    """Read a split folder: labels from recipes.parquet, clouds and sketches in parallel; the
    sketches of the first draws of each parameter class only, where `sketched` (first, draws)
    is given (`steps.dataset.first_draws`)."""
    from geocode.recipe import load_recipes
    from geocode.steps.dataset import first_draws

    split_dir = Path(split_dir)
    frame = load_recipes(paths.recipes_file(split_dir))
    ids = [str(i) for i in frame["id"]]
    if not ids:
        raise UserError(paths.recipes_file(split_dir), "no shapes in this split", "sample more")
    labels = recipe.class_matrix(frame).astype(np.int64)  # (n, P)
    rows = first_draws(ids, sketched)
    with ThreadPoolExecutor(IO_THREADS) as pool:
        clouds = list(pool.map(_load_npz, [paths.cloud_file(split_dir, i) for i in ids]))
        sketches = {
            cam: np.stack(list(pool.map(load_sketch_u8, [paths.sketch_file(split_dir, ids[r], cam) for r in rows])))
            for cam in cameras
        }
    fps = np.stack([c[0] for c in clouds])  # (n, F, 3)
    rand = np.stack([c[1] for c in clouds])  # (n, R, 3)
    return SplitData(ids, fps, rand, sketches, labels, rows)


# ---------------------------------------------------------------- items


@dataclass(frozen=True)
class SketchAugment:
    """Training-only sketch augmentation: horizontal flip with p `flip`; then stroke
    dilation (min filter, p `dilate`) or erosion (max filter, p `erode`), `kernel` wide."""

    flip: float = 0.5
    dilate: float = 0.25
    erode: float = 0.25
    kernel: int = 3

    def __call__(self, x: torch.Tensor, gen: torch.Generator | None = None) -> torch.Tensor:
        """Shapes: x (1, H, W) in [0, 1] -> (1, H, W)."""
        u = torch.rand(2, generator=gen)
        if u[0] < self.flip:
            x = x.flip(-1)
        pad = self.kernel // 2
        if u[1] < self.dilate:  # dark strokes grow: min filter
            x = -F.max_pool2d(-x[None], self.kernel, stride=1, padding=pad)[0]
        elif u[1] < self.dilate + self.erode:  # dark strokes shrink: max filter
            x = F.max_pool2d(x[None], self.kernel, stride=1, padding=pad)[0]
        return x


@dataclass(frozen=True)
class PointAugment:
    """Training-only cloud augmentation (no rotation: every shape is in its canonical pose).
    Each axis scaled by a factor in [1 - `scale`, 1 + `scale`]; Gaussian jitter of std
    `jitter` clipped at 3 std; a fraction in [0, `dropout`] of the points replaced by copies
    of kept ones (the cloud keeps its size and its surface)."""

    jitter: float = 0.0
    scale: float = 0.0
    dropout: float = 0.0

    def __call__(self, points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Shapes: points (N, 3) -> (N, 3) float32."""
        out = points * rng.uniform(1 - self.scale, 1 + self.scale, 3)
        if self.jitter > 0:
            out = out + np.clip(rng.normal(0, self.jitter, out.shape), -3 * self.jitter, 3 * self.jitter)
        n_drop = int(rng.uniform(0, self.dropout) * len(out))
        if n_drop:
            order = rng.permutation(len(out))
            out[order[:n_drop]] = out[rng.choice(order[n_drop:], n_drop)]
        return out.astype(np.float32)


class ShapeItems(Dataset):
    """Items of one split: {"points": (F + n_random, 3), "labels": (P,), "sketch": (1, H, W),
    "sketch_labels": (P,)}, with only the `modalities` asked for.

    An item per cloud, or per sketched shape where the items carry no clouds. Where the split
    draws fewer shapes as sketches than it has clouds (`SplitData.sketch_rows`), item i's sketch
    is of sketched shape i mod s: each sketch comes n / s times an epoch, with its own labels.

    Training: a fresh draw of n_random random points and a random camera of `cameras` per
    item, plus sketch and cloud augmentation, from torch's generator (which `train` seeds
    with the config's seed, workers included). Evaluation: the fixed draw of `eval_cloud`
    under `seed`, cameras[0], no augmentation.
    """

    def __init__(
        self,
        data: SplitData,
        n_random: int,
        cameras: Sequence[str],
        train: bool,
        augment: SketchAugment | None = None,
        point_augment: PointAugment | None = None,
        modalities: Sequence[str] = MODALITIES,
        seed: int = 0,
    ) -> None:
        self.data = data
        self.n_random = n_random
        self.cameras = list(cameras)
        self.train = train
        self.augment = augment if train else None
        self.point_augment = point_augment if train else None
        self.modalities = set(modalities)
        if not train:
            total = data.random.shape[1]
            self.picks = np.stack([eval_pick(total, n_random, seed, i) for i in data.ids])  # (n, n_random)

    def __len__(self) -> int:
        return len(self.data) if "points" in self.modalities else len(self.data.sketch_rows)

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        d = self.data
        if self.train:
            pick = torch.randperm(d.random.shape[1])[: self.n_random].numpy()
            cam = self.cameras[int(torch.randint(len(self.cameras), ()))]
        else:
            pick, cam = self.picks[i], self.cameras[0]
        item = {}
        if "points" in self.modalities:
            points = np.concatenate([d.fps[i], d.random[i][pick]])  # (F + n_random, 3)
            if self.point_augment is not None:
                points = self.point_augment(points, np.random.default_rng(int(torch.randint(2**62, ()))))
            item["points"] = torch.from_numpy(points)
            item["labels"] = torch.from_numpy(d.labels[i])
        if "sketch" in self.modalities:
            s = i % len(d.sketch_rows)
            sketch = torch.from_numpy(d.sketches[cam][s]).float().div_(255.0)[None]  # (1, H, W)
            item["sketch"] = self.augment(sketch) if self.augment is not None else sketch
            item["sketch_labels"] = torch.from_numpy(d.labels[d.sketch_rows[s]])
            item.setdefault("labels", item["sketch_labels"])
        return item


# ---------------------------------------------------------------- DataModule


class GeoCodeDataModule(pl.LightningDataModule):
    """train / val items of one domain's dataset folder (<root>/<split>/...).

    `cameras`: the training cameras (a training item picks one at random); validation uses
    `eval_camera` (default: the first training camera). `modalities`: the inputs the items
    carry (a model trained on points alone never reads a sketch). `sketched`: (first, draws), the
    first draws of each parameter class of the training split that have sketches (None: all). `seed` (the
    config's) fixes the training order of every epoch and the validation draw of random points.
    """

    def __init__(
        self,
        root: str | Path,
        recipe,
        cameras: Sequence[str],
        n_random: int = 800,
        batch_size: int = 33,
        num_workers: int = 0,
        augment: SketchAugment | None = None,
        eval_camera: str | None = None,
        point_augment: PointAugment | None = None,
        modalities: Sequence[str] = MODALITIES,
        seed: int = 0,
        sketched: tuple[int, int] | None = None,
    ) -> None:
        super().__init__()
        unknown = set(modalities) - set(MODALITIES)
        if unknown or not modalities:
            raise ValueError(f"train.modalities={list(modalities)}: give a non-empty subset of {list(MODALITIES)}")
        self.seed = int(seed)
        self.root = Path(root)
        self.recipe = recipe
        self.cameras = list(cameras)
        self.eval_camera = eval_camera or self.cameras[0]
        self.n_random = n_random
        self.batch_size = batch_size
        self.num_workers = num_workers
        self.augment = augment if augment is not None else SketchAugment()
        self.point_augment = point_augment
        self.modalities = list(modalities)
        self.sketched = sketched
        self.splits: dict[str, SplitData] = {}

    def split(self, name: str) -> SplitData:
        """A split, read once and kept."""
        if name not in self.splits:
            cams = self.cameras if name == "train" else [self.eval_camera]
            cams = cams if "sketch" in self.modalities else []
            self.splits[name] = load_split(paths.split_of(self.root, name), self.recipe, cams,
                                           self.sketched if name == "train" else None)
        return self.splits[name]

    def setup(self, stage: str | None = None) -> None:
        if stage in (None, "fit"):
            self.split("train")
        if stage in (None, "fit", "validate"):
            self.split("val")

    def _loader(self, items: Dataset, train: bool) -> DataLoader:
        return DataLoader(
            items,
            batch_size=self.batch_size,
            shuffle=train,
            generator=torch.Generator().manual_seed(key_word(self.seed, "train-order")),
            drop_last=train and len(items) > self.batch_size,  # no 1-item BatchNorm batches
            num_workers=self.num_workers,
            persistent_workers=self.num_workers > 0,
        )

    def train_dataloader(self) -> DataLoader:
        items = ShapeItems(self.split("train"), self.n_random, self.cameras, True, self.augment,
                           self.point_augment, self.modalities)
        return self._loader(items, True)

    def val_dataloader(self) -> DataLoader:
        items = ShapeItems(self.split("val"), self.n_random, [self.eval_camera], False,
                           modalities=self.modalities, seed=self.seed)
        return self._loader(items, False)
