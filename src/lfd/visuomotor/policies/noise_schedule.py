"""DDPM noise schedule and DDIM sampler of the Diffusion Policy (Chi et al. 2023), written here
(``diffusers`` is not a dependency; this is the part of its ``DDPMScheduler`` /
``DDIMScheduler`` the policy uses, with the same conventions).

* Training (Ho et al. 2020): ``x_t = sqrt(a_t) x_0 + sqrt(1 - a_t) eps`` for a step ``t``
  drawn uniformly from ``0..T-1``, the network predicts ``eps``; ``a_t`` the cumulative
  product of ``1 - beta``.
* Schedule ``"squaredcos_cap_v2"`` (Nichol & Dhariwal 2021), the paper's:
  ``beta_i = min(1 - abar((i+1)/T) / abar(i/T), 0.999)``, ``abar(s) = cos((s + 0.008) / 1.008 pi/2)^2``;
  ``"linear"``: ``beta`` from ``1e-4`` to ``0.02``.
* Sampling (Song et al. 2021, DDIM, ``eta = 0``, deterministic): ``S`` steps at
  ``t = (S-1) r, ..., r, 0`` with ``r = T // S`` (diffusers' ``"leading"`` spacing); at each,
  ``x0 = (x - sqrt(1 - a_t) eps) / sqrt(a_t)`` (optionally clipped),
  ``x <- sqrt(a_prev) x0 + sqrt(1 - a_prev) eps`` with ``a_prev = a_{t - r}``, or 1 past the
  first step (``set_alpha_to_one``).
* Prediction types (diffusers' ``prediction_type``; Diffusion Policy's code has both):
  ``"epsilon"``, the network predicts the noise ``eps``; ``"sample"``, it predicts ``x0``
  itself and ``eps = (x - sqrt(a_t) x0) / sqrt(1 - a_t)`` (computed before clipping ``x0``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

#: Beta schedules.
SCHEDULES = ("squaredcos_cap_v2", "linear")
#: What the network predicts: the noise or the clean sample.
PREDICTIONS = ("epsilon", "sample")


def betas_for(schedule: str, n_train_steps: int) -> torch.Tensor:
    """``(T,)`` float64 noise variances of ``schedule`` (:data:`SCHEDULES`) over ``T = n_train_steps``."""
    if schedule not in SCHEDULES:
        raise ValueError(f"noise schedule: expected one of {SCHEDULES}, got {schedule!r}")
    if not (isinstance(n_train_steps, int) and n_train_steps >= 1):
        raise ValueError(f"noise schedule.n_train_steps: expected an int >= 1, got {n_train_steps!r}")
    if schedule == "linear":
        return torch.linspace(1e-4, 0.02, n_train_steps, dtype=torch.float64)

    def abar(s: float) -> float:
        return math.cos((s + 0.008) / 1.008 * math.pi / 2) ** 2

    t = n_train_steps
    return torch.tensor(
        [min(1 - abar((i + 1) / t) / abar(i / t), 0.999) for i in range(t)], dtype=torch.float64
    )


class NoiseSchedule(torch.nn.Module):
    """DDPM forward process and DDIM sampler.

    Args:
        n_train_steps: ``T``, diffusion steps in training (the paper: 100).
        schedule: one of :data:`SCHEDULES`.
        clip_sample: clip the predicted ``x0`` to ``[-clip_sample, clip_sample]`` at each
            sampling step (None: no clipping).
        prediction: one of :data:`PREDICTIONS`: what the network's output is (:meth:`target`
            gives its training target, :meth:`ddim_step` reads it).
    """

    def __init__(
        self,
        n_train_steps: int = 100,
        schedule: str = "squaredcos_cap_v2",
        clip_sample: float | None = None,
        prediction: str = "epsilon",
    ):
        super().__init__()
        if clip_sample is not None and not clip_sample > 0:
            raise ValueError(f"NoiseSchedule.clip_sample: expected a number > 0 or None, got {clip_sample}")
        if prediction not in PREDICTIONS:
            raise ValueError(f"NoiseSchedule.prediction: expected one of {PREDICTIONS}, got {prediction!r}")
        self.n_train_steps, self.clip_sample, self.prediction = n_train_steps, clip_sample, prediction
        betas = betas_for(schedule, n_train_steps)
        self.register_buffer("alphas_cumprod", torch.cumprod(1.0 - betas, 0).float(), persistent=False)

    def add_noise(self, x0: torch.Tensor, noise: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """``x_t`` ``(B, ...)`` for clean samples ``x0``, noise ``eps`` (same shape) and steps ``t`` ``(B,)``."""
        a = self.alphas_cumprod[t].reshape(-1, *([1] * (x0.dim() - 1)))
        return a.sqrt() * x0 + (1 - a).sqrt() * noise

    def target(self, x0: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """The network's training target for clean samples ``x0`` noised with ``noise``: ``noise``
        (``prediction="epsilon"``) or ``x0`` (``"sample"``)."""
        return noise if self.prediction == "epsilon" else x0

    def timesteps(self, n_steps: int) -> list[int]:
        """The ``S = n_steps`` DDIM steps, descending: ``(S-1) r, ..., 0`` with ``r = T // S``."""
        if not (isinstance(n_steps, int) and 1 <= n_steps <= self.n_train_steps):
            raise ValueError(f"DDIM n_steps: expected an int in 1..{self.n_train_steps}, got {n_steps!r}")
        r = self.n_train_steps // n_steps
        return [i * r for i in reversed(range(n_steps))]

    def split(self, out: torch.Tensor, t: int, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(x0, eps)`` (``x0`` unclipped) from the network's output ``out`` at ``(x_t, t)``
        (noise or sample, :attr:`prediction`)."""
        a = self.alphas_cumprod[t]
        if self.prediction == "epsilon":
            return (x - (1 - a).sqrt() * out) / a.sqrt(), out
        return out, (x - a.sqrt() * out) / (1 - a).sqrt()

    def ddim_step(self, out: torch.Tensor, t: int, x: torch.Tensor, prev_t: int) -> torch.Tensor:
        """One deterministic DDIM step from ``x_t`` to ``x_{prev_t}`` (``prev_t < 0``: to ``x0``),
        ``out`` the network's output at ``(x, t)`` (noise or sample, :attr:`prediction`)."""
        a_prev = self.alphas_cumprod[prev_t] if prev_t >= 0 else torch.ones((), device=x.device)
        x0, eps = self.split(out, t, x)
        if self.clip_sample is not None:
            x0 = x0.clamp(-self.clip_sample, self.clip_sample)
        return a_prev.sqrt() * x0 + (1 - a_prev).sqrt() * eps

    def sample(
        self,
        eps_model: Callable[[torch.Tensor, torch.Tensor], torch.Tensor],
        noise: torch.Tensor,
        n_steps: int,
    ) -> torch.Tensor:
        """DDIM sampling from ``noise`` (``x_T``, any shape ``(B, ...)``) with the network
        ``eps_model(x, t)`` (``t`` an int64 ``(B,)`` tensor; its output as :attr:`prediction`
        says) over ``n_steps`` steps; returns ``x0``."""
        steps = self.timesteps(n_steps)
        r = self.n_train_steps // n_steps
        x = noise
        for t in steps:
            tt = torch.full((x.shape[0],), t, dtype=torch.long, device=x.device)
            x = self.ddim_step(eps_model(x, tt), t, x, t - r)
        return x
