"""Image backbones of the chunking policies (ACT, Diffusion Policy): an image ``(B, C, H, W)`` in
[0, 1] -> a feature map ``(B, D, h, w)``.

* ``"resnet18"``: torchvision's ResNet-18 without its pooling and classifier, trained from
  scratch (``weights=None``: nothing is downloaded), stride 32; the first convolution takes
  4 channels for RGB-D input. ``norm="group"`` replaces every batch norm by a group norm
  (Diffusion Policy, Chi et al. 2023, Sec. 3.3: batch norm and an exponential moving average
  of the weights do not mix), ``"batch"`` keeps it (ACT, Zhao et al. 2023).
* ``"trunk"``: the project's conv trunk (:class:`~lfd.visuomotor.policies.vision.KeypointEncoder`'s
  convolutions, stride 2): the CNN -> DMP and velocity policies' image encoder.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from lfd.visuomotor.policies.vision import KeypointEncoder

#: Backbone names (``backbone`` hyper-parameter of the chunking policies).
BACKBONES = ("resnet18", "trunk")
#: Normalisation layers of the ResNet-18 backbone.
NORMS = ("batch", "group")


class ImageBackbone(nn.Module):
    """Image ``(B, in_channels, H, W)`` in [0, 1] -> feature map ``(B, out_channels, h, w)``.

    Args:
        name: one of :data:`BACKBONES`.
        in_channels: 3 (RGB) or 4 (RGB-D).
        channels: the trunk's conv channels (``"trunk"`` only).
        norm: ``"batch"`` or ``"group"`` (``"resnet18"`` only; 16 groups, as LeRobot's
            Diffusion Policy uses ``channels // 16``).
    """

    def __init__(
        self,
        name: str = "resnet18",
        in_channels: int = 3,
        channels: tuple[int, ...] | list[int] = (32, 32, 32, 32),
        norm: str = "batch",
    ) -> None:
        super().__init__()
        if name not in BACKBONES:
            raise ValueError(f"ImageBackbone.name: expected one of {BACKBONES}, got {name!r}")
        if norm not in NORMS:
            raise ValueError(f"ImageBackbone.norm: expected one of {NORMS}, got {norm!r}")
        if in_channels not in (3, 4):
            raise ValueError(f"ImageBackbone.in_channels: expected 3 (RGB) or 4 (RGB-D), got {in_channels!r}")
        self.name, self.in_channels = name, int(in_channels)
        if name == "trunk":
            self.net = KeypointEncoder(channels, in_channels=in_channels).convs
            self.out_channels = int(channels[-1])
            return
        from torchvision.models import resnet18

        def group_norm(c: int) -> nn.Module:
            return nn.GroupNorm(c // 16, c)

        net = resnet18(weights=None, norm_layer=group_norm if norm == "group" else None)
        if in_channels != 3:
            net.conv1 = nn.Conv2d(in_channels, 64, kernel_size=7, stride=2, padding=3, bias=False)
        self.net = nn.Sequential(*list(net.children())[:-2])  # without avgpool and fc
        self.out_channels = 512

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        return self.net(image - 0.5)


def sinusoidal_embedding(positions: torch.Tensor, dim: int) -> torch.Tensor:
    """Transformer sine/cosine embedding (Vaswani et al. 2017) of ``positions`` ``(...,)`` ->
    ``(..., dim)``: ``[sin(p w_0), ..., sin(p w_{d/2-1}), cos(p w_0), ...]``,
    ``w_i = 10000^(-i / (d/2 - 1))``; ``dim`` even."""
    if dim % 2:
        raise ValueError(f"sinusoidal_embedding.dim: expected an even number, got {dim}")
    half = dim // 2
    freqs = torch.exp(
        -math.log(10000.0)
        * torch.arange(half, dtype=torch.float32, device=positions.device)
        / max(half - 1, 1)
    )
    angles = positions.float()[..., None] * freqs
    return torch.cat([angles.sin(), angles.cos()], dim=-1)


def grid_embedding(h: int, w: int, dim: int) -> torch.Tensor:
    """2-D sine/cosine embedding of an ``h x w`` feature map, ``(h w, dim)`` (row-major): half
    the channels encode the row, half the column (DETR's, which ACT uses); ``dim`` divisible by 4."""
    if dim % 4:
        raise ValueError(f"grid_embedding.dim: expected a multiple of 4, got {dim}")
    rows = sinusoidal_embedding(torch.arange(h), dim // 2)[:, None].expand(h, w, dim // 2)
    cols = sinusoidal_embedding(torch.arange(w), dim // 2)[None].expand(h, w, dim // 2)
    return torch.cat([rows, cols], dim=-1).reshape(h * w, dim)
