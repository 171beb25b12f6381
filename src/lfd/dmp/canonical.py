"""Canonical systems (phase variables) and basis functions of the forcing term.

All functions work on *normalised time* ``theta = (t - t0) / tau`` (dimensionless),
so a discrete movement runs from ``theta = 0`` to ``theta = 1`` and a rhythmic
one has phase ``phi = theta`` (radians, period ``2 * pi``).

The functions are written in torch so that the same code serves the numpy API
(:class:`lfd.dmp.DMP`) and the differentiable layer (:class:`lfd.dmp.DMPLayer`);
gradients flow through ``theta`` (hence through ``tau``).
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

__all__ = [
    "discrete_activations",
    "discrete_centres",
    "discrete_features",
    "discrete_phase",
    "discrete_widths",
    "rhythmic_activations",
    "rhythmic_centres",
    "rhythmic_features",
    "rhythmic_width",
]


def discrete_phase(theta: Tensor, alpha_s: float) -> Tensor:
    """Phase of the discrete canonical system ``tau * ds/dt = -alpha_s * s``, ``s(0) = 1``.

    Args:
        theta: normalised time ``(t - t0) / tau``, any shape (dimensionless).
        alpha_s: decay rate of the canonical system (> 0).

    Returns:
        ``s = exp(-alpha_s * theta)``, same shape as ``theta``, in ``(0, 1]``.
    """
    return torch.exp(-alpha_s * theta)


def discrete_centres(n_basis: int, alpha_s: float, *, dtype=torch.float64, device=None) -> Tensor:
    """Basis centres spaced evenly in *time*: ``c_i = exp(-alpha_s * i / (K - 1))``.

    Args:
        n_basis: number of basis functions ``K`` (>= 1); ``K = 1`` gives ``c = [1]``.
        alpha_s: decay rate of the canonical system.

    Returns:
        Centres in phase space, shape ``(K,)``, decreasing from 1 to ``exp(-alpha_s)``.
    """
    times = torch.linspace(0.0, 1.0, n_basis, dtype=dtype, device=device)
    return discrete_phase(times, alpha_s)


def discrete_widths(centres: Tensor, overlap: float) -> Tensor:
    """Widths ``h_i`` such that basis ``i`` has value ``overlap`` at the next centre.

    ``h_i = -ln(overlap) / (c_{i+1} - c_i)^2``; the last basis copies its neighbour's
    width. With a single basis the width is irrelevant (the normalised activation is
    identically 1) and is set to 1.

    Args:
        centres: ``(K,)`` centres from :func:`discrete_centres`.
        overlap: activation of a basis at its neighbour's centre, in ``(0, 1)``.

    Returns:
        Widths, shape ``(K,)``, in ``1 / phase^2``.
    """
    if centres.shape[-1] == 1:
        return torch.ones_like(centres)
    gaps = centres[1:] - centres[:-1]
    widths = -math.log(overlap) / gaps**2
    return torch.cat([widths, widths[-1:]])


def _discrete_log_psi(theta: Tensor, n_basis: int, alpha_s: float, overlap: float):
    """Phase ``s`` ``(..., T, 1)`` and ``log psi_i(s) = -h_i (s - c_i)^2`` ``(..., T, K)``."""
    centres = discrete_centres(n_basis, alpha_s, dtype=theta.dtype, device=theta.device)
    widths = discrete_widths(centres, overlap)
    s = discrete_phase(theta, alpha_s)[..., None]
    return s, -widths * (s - centres) ** 2


def discrete_activations(theta: Tensor, n_basis: int, alpha_s: float, overlap: float) -> Tensor:
    """Un-normalised activations ``psi_i(s) = exp(-h_i (s - c_i)^2)`` of the discrete bases.

    These are the locality weights ``Gamma_i`` of the per-basis regression in fitting.

    Args:
        theta: normalised time, shape ``(..., T)``.
        n_basis: number of basis functions ``K``.
        alpha_s: decay rate of the canonical system.
        overlap: basis overlap, see :func:`discrete_widths`.

    Returns:
        Activations in ``(0, 1]``, shape ``(..., T, K)``.
    """
    return torch.exp(_discrete_log_psi(theta, n_basis, alpha_s, overlap)[1])


def discrete_features(theta: Tensor, n_basis: int, alpha_s: float, overlap: float) -> Tensor:
    """Forcing-term features of the discrete DMP: ``s * psi_i(s) / sum_j psi_j(s)``.

    The forcing term is ``f = (features @ w) * (g - y0)``. The normalisation is a
    softmax of ``log psi``, so it never divides by an underflowed sum.

    Args:
        theta: normalised time, shape ``(..., T)``.
        n_basis: number of basis functions ``K``.
        alpha_s: decay rate of the canonical system.
        overlap: basis overlap, see :func:`discrete_widths`.

    Returns:
        Features, shape ``(..., T, K)``, same dtype/device as ``theta``.
    """
    s, log_psi = _discrete_log_psi(theta, n_basis, alpha_s, overlap)
    return s * torch.softmax(log_psi, dim=-1)


def rhythmic_centres(n_basis: int, *, dtype=torch.float64, device=None) -> Tensor:
    """Centres of the von Mises bases, evenly spaced on the circle: ``c_i = 2 pi i / K``.

    Returns:
        Centres in radians, shape ``(K,)``.
    """
    return 2.0 * math.pi * torch.arange(n_basis, dtype=dtype, device=device) / n_basis


def rhythmic_width(n_basis: int, overlap: float) -> float:
    """Concentration ``h`` such that a basis has value ``overlap`` at its neighbour's centre.

    ``h = -ln(overlap) / (1 - cos(2 pi / K))``; 1 for ``K = 1`` (irrelevant there).
    """
    if n_basis == 1:
        return 1.0
    return -math.log(overlap) / (1.0 - math.cos(2.0 * math.pi / n_basis))


def _rhythmic_log_psi(phi: Tensor, n_basis: int, overlap: float) -> Tensor:
    centres = rhythmic_centres(n_basis, dtype=phi.dtype, device=phi.device)
    return rhythmic_width(n_basis, overlap) * (torch.cos(phi[..., None] - centres) - 1.0)


def rhythmic_activations(phi: Tensor, n_basis: int, overlap: float) -> Tensor:
    """Un-normalised von Mises activations ``psi_i = exp(h (cos(phi - c_i) - 1))``.

    Args:
        phi: phase in radians, shape ``(..., T)``.
        n_basis: number of basis functions ``K``.
        overlap: basis overlap, see :func:`rhythmic_width`.

    Returns:
        Activations in ``(0, 1]``, shape ``(..., T, K)``.
    """
    return torch.exp(_rhythmic_log_psi(phi, n_basis, overlap))


def rhythmic_features(phi: Tensor, n_basis: int, overlap: float) -> Tensor:
    """Forcing-term features of the rhythmic DMP: ``psi_i(phi) / sum_j psi_j(phi)``.

    The forcing term is ``f = r * (features @ w)`` with amplitude ``r``.

    Args:
        phi: phase in radians (``phi = (t - t0) / tau``), shape ``(..., T)``.
        n_basis: number of basis functions ``K``.
        overlap: basis overlap, see :func:`rhythmic_width`.

    Returns:
        Features, shape ``(..., T, K)``; each row sums to 1.
    """
    return torch.softmax(_rhythmic_log_psi(phi, n_basis, overlap), dim=-1)
