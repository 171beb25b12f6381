"""The Diffusion Policy's noise-prediction network: a 1-D temporal convolutional U-Net over the
action sequence with FiLM conditioning (Chi et al. 2023, Sec. 3.4, CNN-based; after Janner et
al. 2022's Diffuser).

Input ``x`` ``(B, horizon, action_dim)`` (noisy normalised actions), diffusion step ``t``
``(B,)`` and the global condition ``(B, cond_dim)`` (observation features) -> predicted noise,
same shape as ``x``. Each residual block: conv (k=5) -> GroupNorm(8) -> Mish, FiLM
(``scale * h + bias`` per channel from the step embedding and the condition), conv ->
GroupNorm -> Mish, plus a 1x1 residual projection. Down path: two blocks per level and a
stride-2 conv (not after the last level); two middle blocks; up path: two blocks on the skip
connection's concatenation and a transposed conv; a final conv block and a 1x1 conv.
"""

from __future__ import annotations

import torch
from torch import nn

from lfd.visuomotor.policies.backbones import sinusoidal_embedding


class _ConvBlock(nn.Sequential):
    def __init__(self, c_in: int, c_out: int, kernel: int, groups: int = 8) -> None:
        super().__init__(
            nn.Conv1d(c_in, c_out, kernel, padding=kernel // 2), nn.GroupNorm(groups, c_out), nn.Mish()
        )


class _ResidualBlock(nn.Module):
    """Conditional residual block with FiLM (per-channel scale and bias)."""

    def __init__(self, c_in: int, c_out: int, cond_dim: int, kernel: int, groups: int) -> None:
        super().__init__()
        self.blocks = nn.ModuleList(
            [_ConvBlock(c_in, c_out, kernel, groups), _ConvBlock(c_out, c_out, kernel, groups)]
        )
        self.film = nn.Sequential(nn.Mish(), nn.Linear(cond_dim, 2 * c_out))
        self.residual = nn.Conv1d(c_in, c_out, 1) if c_in != c_out else nn.Identity()

    def forward(self, x: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        h = self.blocks[0](x)
        scale, bias = self.film(cond)[:, :, None].chunk(2, dim=1)
        h = self.blocks[1](scale * h + bias)
        return h + self.residual(x)


class ConditionalUnet1D(nn.Module):
    """Noise predictor ``(x (B, L, a), t (B,), cond (B, c)) -> (B, L, a)``.

    Args:
        action_dim: ``a``.
        cond_dim: ``c``, global condition size.
        down_dims: channels per level (the paper: 256, 512, 1024); ``L`` must be divisible by
            ``2 ** (len(down_dims) - 1)``.
        step_embed_dim: size of the diffusion-step embedding (sine, then an MLP with Mish).
        kernel_size, n_groups: conv kernel and GroupNorm groups (the paper: 5, 8).
    """

    def __init__(
        self,
        action_dim: int,
        cond_dim: int,
        down_dims: tuple[int, ...] | list[int] = (256, 512, 1024),
        step_embed_dim: int = 128,
        kernel_size: int = 5,
        n_groups: int = 8,
    ) -> None:
        super().__init__()
        dims = [int(d) for d in down_dims]
        if not dims or any(d < 1 or d % n_groups for d in dims):
            raise ValueError(
                f"ConditionalUnet1D.down_dims: expected multiples of n_groups={n_groups}, got {dims}"
            )
        self.levels = len(dims)
        self.step_embed_dim = step_embed_dim
        self.step_mlp = nn.Sequential(
            nn.Linear(step_embed_dim, 4 * step_embed_dim),
            nn.Mish(),
            nn.Linear(4 * step_embed_dim, step_embed_dim),
        )
        c = step_embed_dim + cond_dim

        def block(i: int, o: int) -> _ResidualBlock:
            return _ResidualBlock(i, o, c, kernel_size, n_groups)

        ins = [action_dim, *dims[:-1]]
        self.down = nn.ModuleList()
        for i, (d_in, d_out) in enumerate(zip(ins, dims)):
            last = i == len(dims) - 1
            self.down.append(
                nn.ModuleList(
                    [
                        block(d_in, d_out),
                        block(d_out, d_out),
                        nn.Identity() if last else nn.Conv1d(d_out, d_out, 3, 2, 1),
                    ]
                )
            )
        self.mid = nn.ModuleList([block(dims[-1], dims[-1]), block(dims[-1], dims[-1])])
        self.up = nn.ModuleList()
        for d_out, d_in in zip(reversed(dims[:-1]), reversed(dims[1:])):
            self.up.append(
                nn.ModuleList(
                    [block(2 * d_in, d_out), block(d_out, d_out), nn.ConvTranspose1d(d_out, d_out, 4, 2, 1)]
                )
            )
        self.final = nn.Sequential(
            _ConvBlock(dims[0], dims[0], kernel_size, n_groups), nn.Conv1d(dims[0], action_dim, 1)
        )

    def forward(self, x: torch.Tensor, t: torch.Tensor, cond: torch.Tensor) -> torch.Tensor:
        if x.shape[1] % (2 ** (self.levels - 1)):
            raise ValueError(
                f"ConditionalUnet1D: horizon {x.shape[1]} not divisible by {2 ** (self.levels - 1)}"
            )
        emb = self.step_mlp(sinusoidal_embedding(t.float(), self.step_embed_dim))
        c = torch.cat([emb, cond], dim=-1)
        h = x.transpose(1, 2)
        skips = []
        for b1, b2, down in self.down:
            h = b2(b1(h, c), c)
            skips.append(h)
            h = down(h)
        for m in self.mid:
            h = m(h, c)
        for b1, b2, up in self.up:
            h = torch.cat([h, skips.pop()], dim=1)
            h = up(b2(b1(h, c), c))
        return self.final(h).transpose(1, 2)
