"""Image encoder shared by the visuomotor policies: conv trunk + spatial soft-argmax.

The trunk maps an RGB image to a small set of 2-D keypoints ("where is the thing that
feature map c responds to"), following the deep spatial autoencoder / visuomotor
policy architecture: conv layers -> per-channel softmax over the image plane ->
expected image coordinates.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F


class SpatialSoftmax(nn.Module):
    """Per-channel spatial soft-argmax with a learned temperature.

    For each channel c of a feature map ``x (B, C, H, W)``::

        p_c(i, j) = softmax_{i,j}(x_c(i, j) / temperature)
        k_c = sum_{i,j} p_c(i, j) * (u_j, v_i)

    where ``u_j`` and ``v_i`` are the column and row coordinates, spaced evenly in
    ``[-1, 1]`` (``-1`` = left / top pixel centre, ``+1`` = right / bottom pixel centre).

    Args:
        temperature: initial softmax temperature (> 0). Learned in log space.
        learn_temperature: if False the temperature stays fixed.

    Returns (from ``forward``): keypoints ``(B, 2C)`` laid out ``[x_0, y_0, x_1, y_1, ...]``.
    """

    def __init__(self, temperature: float = 1.0, learn_temperature: bool = True) -> None:
        super().__init__()
        if temperature <= 0:
            raise ValueError(f"SpatialSoftmax: temperature must be > 0, got {temperature}")
        log_t = torch.tensor(math.log(temperature), dtype=torch.float32)
        if learn_temperature:
            self.log_temperature = nn.Parameter(log_t)
        else:
            self.register_buffer("log_temperature", log_t)

    @property
    def temperature(self) -> torch.Tensor:
        return self.log_temperature.exp()

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.ndim != 4:
            raise ValueError(f"SpatialSoftmax expects (B, C, H, W), got shape {tuple(x.shape)}")
        b, c, h, w = x.shape
        p = F.softmax(x.flatten(2) / self.temperature, dim=-1).view(b, c, h, w)
        xs = torch.linspace(-1.0, 1.0, w, dtype=x.dtype, device=x.device)
        ys = torch.linspace(-1.0, 1.0, h, dtype=x.dtype, device=x.device)
        kx = (p.sum(dim=2) * xs).sum(dim=-1)  # marginal over rows -> (B, C)
        ky = (p.sum(dim=3) * ys).sum(dim=-1)  # marginal over columns -> (B, C)
        return torch.stack((kx, ky), dim=-1).flatten(1)

    def spread(self, x: torch.Tensor) -> torch.Tensor:
        """The standard deviations of each channel's softmax distribution along the columns and
        rows, ``(B, 2C)`` laid out ``[sx_0, sy_0, ...]``, in cells of the map: how far the
        response spreads around its keypoint, e.g. the apparent size of an object the channel
        responds to all over (larger when nearer the camera)."""
        b, c, h, w = x.shape
        p = F.softmax(x.flatten(2) / self.temperature, dim=-1).view(b, c, h, w)
        xs = torch.arange(w, dtype=x.dtype, device=x.device)
        ys = torch.arange(h, dtype=x.dtype, device=x.device)
        px, py = p.sum(dim=2), p.sum(dim=3)
        vx = (px * xs**2).sum(-1) - (px * xs).sum(-1) ** 2
        vy = (py * ys**2).sum(-1) - (py * ys).sum(-1) ** 2
        return torch.stack((vx, vy), dim=-1).clamp_min(1e-6).sqrt().flatten(1)


class KeypointEncoder(nn.Module):
    """Conv trunk + spatial soft-argmax: image ``(B, in_channels, H, W)`` in [0, 1] -> keypoints ``(B, 2C)``.

    Layer ``0`` has a 5x5 kernel with stride 2 (halves the resolution, as in the visuomotor
    policy papers); the following ones are 3x3, stride 1, padded. Each conv is followed by
    batch norm and ReLU, except the last, whose raw response feeds the soft-argmax.

    Args:
        channels: output channels per conv layer, e.g. ``(32, 32, 32, 32)``. The number of
            keypoints is ``channels[-1]``.
        temperature: initial soft-argmax temperature.
        global_pool: also output each channel's spatial maximum of the last (raw) feature map,
            ``(B, C)`` after the keypoints: *whether* and how strongly a feature is present,
            which keypoints (only *where*) cannot say. It lets the head tell object kinds
            apart (e.g. a box, approached from the top, from a cylinder, from the side).
        in_channels: 3 (RGB) or 4 (RGB-D, :func:`lfd.sim.depth.rgbd_image`).

    Output: ``(B, 2C)`` keypoints ``[x_0, y_0, ...]`` in ``[-1, 1]``, then with
    ``global_pool`` the ``(B, C)`` maxima, then with :attr:`spread_channels` ``= S`` (an attribute,
    0 by default: no parameters depend on it) the ``(B, 2S)`` spreads of the first ``S`` channels
    (:meth:`SpatialSoftmax.spread`) (:attr:`out_dim` is the total).
    """

    def __init__(
        self,
        channels: tuple[int, ...] | list[int] = (32, 32, 32, 32),
        temperature: float = 1.0,
        global_pool: bool = False,
        in_channels: int = 3,
    ) -> None:
        super().__init__()
        channels = [int(c) for c in channels]
        if not channels or min(channels) < 1:
            raise ValueError(
                f"KeypointEncoder: channels must be a non-empty list of positive ints, got {channels}"
            )
        if in_channels not in (3, 4):
            raise ValueError(
                f"KeypointEncoder.in_channels: expected 3 (RGB) or 4 (RGB-D), got {in_channels!r}"
            )
        layers: list[nn.Module] = []
        c_in = self.in_channels = int(in_channels)
        for i, c_out in enumerate(channels):
            first = i == 0
            layers.append(
                nn.Conv2d(
                    c_in,
                    c_out,
                    kernel_size=5 if first else 3,
                    stride=2 if first else 1,
                    padding=2 if first else 1,
                )
            )
            if i < len(channels) - 1:
                layers += [nn.BatchNorm2d(c_out), nn.ReLU(inplace=True)]
            c_in = c_out
        self.convs = nn.Sequential(*layers)
        self.softargmax = SpatialSoftmax(temperature)
        self.global_pool = bool(global_pool)
        self.n_channels = channels[-1]
        self.spread_channels = 0

    @property
    def out_dim(self) -> int:
        """Size of :meth:`forward`'s output per image."""
        return (3 if self.global_pool else 2) * self.n_channels + 2 * self.spread_channels

    @staticmethod
    def pixel_keypoints(pixels: torch.Tensor, image_size: int) -> torch.Tensor:
        """Image positions ``(..., 2)`` (``u`` right, ``v`` down, pixels from the image's top-left
        corner; a pixel's centre at ``+0.5``) of a square ``image_size`` image -> the keypoint
        coordinates ``(..., 2)`` the soft-argmax gives a feature map peaked there (``[-1, 1]``
        across the first layer's output cells: cell ``j``, centred on input pixel ``2 j``, is at
        ``-1 + 2 j / (w - 1)``, ``w`` cells)."""
        return -1.0 + (pixels - 0.5) / KeypointEncoder.pixels_per_unit(image_size)

    @staticmethod
    def pixels_per_unit(image_size: int) -> int:
        """Image pixels per keypoint unit of a square ``image_size`` image: ``w - 1`` for the
        ``w`` output cells of the 5x5, stride 2, pad 2 first layer (2 px each, over 2 units)."""
        return (int(image_size) - 1) // 2

    def forward(self, image: torch.Tensor) -> torch.Tensor:
        maps = self.convs(image - 0.5)
        keypoints = self.softargmax(maps)
        if not self.global_pool and not self.spread_channels:
            return keypoints
        parts = [keypoints]
        if self.global_pool:
            parts.append(maps.amax(dim=(2, 3)))
        if self.spread_channels:
            parts.append(self.softargmax.spread(maps[:, : self.spread_channels]))
        return torch.cat(parts, dim=1)


def mlp(in_dim: int, hidden: tuple[int, ...] | list[int], out_dim: int) -> nn.Sequential:
    """Fully connected ReLU network ``in_dim -> hidden... -> out_dim`` (linear output)."""
    layers: list[nn.Module] = []
    for h in hidden:
        layers += [nn.Linear(in_dim, int(h)), nn.ReLU(inplace=True)]
        in_dim = int(h)
    layers.append(nn.Linear(in_dim, out_dim))
    return nn.Sequential(*layers)


def image_to_tensor(image: np.ndarray | torch.Tensor, channels: int = 3) -> torch.Tensor:
    """Camera image(s) -> float tensor ``(B, channels, H, W)`` in [0, 1].

    Accepts uint8 ``(H, W, C)`` / ``(B, H, W, C)`` (as rendered) or float ``(C, H, W)`` /
    ``(B, C, H, W)`` already in [0, 1] (as stored in the datasets). With ``channels=3`` (RGB)
    a 4th uint8 channel (alpha) is dropped; with ``channels=4`` (RGB-D,
    :func:`lfd.sim.depth.rgbd_image`) the image must have it.
    """
    if channels not in (3, 4):
        raise ValueError(f"image_to_tensor.channels: expected 3 (RGB) or 4 (RGB-D), got {channels!r}")
    t = torch.as_tensor(image)
    if t.ndim == 3:
        t = t.unsqueeze(0)
    if t.ndim != 4:
        raise ValueError(
            f"image must be (H, W, C), (B, H, W, C), (C, H, W) or (B, C, H, W); got shape {tuple(t.shape)}"
        )
    what = "RGB-D images with 4 channels (lfd.sim.depth.rgbd_image)" if channels == 4 else "RGB images"
    if t.dtype == torch.uint8:
        if t.shape[-1] not in (channels, 4):
            raise ValueError(
                f"expected uint8 {what}, channels-last (..., H, W, {channels}); got shape {tuple(t.shape)}"
            )
        return t[..., :channels].permute(0, 3, 1, 2).float().div_(255.0)
    if t.shape[1] != channels:
        raise ValueError(
            f"expected float {what}, channels-first (B, {channels}, H, W); got shape {tuple(t.shape)}"
        )
    return t.float()


def permute_colour_channels(image: torch.Tensor) -> torch.Tensor:
    """Training-time colour augmentation: each image of ``(B, C, H, W)`` gets its RGB
    channels (the first 3) in a random order (grey surfaces stay grey, object colours
    change), so a network cannot tell object families apart by the colours of the training
    instances. A depth channel (``C = 4``) stays where it is."""
    rgb = image[:, :3]
    order = torch.argsort(torch.rand(image.shape[0], 3, device=image.device), dim=1)
    rgb = torch.gather(rgb, 1, order[:, :, None, None].expand_as(rgb))
    return torch.cat([rgb, image[:, 3:]], dim=1)


def foreground_mask(
    image: torch.Tensor, margin: float = 1.5 / 255, nearer_is_larger: bool = False
) -> torch.Tensor:
    """``(B, 1, H, W)`` bool: the pixels of an RGB-D batch ``(B, 4, H, W)`` (depth channel of
    :func:`lfd.sim.depth.rgbd_image`) nearer than the farthest depth any image of the batch
    has at that pixel, by more than ``margin``. The table and floor never move, so that
    farthest depth is the empty scene wherever one image of the batch leaves the pixel free
    (objects cover ~0.5 % of an image); the mask is then the object and whatever of the arm
    is in view. A batch of one has no foreground. ``nearer_is_larger``: the channel grows
    towards the camera (the relief encoding) instead of away from it (the range encoding)."""
    if image.ndim != 4 or image.shape[1] != 4:
        raise ValueError(
            f"foreground_mask: expected an RGB-D batch (B, 4, H, W), got shape {tuple(image.shape)}"
        )
    depth = -image[:, 3:] if nearer_is_larger else image[:, 3:]
    return depth < depth.amax(dim=0, keepdim=True) - margin


def brightness_range(value, depth: bool, owner: str) -> list[float] | None:
    """A validated ``brightness_augment`` option: None, or ``[low, high]`` as floats.

    Raises:
        ValueError (naming ``owner``): not two finite numbers with ``0 < low <= high``, or
            given without ``depth`` (the depth channel tells the object from the table).
    """
    if value is None:
        return None
    values = list(value)
    if (
        len(values) != 2
        or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)
        or not 0 < values[0] <= values[1]
    ):
        raise ValueError(
            f"{owner}.brightness_augment: expected [low, high] with 0 < low <= high, or null; got {value!r}"
        )
    if not depth:
        raise ValueError(f"{owner}.brightness_augment: needs depth=true (the depth channel finds the object)")
    return [float(v) for v in values]


def scale_foreground_brightness(
    image: torch.Tensor, low: float, high: float, nearer_is_larger: bool = False
) -> torch.Tensor:
    """Training-time albedo augmentation of an RGB-D batch ``(B, 4, H, W)`` in [0, 1]: the
    RGB of each image's foreground (:func:`foreground_mask`) times a factor drawn
    log-uniformly from ``[low, high]``, clipped to 1; background and depth unchanged. Diffuse
    shading is proportional to the surface colour, so this renders each training object as a
    darker or paler one of the same shape: dark objects, whose faces differ little in
    brightness, and near-white ones are otherwise rare cases for the shape cue.
    ``nearer_is_larger``: as in :func:`foreground_mask`."""
    if not 0 < low <= high:
        raise ValueError(f"scale_foreground_brightness: need 0 < low <= high, got [{low}, {high}]")
    mask = foreground_mask(image, nearer_is_larger=nearer_is_larger)
    u = torch.rand(image.shape[0], 1, 1, 1, device=image.device, dtype=image.dtype)
    factor = torch.exp(math.log(low) + u * (math.log(high) - math.log(low)))
    rgb = torch.where(mask, (image[:, :3] * factor).clamp_(max=1.0), image[:, :3])
    return torch.cat([rgb, image[:, 3:]], dim=1)


#: The 6 orders of the RGB channels (:func:`all_colour_orders`).
COLOUR_ORDERS = tuple(itertools.permutations(range(3)))


def all_colour_orders(image: torch.Tensor) -> torch.Tensor:
    """Test-time counterpart of :func:`permute_colour_channels`: ``(B, C, H, W)`` ->
    ``(6 B, C, H, W)``, the batch once per order of :data:`COLOUR_ORDERS` (order-major). A
    depth channel (``C = 4``) stays where it is."""
    return torch.cat([torch.cat([image[:, list(order)], image[:, 3:]], dim=1) for order in COLOUR_ORDERS])
