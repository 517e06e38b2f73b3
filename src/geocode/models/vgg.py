"""Reduced VGG11 sketch encoder (docs/paper-numbers.md#network)."""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import nn

VGG_CHANNELS = (8, "M", 16, "M", 32, 32, "M", 64, 64, "M", 64, 64, "M")


class VGGSketchEncoder(nn.Module):
    """VGG11 with narrow channels on one grey channel.

    f = Linear(flatten(AdaptiveAvgPool(features(x)))), features = [Conv3x3 pad 1, BN, ReLU]
    blocks with 2x2 max-pools where `channels` says "M". pool_size=7 keeps the 7x7 grid
    torchvision's VGG keeps (where the sketch's strokes are matters); 1 is global pooling.
    `bfloat16`: convolutions and the linear layer autocast to bfloat16 (BatchNorm stays float32,
    the output is float32): about 2.3x faster on a CPU with AVX-512 BF16
    (docs/design.md#sketch-encoder-in-bfloat16).

    Shapes: sketches (B, in_channels, 224, 224) -> (B, out_dim).
    """

    def __init__(
        self,
        channels: Sequence[int | str] = VGG_CHANNELS,
        in_channels: int = 1,
        out_dim: int = 128,
        pool_size: int = 7,
        bfloat16: bool = False,
    ) -> None:
        super().__init__()
        self.bfloat16 = bfloat16
        layers: list[nn.Module] = []
        width = in_channels
        for c in channels:
            if c == "M":
                layers.append(nn.MaxPool2d(kernel_size=2, stride=2))
                continue
            layers += [nn.Conv2d(width, int(c), 3, padding=1, bias=False), nn.BatchNorm2d(int(c)),
                       nn.ReLU(inplace=True)]
            width = int(c)
        # Channels-last convolutions are about 1.4x faster on the CPU (oneDNN) and as fast on GPUs;
        # a one-channel input has no layout of its own, so the weights carry it.
        self.features = nn.Sequential(*layers).to(memory_format=torch.channels_last)
        self.pool = nn.AdaptiveAvgPool2d(pool_size)
        self.fc = nn.Linear(width * pool_size * pool_size, out_dim)
        self.out_dim = out_dim

    def forward(self, sketches: torch.Tensor) -> torch.Tensor:
        with torch.autocast(sketches.device.type, torch.bfloat16, enabled=self.bfloat16):
            h = self.pool(self.features(sketches))  # (B, C, s, s)
            return self.fc(h.flatten(1)).float()  # (B, out_dim)
