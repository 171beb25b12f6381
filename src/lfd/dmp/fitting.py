"""Learning forcing-term weights from demonstrations.

Two estimators, both vectorised over a leading batch of demonstrations ``(B, ...)``
sharing one time grid, neither forming a ``T x T`` matrix:

- :class:`TrajectoryFit` (default of ``fit``): ridge-regularised least squares on the
  *positions*. The rollout is exactly linear in the weights (:mod:`lfd.dmp.transform`), so
  the weights minimising the reproduction error come from one ``(K, T)`` regularised
  pseudo-inverse shared by all DoFs and demonstrations (O(T K^2) once per time grid, then
  O(B T K D)). No numerical differentiation of the demonstration is needed.
- :func:`lwr_weights`: the thesis's per-basis locally weighted regression of the
  forcing target ``f_target = tau^2 ddy - alpha_z (beta_z (g - y) - tau dy)``, O(B T K D).
  Cheaper and local, but at 20 bases it reproduces curved demonstrations far less
  accurately (it averages the target over each basis instead of interpolating it).

Both return *amplitude-scaled* weights ``v`` (the forcing input is ``features @ v``); the
weights ``w`` follow from the formulation (:func:`lfd.dmp.formulation.unscale_weights` for
discrete DMPs, ``v / r`` for rhythmic ones).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from lfd import checks

from .transform import RolloutOperator

__all__ = [
    "DEFAULT_RIDGE",
    "TrajectoryFit",
    "check_demonstration",
    "check_ridge",
    "demo_derivatives",
    "forcing_target",
    "lwr_weights",
]


def check_demonstration(t, y) -> tuple[np.ndarray, np.ndarray]:
    """A demonstration ``(t (T,), y (T, D) or (B, T, D))`` with ``T >= 3``, as float64 arrays.

    Raises:
        ValueError: ``t`` not a strictly increasing finite grid of at least 3 samples, ``y``
            not 2-D/3-D, NaN/inf, or ``y``'s sample axis not ``len(t)`` long.
    """
    times = checks.time_grid(t, min_samples=3)
    positions = checks.finite_array(y, "y", ndim=(2, 3))
    if positions.shape[-2] != times.shape[0]:
        raise ValueError(
            f"y must have shape (T, D) or (B, T, D) with T = len(t) = {times.shape[0]}, got {positions.shape}"
        )
    return times, positions


def demo_derivatives(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of sampled positions by second-order finite differences.

    Uses ``np.gradient(..., t, edge_order=2)`` twice, which is second-order accurate on
    non-uniform grids, including the end points.

    Args:
        t: ``(T,)`` strictly increasing sample times in seconds, ``T >= 3``.
        y: ``(..., T, D)`` positions.

    Returns:
        ``(dy, ddy)``, each ``(..., T, D)``, in ``y/s`` and ``y/s^2``.
    """
    dy = np.gradient(y, t, axis=-2, edge_order=2)
    ddy = np.gradient(dy, t, axis=-2, edge_order=2)
    return dy, ddy


def forcing_target(
    y: np.ndarray,
    dy: np.ndarray,
    ddy: np.ndarray,
    goal: np.ndarray,
    tau: float,
    alpha_z: float,
    beta_z: float,
) -> np.ndarray:
    """Forcing term that would reproduce the demonstration exactly.

    ``f_target = tau^2 ddy - alpha_z (beta_z (g - y) - tau dy)``.

    Args:
        y, dy, ddy: ``(..., T, D)`` positions, velocities, accelerations.
        goal: ``(..., D)`` goal positions.
        tau: temporal scaling in seconds.
        alpha_z, beta_z: transformation-system gains.

    Returns:
        ``(..., T, D)`` target forcing values (units of ``y``).
    """
    return tau**2 * ddy - alpha_z * (beta_z * (goal[..., None, :] - y) - tau * dy)


def lwr_weights(activations: np.ndarray, phase: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Per-basis locally weighted regression of the forcing target (amplitude-scaled).

    ``w_i = (xi^T Gamma_i f) / (xi^T Gamma_i xi)`` with ``xi = s * a`` and
    ``Gamma_i = diag(psi_i(s_t))``; this returns ``v_i = a w_i = (sum_t psi_it s_t f_t) / (sum_t psi_it s_t^2)``.
    A basis with no support on the samples (all ``psi_it`` underflow) gets weight 0.

    Args:
        activations: ``(T, K)`` un-normalised basis activations ``psi_i(s_t)``.
        phase: ``(T,)`` phase ``s_t`` (ones for the rhythmic DMP).
        target: ``(..., T, D)`` forcing targets (see :func:`forcing_target`).

    Returns:
        Amplitude-scaled weights ``(..., D, K)``.
    """
    numerator = np.einsum("tk,t,...td->...dk", activations, phase, target)
    denominator = np.einsum("tk,t->k", activations, phase**2)
    return np.divide(numerator, denominator, out=np.zeros_like(numerator), where=denominator > 0)


#: Default ridge strength of the trajectory fit, relative to the largest squared singular
#: value of the (end-weighted) response matrix; chosen by measurement on coarse grids and
#: LASA (``benchmarks/dmp_ridge.py``, docs/dmp.md "Regularised fitting").
DEFAULT_RIDGE = 1e-12


def check_ridge(ridge) -> float:
    """``ridge`` as a finite float ``>= 0``, else ``ValueError``."""
    return checks.check_float(ridge, "ridge", low=0.0)


@dataclass(frozen=True)
class TrajectoryFit:
    """Ridge (Tikhonov) least-squares fit of amplitude-scaled weights to positions on one grid.

    The rollout from start ``y0`` (scaled velocity ``z0``) towards ``g`` is
    ``y = g + E_ee (y0 - g) + E_ez z0 + Phi v``; the weights minimising
    ``sum_t c_t^2 |y_t - free_t - Phi_t v|^2 + lambda |v|^2`` are ``v = S (y - free)``.
    ``c_t = 1`` except for the final sample, ``c_{T-1} = sqrt(T)``: the end point counts as
    much as all other samples together, so the rollout ends where the demonstration ends
    (reaching accuracy) at a negligible cost in RMSE. ``lambda = ridge * sigma_max^2``
    (``sigma_max`` the largest singular value of ``C Phi``), so ``ridge`` is dimensionless
    and independent of the number of samples; ``ridge = 0`` is the plain pseudo-inverse
    (the response matrix has condition numbers of ~1e6 at 20 bases: on grids of 30-50
    samples it interpolates them with weights of 1e5-1e6 that oscillate between samples).

    Attributes:
        initial: ``(T, 2)`` position response ``[E_ee, E_ez]`` to the start state.
        solver: ``(K, T)`` regularised pseudo-inverse ``S`` of ``Phi`` (thin SVD).
    """

    initial: Tensor
    solver: Tensor

    @classmethod
    def from_operator(cls, operator: RolloutOperator, ridge: float = DEFAULT_RIDGE) -> TrajectoryFit:
        """Precompute from a float64 operator (O(T K^2), once per time grid).

        Args:
            operator: rollout operator on the demonstration's grid.
            ridge: relative Tikhonov strength (>= 0), see the class docstring.
        """
        n_steps = operator.forced.shape[-3]
        rows = torch.ones(n_steps, dtype=operator.forced.dtype)
        rows[-1] = n_steps**0.5
        u, sigma, vh = torch.linalg.svd(operator.forced[:, 0, :] * rows[:, None], full_matrices=False)
        if ridge > 0:
            gain = sigma / (sigma**2 + ridge * sigma[0] ** 2)
        else:  # pinv's cut-off
            cutoff = sigma[0] * max(u.shape) * torch.finfo(sigma.dtype).eps
            gain = torch.where(sigma > cutoff, 1.0 / sigma, torch.zeros_like(sigma))
        solver = (vh.transpose(-1, -2) * gain) @ u.transpose(-1, -2) * rows
        return cls(operator.initial[:, 0, :], solver)

    def weights(self, y: np.ndarray, goal: np.ndarray, z0: np.ndarray | None = None) -> np.ndarray:
        """Amplitude-scaled weights ``(..., D, K)`` for positions ``y`` ``(..., T, D)``.

        Args:
            y: demonstrated positions; the start is ``y[..., 0, :]``.
            goal: ``(..., D)`` goal (discrete) or anchor (rhythmic) positions.
            z0: ``(..., D)`` start scaled velocity ``tau * dy/dt(0)``; ``None`` means zero.
        """
        positions, anchor = torch.from_numpy(y), torch.from_numpy(goal)[..., None, :]
        free = anchor + self.initial[:, :1] * (positions[..., :1, :] - anchor)
        if z0 is not None:
            free = free + self.initial[:, 1:] * torch.from_numpy(z0)[..., None, :]
        return (self.solver @ (positions - free)).transpose(-1, -2).numpy()
