"""Per-parameter decoders and their losses (docs/paper-numbers.md#network; the regression
ablation, docs/paper-numbers.md#tables).

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
        self._stack: list | None = None  # the eval-mode heads, stacked (see `_stacked`)
        self.register_load_state_dict_post_hook(lambda module, _: module._forget_stack())

    def _width(self, spec: Mapping) -> int:
        if self.modes[spec["name"]] == "cls":
            return int(spec["n_classes"])
        return 2 if spec["existence"] else 1

    def forward(self, embedding: torch.Tensor) -> dict[str, torch.Tensor]:
        if self.training or not self.heads:
            return {name: head(embedding) for name, head in self.heads.items()}
        return self._forward_stacked(embedding)

    def _forward_stacked(self, embedding: torch.Tensor) -> dict[str, torch.Tensor]:
        """Eval mode, all heads in one batched product per layer (the same numbers as the
        heads one by one, whose dozens of small modules cost more than their arithmetic).

        Shapes: embedding (B, in_dim) -> {name: (B, width)}.
        """
        h = embedding.unsqueeze(0).expand(len(self.heads), -1, -1)  # (P, B, in)
        *hidden, (w_out, b_out) = self._stacked()
        for w, b, scale, shift in hidden:
            h = torch.baddbmm(b.unsqueeze(1), h, w.transpose(1, 2))  # (P, B, h)
            h = F.leaky_relu(h * scale.unsqueeze(1) + shift.unsqueeze(1), LEAKY_SLOPE)
        out = torch.baddbmm(b_out.unsqueeze(1), h, w_out.transpose(1, 2))  # (P, B, widest)
        return {name: out[p, :, : self._width(spec)]
                for p, (name, spec) in enumerate(zip(self.heads, self.specs, strict=True))}

    def _stacked(self) -> list[tuple[torch.Tensor, ...]]:
        """Per layer, the heads' weights stacked: hidden layers as (W (P, out, in), b,
        BN scale, BN shift (P, out)), the last as (W (P, widest, in) zero-padded, b).
        Built at the first eval-mode call and kept until the weights can have changed:
        `train()`/`eval()`, `.to()` and `load_state_dict` drop it (so do that after
        editing the weights of an eval-mode model by hand)."""
        if self._stack is None:
            self._stack = _stack_heads(list(self.heads.values()))
        return self._stack

    def _forget_stack(self) -> None:
        self._stack = None

    def train(self, mode: bool = True):
        self._forget_stack()
        return super().train(mode)

    def _apply(self, fn, *args, **kwargs):
        self._forget_stack()
        return super()._apply(fn, *args, **kwargs)

    def loss(self, outputs: Mapping[str, torch.Tensor], labels: torch.Tensor,
             columns: Mapping[str, int]) -> torch.Tensor:
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

    def classes(self, outputs: Mapping[str, torch.Tensor], decode: str = "argmax") -> dict[str, torch.Tensor]:
        """Predicted class index per parameter; `decode` (eval.decode: argmax, median or mean) reads a
        continuous parameter's classification head (mean: the median's class, whose value
        `checkpoints.predicted_values` then replaces by the expected one).
        Shapes: {name: (B, width)} -> {name: (B,)}."""
        out = {}
        for spec in self.specs:
            name = spec["name"]
            if self.modes[name] == "reg":
                out[name] = regression_classes(outputs[name], spec)
            elif decode in ("median", "mean") and spec["continuous"]:
                out[name] = median_classes(outputs[name], spec)
            else:
                out[name] = outputs[name].argmax(dim=1)
        return out


@torch.no_grad()
def _stack_heads(heads: Sequence[nn.Sequential]) -> list[tuple[torch.Tensor, ...]]:
    """See `Decoders._stacked`; the heads are `mlp`s of one shape but for the last width."""
    layers = []
    linears = [[m for m in head if isinstance(m, nn.Linear)] for head in heads]
    norms = [[m for m in head if isinstance(m, nn.BatchNorm1d)] for head in heads]
    for depth in range(len(norms[0])):
        lin = [ls[depth] for ls in linears]
        bns = [ns[depth] for ns in norms]
        scale = torch.stack([bn.weight * torch.rsqrt(bn.running_var + bn.eps) for bn in bns])  # (P, out)
        shift = torch.stack([bn.bias for bn in bns]) - torch.stack([bn.running_mean for bn in bns]) * scale
        layers.append((torch.stack([m.weight for m in lin]), torch.stack([m.bias for m in lin]), scale, shift))
    last = [ls[-1] for ls in linears]
    widest = max(m.out_features for m in last)
    w = last[0].weight.new_zeros(len(last), widest, last[0].in_features)  # (P, widest, in)
    b = last[0].bias.new_zeros(len(last), widest)
    for p, m in enumerate(last):
        w[p, : m.out_features] = m.weight
        b[p, : m.out_features] = m.bias
    layers.append((w, b))
    return layers


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


def median_classes(logits: torch.Tensor, spec: Mapping) -> torch.Tensor:
    """The median of the predicted distribution over a continuous parameter's value classes
    (ordered, evenly spaced): the class that minimises the expected distance to the true
    value, where the argmax can pick one end of a spread distribution. The existence class
    where it is the likeliest. Shapes: logits (B, n_classes) -> (B,) int64."""
    n_values = _n_values(spec)
    probs = torch.softmax(logits, dim=1)  # (B, n_classes)
    cdf = probs[:, :n_values].cumsum(dim=1)  # (B, n_values)
    median = (cdf < 0.5 * cdf[:, -1:]).sum(dim=1).clamp(max=n_values - 1)  # (B,)
    if spec["existence"]:
        median = torch.where(logits.argmax(dim=1) == n_values, torch.full_like(median, n_values), median)
    return median


def regression_classes(pred: torch.Tensor, spec: Mapping) -> torch.Tensor:
    """Nearest value class of the predicted value; the existence class where the
    existence score is > 0.5. Shapes: pred (B, 1 or 2) -> (B,) int64."""
    n_values = _n_values(spec)
    cls = (pred[:, 0].clamp(0, 1) * (n_values - 1)).round().long()  # (B,)
    if spec["existence"]:
        cls = torch.where(pred[:, 1] > 0.5, torch.full_like(cls, n_values), cls)
    return cls
