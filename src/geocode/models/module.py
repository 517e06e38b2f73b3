"""The GeoCode network as a LightningModule, with the paper's ablation variants
(docs/paper-numbers.md#network and #tables).

Variants:
  joint       one point encoder, one sketch encoder, one set of decoders for both
  separate    the same encoders, a set of decoders per modality
  regression  continuous parameters regressed (value, existence) with MSE
  huang       Huang et al. 2017: sketches only; a network (its own VGG encoder) classifying the
              discrete parameters and a separate one regressing the continuous ones, both trained
              from scratch on the same data (the paper's comparison, supplementary)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from functools import partial

import pytorch_lightning as pl
import torch
from torch import nn

from geocode.models.dgcnn import DGCNN, DGCNNReference
from geocode.models.heads import Decoders
from geocode.models.vgg import VGG_CHANNELS, VGGSketchEncoder

VARIANTS = ("joint", "separate", "regression", "huang")
SCHEDULES = ("step", "cosine")  # the paper's StepLR; warmup + cosine decay for short budgets
MODALITIES = ("points", "sketch")
# The inputs a variant can take: Huang et al. 2017 read sketches only.
VARIANT_MODALITIES = {"huang": ("sketch",)}


def variant_modalities(variant: str, modalities: Sequence[str] = MODALITIES) -> list[str]:
    """The asked-for modalities that the variant takes, in MODALITIES order."""
    allowed = VARIANT_MODALITIES.get(variant, MODALITIES)
    kept = [m for m in MODALITIES if m in modalities and m in allowed]
    if not kept:
        raise ValueError(f"model.variant={variant} takes {', '.join(allowed)}: "
                         f"modalities={list(modalities)} leaves it no input")
    return kept


class Branch(nn.Module):
    """An encoder per modality and their decoders for a subset of the parameters.

    Shapes: points (B, N, 3), sketches (B, 1, H, W) -> {modality: {name: (B, width)}}.
    """

    def __init__(
        self,
        specs: Sequence[Mapping],
        modalities: Sequence[str],
        separate: bool,
        regression: bool,
        k: int,
        edge_channels: Sequence[int],
        point_channels: int,
        sketch_channels: Sequence[int | str],
        sketch_pool: int,
        hidden: Sequence[int],
        dropout: float,
        fast: bool,
        embedding_norm: bool = False,
    ) -> None:
        super().__init__()
        dgcnn = DGCNN if fast else DGCNNReference
        if "points" in modalities:
            self.points = dgcnn(k=k, channels=edge_channels, out_channels=point_channels)
        if "sketch" in modalities:
            self.sketch = VGGSketchEncoder(sketch_channels, out_dim=2 * point_channels, pool_size=sketch_pool)
        # A BatchNorm per modality on its embedding: shared decoders then read inputs of one
        # scale (a DGCNN pools rectified features; the sketch encoder ends with a linear layer).
        self.norms = nn.ModuleDict({m: nn.BatchNorm1d(2 * point_channels) for m in modalities} if embedding_norm else {})
        keys = modalities if separate else ("common",)
        self.decoders = nn.ModuleDict(
            {key: Decoders(specs, 2 * point_channels, hidden, dropout, regression) for key in keys}
        )

    def decoder(self, modality: str) -> Decoders:
        return self.decoders[modality if modality in self.decoders else "common"]

    def forward(self, points=None, sketches=None) -> dict[str, dict[str, torch.Tensor]]:
        embeddings = {m: getattr(self, m)(x)
                      for m, x in (("points", points), ("sketch", sketches)) if x is not None}
        embeddings = {m: self.norms[m](e) if m in self.norms else e for m, e in embeddings.items()}
        if "common" not in self.decoders:
            return {m: self.decoders[m](e) for m, e in embeddings.items()}
        # Shared decoders see both modalities in one batch: their BatchNorm then normalises
        # in training with the statistics it keeps for evaluation. Called once per modality,
        # the running statistics would blend two distributions that training never saw
        # blended, and eval-mode predictions of both modalities would suffer.
        outputs = self.decoders["common"](torch.cat(list(embeddings.values())))
        sizes = [len(e) for e in embeddings.values()]
        parts = {name: out.split(sizes) for name, out in outputs.items()}
        return {m: {name: p[i] for name, p in parts.items()} for i, m in enumerate(embeddings)}


def branch_layout(variant: str, specs: Sequence[Mapping]) -> list[tuple[list[dict], bool, bool]]:
    """(specs, separate decoders?, regression?) for each network of a variant."""
    specs = [dict(s) for s in specs]
    if variant == "joint":
        return [(specs, False, False)]
    if variant == "separate":
        return [(specs, True, False)]
    if variant == "regression":
        return [(specs, False, True)]
    if variant == "huang":
        discrete = [s for s in specs if not s["continuous"]]
        continuous = [s for s in specs if s["continuous"]]
        return [(group, False, reg) for group, reg in ((discrete, False), (continuous, True)) if group]
    raise ValueError(f"model.variant={variant!r}: use one of {', '.join(VARIANTS)}")


class GeoCodeModule(pl.LightningModule):
    """Point clouds and sketches (the `modalities` the variant takes) -> one class per
    program parameter.

    loss = sum_params CE(decoder(DGCNN(points))) + sum_params CE(decoder(VGG(sketch)))
    (MSE for regressed parameters). Adam + StepLR, as in the paper.

    Batches: {"points": (B, N, 3) float, "sketch": (B, 1, 224, 224) float, "labels": (B, P) int64}.
    """

    def __init__(
        self,
        heads: Sequence[Mapping],
        variant: str = "joint",
        k: int = 20,
        edge_channels: Sequence[int] = (16, 16, 32, 64),
        point_channels: int = 64,
        sketch_channels: Sequence[int | str] = VGG_CHANNELS,
        sketch_pool: int = 7,
        hidden: Sequence[int] = (128, 64),
        dropout: float = 0.5,
        fast: bool = True,
        embedding_norm: bool = False,
        lr: float = 1e-2,
        step_size: int = 20,
        gamma: float = 0.9,
        schedule: str = "step",
        warmup_epochs: int = 0,
        modalities: Sequence[str] = MODALITIES,
    ) -> None:
        super().__init__()
        if schedule not in SCHEDULES:
            raise ValueError(f"train.schedule={schedule!r}: use one of {', '.join(SCHEDULES)}")
        heads = [dict(h) for h in heads]
        modalities = variant_modalities(variant, modalities)
        self.save_hyperparameters(
            {"heads": heads, "variant": variant, "k": k, "edge_channels": list(edge_channels),
             "point_channels": point_channels, "sketch_channels": list(sketch_channels),
             "sketch_pool": sketch_pool, "hidden": list(hidden), "dropout": dropout, "fast": fast, "embedding_norm": embedding_norm,
             "lr": lr, "step_size": step_size, "gamma": gamma, "schedule": schedule,
             "warmup_epochs": warmup_epochs, "modalities": modalities}
        )
        self.modalities = modalities
        self.parameter_names = [h["name"] for h in heads]
        self.columns = {name: j for j, name in enumerate(self.parameter_names)}
        self.branches = nn.ModuleList(
            Branch(group, modalities, sep, reg, k, edge_channels, point_channels, sketch_channels, sketch_pool,
                   hidden, dropout, fast, embedding_norm)
            for group, sep, reg in branch_layout(variant, heads)
        )

    # ------------------------------------------------------------ inference

    def forward(self, points=None, sketches=None) -> dict[str, dict[str, torch.Tensor]]:
        """{modality: {parameter: head output}} over all branches."""
        for modality, inputs in (("points", points), ("sketch", sketches)):
            if inputs is not None and modality not in self.modalities:
                raise ValueError(f"a {self.hparams.variant} model takes no {modality} input "
                                 f"(its modalities: {', '.join(self.modalities)})")
        out: dict[str, dict[str, torch.Tensor]] = {}
        for branch in self.branches:
            for modality, heads in branch(points, sketches).items():
                out.setdefault(modality, {}).update(heads)
        return out

    def classes(self, outputs: Mapping[str, torch.Tensor], modality: str) -> torch.Tensor:
        """Head outputs of one modality -> class indices. Shapes: -> (B, P) int64."""
        found: dict[str, torch.Tensor] = {}
        for branch in self.branches:
            found.update(branch.decoder(modality).classes(outputs))
        return torch.stack([found[name] for name in self.parameter_names], dim=1)

    @torch.inference_mode()
    def predict_classes(self, points=None, sketches=None) -> dict[str, torch.Tensor]:
        """Eval-mode class indices per modality. Shapes: -> {modality: (B, P) int64}."""
        outputs = self(points, sketches)
        return {m: self.classes(o, m) for m, o in outputs.items()}

    # ------------------------------------------------------------ training

    def _loss(self, outputs, labels: torch.Tensor, modality: str) -> torch.Tensor:
        return sum(b.decoder(modality).loss(outputs, labels, self.columns) for b in self.branches)

    def _step(self, batch: Mapping[str, torch.Tensor], stage: str) -> torch.Tensor:
        labels = batch["labels"]  # (B, P)
        inputs = {m: batch.get(m) if m in self.modalities else None for m in MODALITIES}
        outputs = self(inputs["points"], inputs["sketch"])
        size = labels.shape[0]
        total = 0.0
        accs = []
        for modality, out in outputs.items():
            loss = self._loss(out, labels, modality)
            total = total + loss
            correct = (self.classes(out, modality) == labels).float()  # (B, P)
            acc = correct.mean()
            accs.append(acc)
            self.log(f"{stage}/loss_{modality}", loss, batch_size=size, on_epoch=True, on_step=False)
            self.log(f"{stage}/acc_{modality}", acc, batch_size=size, on_epoch=True, on_step=False)
            if stage == "val":
                per = correct.mean(dim=0)  # (P,)
                self.log_dict({f"val_param/{modality}/{n}": per[j] for n, j in self.columns.items()},
                              batch_size=size, on_epoch=True, on_step=False)
        self.log(f"{stage}/loss", total, batch_size=size, on_epoch=True, on_step=False,
                 prog_bar=True)
        self.log(f"{stage}/acc", torch.stack(accs).mean(), batch_size=size, on_epoch=True,
                 on_step=False, prog_bar=True)
        return total

    def training_step(self, batch, batch_idx):
        return self._step(batch, "train")

    def validation_step(self, batch, batch_idx):
        self._step(batch, "val")

    def configure_optimizers(self):
        hp = self.hparams
        opt = torch.optim.Adam(self.parameters(), lr=hp.lr)
        if hp.get("schedule", "step") == "step":
            sched = torch.optim.lr_scheduler.StepLR(opt, step_size=hp.step_size, gamma=hp.gamma)
        else:
            factor = partial(cosine_factor, warmup=hp.warmup_epochs, total=self.trainer.max_epochs)
            sched = torch.optim.lr_scheduler.LambdaLR(opt, factor)
        return {"optimizer": opt, "lr_scheduler": {"scheduler": sched, "interval": "epoch"}}


def cosine_factor(epoch: int, warmup: int, total: int) -> float:
    """The learning rate's factor in an epoch: a linear rise over `warmup` epochs, then a
    cosine from 1 down to 0.05 at the last epoch."""
    if epoch < warmup:
        return (epoch + 1) / (warmup + 1)
    progress = (epoch - warmup) / max(total - warmup - 1, 1)
    return 0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * min(progress, 1.0)))
