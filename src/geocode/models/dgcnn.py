"""DGCNN point-cloud encoder (docs/paper-numbers.md#network): a plain reference and an exact, faster twin.

Both share one parameter layout (same `state_dict` keys and shapes), so weights move
between them with `load_state_dict`.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import nn

from geocode.models.neighbours import (
    knn,
    nearest_neighbours,
    neighbour_max,
    neighbour_max_arg_sum,
    neighbour_max_sum_grad,
)

LEAKY_SLOPE = 0.2


# ---------------------------------------------------------------- pure helpers


def gather_neighbours(x: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """x_j for every neighbour j of every point i.

    Shapes: x (B, C, N), idx (B, N, k) -> (B, C, N, k).
    """
    b, c, n = x.shape
    k = idx.shape[-1]
    flat = idx.reshape(b, 1, n * k).expand(b, c, n * k)  # (B, C, N*k)
    return x.gather(2, flat).view(b, c, n, k)  # (B, C, N, k)


def edge_features(x: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
    """EdgeConv input [x_i, x_j - x_i].

    Shapes: x (B, C, N), idx (B, N, k) -> (B, 2C, N, k).
    """
    xj = gather_neighbours(x, idx)  # (B, C, N, k)
    xi = x.unsqueeze(-1).expand_as(xj)  # (B, C, N, k)
    return torch.cat([xi, xj - xi], dim=1)  # (B, 2C, N, k)


def flat_neighbours(idx: torch.Tensor) -> torch.Tensor:
    """Neighbour indices into the point-major rows of a whole batch.

    Shapes: idx (B, N, k) -> (B*N*k,) int64, values in [0, B*N).
    """
    b, n, _ = idx.shape
    offset = torch.arange(b, device=idx.device).view(b, 1, 1) * n  # (B, 1, 1)
    return (idx + offset).reshape(-1)  # (B*N*k,)


class _NeighbourMaxSum(torch.autograd.Function):
    """max_j and sum_j of rows b_j over each point's neighbours; the backward scatters
    the max gradient to the arg-max rows only (no (P, k, O) gradient tensor)."""

    @staticmethod
    def forward(ctx, b: torch.Tensor, flat: torch.Tensor, k: int, with_sum: bool):
        if not ctx.needs_input_grad[0] and not with_sum:  # inference
            return neighbour_max(b, flat, k), None
        mx, src, total = neighbour_max_arg_sum(b, flat, k, with_sum)
        ctx.save_for_backward(src, flat)
        ctx.k, ctx.rows = k, b.shape[0]
        return mx, total

    @staticmethod
    def backward(ctx, g_max: torch.Tensor, g_sum: torch.Tensor):
        src, flat = ctx.saved_tensors
        return neighbour_max_sum_grad(g_max, src, g_sum, flat, ctx.k, ctx.rows), None, None, None


def neighbour_max_sum(
    b: torch.Tensor, flat: torch.Tensor, k: int, with_sum: bool = True
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """(max_{j in N(i)} b_j, sum_{j in N(i)} b_j or None) for every point i.

    Shapes: b (P, O) point rows, flat (P*k,) from `flat_neighbours` -> (P, O), (P, O).
    """
    return _NeighbourMaxSum.apply(b, flat, k, with_sum)


# ---------------------------------------------------------------- layers


def _edge_conv(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(2 * c_in, c_out, kernel_size=1, bias=False),
        nn.BatchNorm2d(c_out),
        nn.LeakyReLU(LEAKY_SLOPE),
    )


def _head(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv1d(c_in, c_out, kernel_size=1, bias=False),
        nn.BatchNorm1d(c_out),
        nn.LeakyReLU(LEAKY_SLOPE),
    )


class DGCNNReference(nn.Module):
    """DGCNN as written in the paper: kNN, EdgeConv, max over neighbours, four times.

    h_i = max_j LeakyReLU(BN(W [x_i, x_j - x_i])), j in kNN(i) (xyz first, then features);
    z = LeakyReLU(BN(W5 [h1; h2; h3; h4])); out = [max_i z_i, mean_i z_i].

    Shapes: points (B, N, 3) -> (B, 2 * out_channels).
    """

    def __init__(
        self,
        k: int = 20,
        channels: Sequence[int] = (16, 16, 32, 64),
        out_channels: int = 64,
        in_channels: int = 3,
    ) -> None:
        super().__init__()
        self.k = k
        widths = [in_channels, *channels]
        self.edge_convs = nn.ModuleList(_edge_conv(a, b) for a, b in zip(widths, widths[1:], strict=False))
        self.head = _head(sum(channels), out_channels)
        self.out_dim = 2 * out_channels

    def forward(self, points: torch.Tensor) -> torch.Tensor:
        x = points.transpose(1, 2)  # (B, 3, N)
        feats = []
        for conv in self.edge_convs:
            idx = knn(x, min(self.k, x.shape[-1]))  # (B, N, k)
            x = conv(edge_features(x, idx)).max(dim=-1).values  # (B, C, N)
            feats.append(x)
        z = self.head(torch.cat(feats, dim=1))  # (B, out, N)
        return torch.cat([z.amax(dim=-1), z.mean(dim=-1)], dim=1)  # (B, 2*out)


def edge_conv_fast(
    x: torch.Tensor, idx: torch.Tensor, weight: torch.Tensor, bn: nn.BatchNorm2d
) -> torch.Tensor:
    """One EdgeConv (1x1 conv, BatchNorm over edges, LeakyReLU, max over j), exactly,
    without materialising the (2C, N, k) edge features.

    Linear part per point: W [x_i, x_j - x_i] = a_i + b_j, a = (W1 - W2) x, b = W2 x.
    BN is affine per channel with scale g / sigma and LeakyReLU is increasing, so
    max_j f(a_i + b_j) = f(a_i + max_j b_j) where g >= 0, f(a_i + min_j b_j) where g < 0:
    one gather of the output-width b, one max, one sum. Batch statistics over the
    B*N*k edges, from per-point terms and the neighbour in-degrees c_j:
      mu = mean_i a_i + sum_j c_j b_j / E
      var = (k sum_i A_i^2 + 2 sum_i A_i sum_{j in N(i)} B_j + sum_j c_j B_j^2) / E,
    with A = a - mean a, B = b - mean_edges b, E = B*N*k. Running statistics are
    updated as `nn.BatchNorm2d` does (unbiased variance).

    Shapes: x (B, N, C) point-major, idx (B, N, k), weight (O, 2C, 1, 1) -> (B, N, O).
    """
    bsz, n, c = x.shape
    k = idx.shape[-1]
    w = weight.view(weight.shape[0], 2 * c)  # (O, 2C)
    w_self, w_nb = w[:, :c], w[:, c:]  # (O, C) each
    a = F.linear(x, w_self - w_nb).reshape(bsz * n, -1)  # (B*N, O)
    b = F.linear(x, w_nb).reshape(bsz * n, -1)  # (B*N, O)
    gamma = bn.weight
    sign = torch.where(gamma < 0, -1.0, 1.0).to(b.dtype).detach()  # (O,)
    flat = flat_neighbours(idx)  # (B*N*k,)
    nb_max, nb_sum = neighbour_max_sum(b * sign, flat, k, bn.training)  # (B*N, O) each
    extreme = nb_max * sign  # (B*N, O): max_j b_j, or min_j b_j where g < 0
    if bn.training:
        mean, var = _edge_stats(a, b, nb_sum * sign, flat, k)
        _update_running(bn, mean, var, a.shape[0] * k)
    else:
        mean, var = bn.running_mean, bn.running_var
    scale = gamma * torch.rsqrt(var + bn.eps)  # (O,)
    y = (a + extreme - mean) * scale + bn.bias  # (B*N, O)
    return F.leaky_relu(y, LEAKY_SLOPE).view(bsz, n, -1)  # (B, N, O)


def _edge_stats(
    a: torch.Tensor, b: torch.Tensor, nb_sum: torch.Tensor, flat: torch.Tensor, k: int
) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean and biased variance over edges of e_ij = a_i + b_j (see `edge_conv_fast`).

    Shapes: a, b, nb_sum (P, O) with nb_sum_i = sum_{j in N(i)} b_j, flat (P*k,) -> (O,), (O,).
    """
    edges = a.shape[0] * k
    deg = torch.bincount(flat, minlength=a.shape[0]).to(a.dtype)  # (P,) in-degrees c_j
    mean_a = a.mean(dim=0)  # (O,)
    mean_b = deg @ b / edges  # (O,) edge mean of b_j
    ca = a - mean_a  # (P, O)
    cb = b - mean_b  # (P, O)
    cross = (ca * (nb_sum - k * mean_b)).sum(dim=0)  # (O,)
    var = (k * (ca * ca).sum(dim=0) + 2 * cross + deg @ (cb * cb)) / edges  # (O,)
    return mean_a + mean_b, var


def _update_running(bn: nn.modules.batchnorm._BatchNorm, mean: torch.Tensor, var: torch.Tensor, count: int) -> None:
    """Running statistics as `nn.BatchNorm*` keeps them (momentum, unbiased variance)."""
    if not bn.track_running_stats:
        raise ValueError("edge_conv_fast needs BatchNorm with track_running_stats=True")
    with torch.no_grad():
        bn.num_batches_tracked.add_(1)
        m = bn.momentum if bn.momentum is not None else 1.0 / float(bn.num_batches_tracked)
        bn.running_mean.mul_(1 - m).add_(mean.detach(), alpha=m)
        bn.running_var.mul_(1 - m).add_(var.detach() * count / max(count - 1, 1), alpha=m)


class DGCNN(DGCNNReference):
    """`DGCNNReference`, exact and faster: per-point linear maps (`edge_conv_fast`),
    point-major layout, kNN by cells on the CPU; same parameters, outputs and gradients.

    Shapes: points (B, N, 3) -> (B, 2 * out_channels).
    """

    def forward(self, points: torch.Tensor) -> torch.Tensor:
        x = points  # (B, N, 3)
        feats = []
        idx = None
        for conv in self.edge_convs:
            idx = nearest_neighbours(x.detach(), min(self.k, x.shape[1]), seeds=idx)  # (B, N, k)
            x = edge_conv_fast(x, idx, conv[0].weight, conv[1])  # (B, N, C)
            feats.append(x)
        z = self._head_point_major(torch.cat(feats, dim=2))  # (B, N, out)
        return torch.cat([z.amax(dim=1), z.mean(dim=1)], dim=1)  # (B, 2*out)

    def _head_point_major(self, h: torch.Tensor) -> torch.Tensor:
        """The 1x1 Conv1d + BatchNorm1d + LeakyReLU head on (B, N, C) features."""
        conv, bn = self.head[0], self.head[1]
        bsz, n, c = h.shape
        z = F.linear(h.reshape(bsz * n, c), conv.weight.view(conv.weight.shape[0], c))  # (B*N, out)
        factor = 0.0
        if bn.training:
            bn.num_batches_tracked.add_(1)
            factor = bn.momentum if bn.momentum is not None else 1.0 / float(bn.num_batches_tracked)
        z = F.batch_norm(
            z, bn.running_mean, bn.running_var, bn.weight, bn.bias,
            training=bn.training, momentum=factor, eps=bn.eps,
        )  # (B*N, out)
        return F.leaky_relu(z, LEAKY_SLOPE).view(bsz, n, -1)  # (B, N, out)
