"""Per-parameter decoders and their losses (SPEC §4; the regression ablation, SPEC §6).

A head spec is a plain dict (it travels in checkpoints):
  {"name": str, "n_classes": int, "continuous": bool, "existence": bool}
n_classes counts the existence class (the last index) where `existence` is true.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import torch
import torch.nn.functional as F
from torch import nn

LEAKY_SLOPE = 0.2


def head_specs(recipe) -> list[dict]:
    """Head specs of a `geocode.recipe.Recipe`, in recipe order."""
    return [
        {"name": p.name, "n_classes": int(p.n_classes), "continuous": p.kind == "float",
         "existence": bool(p.has_existence)}
        for p in recipe.parameters
    ]


def mlp(in_dim: int, hidden: Sequence[int], out_dim: int, dropout: float) -> nn.Sequential:
    """in -> hidden... -> out; Linear, BatchNorm, LeakyReLU 0.2, Dropout after each hidden layer.

    Shapes: (B, in_dim) -> (B, out_dim).
    """
    layers: list[nn.Module] = []
    width = in_dim
    for h in hidden:
        layers += [nn.Linear(width, h), nn.BatchNorm1d(h), nn.LeakyReLU(LEAKY_SLOPE), nn.Dropout(dropout)]
        width = h
    layers.append(nn.Linear(width, out_dim))
    return nn.Sequential(*layers)


class Decoders(nn.Module):
    """One MLP per parameter. A classification head outputs n_classes logits; a regression
    head (`regression=True`, continuous parameters) outputs the normalised value, plus an
    existence score where the parameter can be invisible.

    Shapes: embedding (B, in_dim) -> {name: (B, width)}.
    """

    def __init__(
        self,
        specs: Sequence[Mapping],
        in_dim: int = 128,
        hidden: Sequence[int] = (128, 64),
        dropout: float = 0.5,
        regression: bool = False,
    ) -> None:
        super().__init__()
        self.specs = [dict(s) for s in specs]
        self.modes = {s["name"]: "reg" if regression and s["continuous"] else "cls" for s in self.specs}
        self.heads = nn.ModuleDict(
            {s["name"]: mlp(in_dim, hidden, self._width(s), dropout) for s in self.specs}
        )

    def _width(self, spec: Mapping) -> int:
        if self.modes[spec["name"]] == "cls":
            return int(spec["n_classes"])
        return 2 if spec["existence"] else 1

    def forward(self, embedding: torch.Tensor) -> dict[str, torch.Tensor]:
        return {name: head(embedding) for name, head in self.heads.items()}

    def loss(self, outputs: Mapping[str, torch.Tensor], labels: torch.Tensor, columns: Mapping[str, int]) -> torch.Tensor:
        """sum over parameters of CE (classification) or MSE (regression).

        Shapes: outputs {name: (B, width)}, labels (B, P) int64 classes -> ().
        """
        total = labels.new_zeros((), dtype=torch.float32)
        for spec in self.specs:
            name = spec["name"]
            target = labels[:, columns[name]]  # (B,)
            if self.modes[name] == "cls":
                total = total + F.cross_entropy(outputs[name], target)
            else:
                total = total + regression_loss(outputs[name], target, spec)
        return total

    def classes(self, outputs: Mapping[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        """Predicted class index per parameter. Shapes: {name: (B, width)} -> {name: (B,)}."""
        out = {}
        for spec in self.specs:
            name = spec["name"]
            if self.modes[name] == "cls":
                out[name] = outputs[name].argmax(dim=1)
            else:
                out[name] = regression_classes(outputs[name], spec)
        return out


def _n_values(spec: Mapping) -> int:
    return int(spec["n_classes"]) - int(bool(spec["existence"]))


def regression_loss(pred: torch.Tensor, target: torch.Tensor, spec: Mapping) -> torch.Tensor:
    """The paper's regression ablation: MSE of the value against the normalised label
    (class / (n_values - 1), or the existence label -1 where the part is invisible), plus MSE
    of the existence score against [invisible]. Where the existence score predicts
    invisible (> 0.5) the value's error is not collected.

    Shapes: pred (B, 1 or 2), target (B,) class indices -> ().
    """
    n_values = _n_values(spec)
    visible = target < n_values  # (B,)
    value = torch.where(visible, target.to(pred.dtype) / max(n_values - 1, 1), -1.0)  # (B,)
    collect = pred[:, 1].detach() <= 0.5 if spec["existence"] else torch.ones_like(visible)  # (B,)
    loss = ((pred[:, 0] - value) ** 2 * collect).sum() / collect.sum().clamp(min=1)
    if spec["existence"]:
        loss = loss + F.mse_loss(pred[:, 1], (~visible).to(pred.dtype))
    return loss


def regression_classes(pred: torch.Tensor, spec: Mapping) -> torch.Tensor:
    """Nearest value class of the predicted value; the existence class where the
    existence score is > 0.5. Shapes: pred (B, 1 or 2) -> (B,) int64."""
    n_values = _n_values(spec)
    cls = (pred[:, 0].clamp(0, 1) * (n_values - 1)).round().long()  # (B,)
    if spec["existence"]:
        cls = torch.where(pred[:, 1] > 0.5, torch.full_like(cls, n_values), cls)
    return cls
