"""The GeoCode network without its training (no Lightning: inference imports stay light).

`Network` builds the branches and predicts; `GeoCodeNet` is it as a plain module, which
`geocode.checkpoints.load_model` rebuilds from a checkpoint; `geocode.models.module.GeoCodeModule`
is it as a LightningModule for training. Both hold the same tensors under the same names.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import torch
from torch import nn

from geocode.models.dgcnn import DGCNN, DGCNNReference
from geocode.models.heads import Decoders
from geocode.models.vgg import VGG_CHANNELS, VGGSketchEncoder
from geocode.variants import MODALITIES, VARIANT_MODALITIES, VARIANTS, variant_modalities  # noqa: F401 (re-exported)


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
        sketch_bfloat16: bool = False,
    ) -> None:
        super().__init__()
        dgcnn = DGCNN if fast else DGCNNReference
        if "points" in modalities:
            self.points = dgcnn(k=k, channels=edge_channels, out_channels=point_channels)
        if "sketch" in modalities:
            self.sketch = VGGSketchEncoder(sketch_channels, out_dim=2 * point_channels, pool_size=sketch_pool,
                                           bfloat16=sketch_bfloat16)
        # A BatchNorm per modality on its embedding: shared decoders then read inputs of one
        # scale (a DGCNN pools rectified features; the sketch encoder ends with a linear layer).
        self.norms = nn.ModuleDict({m: nn.BatchNorm1d(2 * point_channels) for m in modalities}
                                   if embedding_norm else {})
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


class Hyper(dict):
    """Hyperparameters with attribute access, as Lightning's `hparams`."""

    __getattr__ = dict.__getitem__


# The network's hyperparameters and their defaults (those of `GeoCodeModule` too); a checkpoint
# from before a key existed loads with its default.
NETWORK_DEFAULTS = {"variant": "joint", "k": 20, "edge_channels": (16, 16, 32, 64), "point_channels": 64,
                    "sketch_channels": VGG_CHANNELS, "sketch_pool": 7, "hidden": (128, 64), "dropout": 0.5,
                    "fast": True, "embedding_norm": False, "sketch_bfloat16": False, "modalities": MODALITIES}


class Network:
    """Branches built from the hyperparameters, forward and decoding: shared by `GeoCodeNet`
    and the training module (a mixin before nn.Module in the class bases)."""

    def _build(self, heads, variant, k, edge_channels, point_channels, sketch_channels, sketch_pool,
               hidden, dropout, fast, embedding_norm, sketch_bfloat16, modalities) -> None:
        self.modalities = modalities
        self.parameter_names = [h["name"] for h in heads]
        self.columns = {name: j for j, name in enumerate(self.parameter_names)}
        self.branches = nn.ModuleList(
            Branch(group, modalities, sep, reg, k, edge_channels, point_channels, sketch_channels, sketch_pool,
                   hidden, dropout, fast, embedding_norm, sketch_bfloat16)
            for group, sep, reg in branch_layout(variant, heads)
        )

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

    def classes(self, outputs: Mapping[str, torch.Tensor], modality: str, decode: str = "argmax") -> torch.Tensor:
        """Head outputs of one modality -> class indices (`decode`: eval.decode).
        Shapes: -> (B, P) int64."""
        found: dict[str, torch.Tensor] = {}
        for branch in self.branches:
            found.update(branch.decoder(modality).classes(outputs, decode))
        return torch.stack([found[name] for name in self.parameter_names], dim=1)

    @torch.inference_mode()
    def predict_classes(self, points=None, sketches=None, decode: str = "argmax") -> dict[str, torch.Tensor]:
        """Eval-mode class indices per modality. Shapes: -> {modality: (B, P) int64}."""
        outputs = self(points, sketches)
        return {m: self.classes(o, m, decode) for m, o in outputs.items()}


class GeoCodeNet(Network, nn.Module):
    """The network of a checkpoint's hyperparameters (`hparams` as the training module's;
    the training settings among them are kept, not used)."""

    def __init__(self, **hparams) -> None:
        super().__init__()
        self.hparams = Hyper(hparams)
        self._build(hparams["heads"], **{key: hparams.get(key, value) for key, value in NETWORK_DEFAULTS.items()})
