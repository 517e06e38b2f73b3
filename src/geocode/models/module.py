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

from geocode.models.network import (  # noqa: F401  (the variants' names are used from here too)
    MODALITIES,
    VARIANT_MODALITIES,
    VARIANTS,
    Branch,
    Network,
    branch_layout,
    variant_modalities,
)
from geocode.models.vgg import VGG_CHANNELS

SCHEDULES = ("step", "cosine")  # the paper's StepLR; warmup + cosine decay for short budgets


class GeoCodeModule(Network, pl.LightningModule):
    """Point clouds and sketches (the `modalities` the variant takes) -> one class per
    program parameter.

    loss = sum_params CE(decoder(DGCNN(points))) + sum_params CE(decoder(VGG(sketch)))
    (MSE for regressed parameters). Adam + StepLR, as in the paper.

    Batches: {"points": (B, N, 3) float, "labels": (B, P) int64, "sketch": (B, 1, 224, 224) float,
    "sketch_labels": (B, P) int64 (the sketches' own shapes; "labels" where not given)}.
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
        sketch_bfloat16: bool = False,
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
             "sketch_pool": sketch_pool, "hidden": list(hidden), "dropout": dropout, "fast": fast,
             "embedding_norm": embedding_norm, "sketch_bfloat16": sketch_bfloat16,
             "lr": lr, "step_size": step_size, "gamma": gamma, "schedule": schedule,
             "warmup_epochs": warmup_epochs, "modalities": modalities}
        )
        self._build(heads, variant, k, edge_channels, point_channels, sketch_channels, sketch_pool,
                    hidden, dropout, fast, embedding_norm, sketch_bfloat16, modalities)

    # ------------------------------------------------------------ training

    def _loss(self, outputs, labels: torch.Tensor, modality: str) -> torch.Tensor:
        return sum(b.decoder(modality).loss(outputs, labels, self.columns) for b in self.branches)

    def _step(self, batch: Mapping[str, torch.Tensor], stage: str) -> torch.Tensor:
        inputs = {m: batch.get(m) if m in self.modalities else None for m in MODALITIES}
        outputs = self(inputs["points"], inputs["sketch"])
        size = batch["labels"].shape[0]
        total = 0.0
        accs = []
        for modality, out in outputs.items():
            labels = batch.get(f"{modality}_labels", batch["labels"])  # (B, P)
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
