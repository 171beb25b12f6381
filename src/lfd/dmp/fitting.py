"""Learning forcing-term weights from demonstrations.

Two estimators, both vectorised over a leading batch of demonstrations ``(B, ...)``
sharing one time grid, neither forming a ``T x T`` matrix:

- :class:`TrajectoryFit` (default of ``fit``): least squares on the *positions*.
  The rollout is exactly linear in the weights (:mod:`lfd.dmp.transform`), so the weights
  minimising the reproduction error come from one ``(T, K)`` pseudo-inverse shared by all
  DoFs and demonstrations (O(T K^2) once per time grid, then O(B T K D)). No numerical
  differentiation of the demonstration is needed.
- :func:`lwr_weights`: SPEC section 1's per-basis locally weighted regression of the
  forcing target ``f_target = tau^2 ddy - alpha_z (beta_z (g - y) - tau dy)``, O(B T K D).
  Cheaper and local, but at 20 bases it reproduces curved demonstrations far less
  accurately (it averages the target over each basis instead of interpolating it).

Both return *amplitude-scaled* weights ``v = w * a`` (``a = g - y0`` for discrete DMPs,
``r`` for rhythmic ones); divide by the amplitude with :func:`safe_inverse_amplitude`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from .transform import RolloutOperator

__all__ = [
    "TrajectoryFit",
    "demo_derivatives",
    "forcing_target",
    "lwr_weights",
    "safe_inverse_amplitude",
]

#: Relative size (w.r.t. the demonstration's extent) at or below which a start-to-goal
#: displacement ``g - y0`` counts as zero; see :func:`safe_inverse_amplitude`.
ZERO_DISPLACEMENT = 1e-8


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
    y: np.ndarray, dy: np.ndarray, ddy: np.ndarray, goal: np.ndarray, tau: float, alpha_z: float, beta_z: float
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


def safe_inverse_amplitude(displacement: np.ndarray, extent: np.ndarray) -> np.ndarray:
    """``1 / (g - y0)`` used to turn amplitude-scaled weights into weights, 0 for zero-length DoFs.

    The discrete forcing term scales with ``a = g - y0``, so weights are ``v / a``. A DoF with
    ``|a| <= ZERO_DISPLACEMENT * extent`` counts as zero-length: its factor (hence its
    weights) is 0, so it stays at rest in every rollout from the same start and moves
    straight to a new goal. A stationary DoF is thereby reproduced exactly; one that moves
    and returns to its start cannot be represented by this DMP formulation (see
    :func:`warn_if_returning`).

    Args:
        displacement: ``(..., D)`` start-to-goal displacement ``g - y0``.
        extent: ``(...)`` largest distance of the demonstration from its start (all DoFs).

    Returns:
        ``(..., D)`` finite factors.
    """
    moving = np.abs(displacement) > ZERO_DISPLACEMENT * extent[..., None]
    return np.divide(1.0, displacement, out=np.zeros_like(displacement), where=moving)


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


@dataclass(frozen=True)
class TrajectoryFit:
    """Least-squares fit of amplitude-scaled weights to positions on one time grid.

    The rollout from start ``y0`` (scaled velocity ``z0``) towards ``g`` is
    ``y = g + E_ee (y0 - g) + E_ez z0 + Phi v``; the weights minimising
    ``sum_t c_t^2 |y_t - free_t - Phi_t v|^2`` are ``v = S (y - free)``. ``c_t = 1`` except
    for the final sample, ``c_{T-1} = sqrt(T)``: the end point counts as much as all other
    samples together, so the rollout ends where the demonstration ends (reaching accuracy)
    at a negligible cost in RMSE.

    Attributes:
        initial: ``(T, 2)`` position response ``[E_ee, E_ez]`` to the start state.
        solver: ``(K, T)`` weighted pseudo-inverse ``S`` of ``Phi`` (thin SVD).
    """

    initial: Tensor
    solver: Tensor

    @classmethod
    def from_operator(cls, operator: RolloutOperator) -> TrajectoryFit:
        """Precompute from a float64 operator (O(T K^2), once per time grid)."""
        n_steps = operator.forced.shape[-3]
        rows = torch.ones(n_steps, dtype=operator.forced.dtype)
        rows[-1] = n_steps**0.5
        solver = torch.linalg.pinv(operator.forced[:, 0, :] * rows[:, None]) * rows
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


def warn_if_returning(positions: np.ndarray, displacement: np.ndarray, extent: np.ndarray) -> None:
    """``RuntimeWarning`` for DoFs that move but end where they started (zero-length, yet not at rest).

    Args:
        positions: ``(..., T, D)`` demonstration; displacement: ``(..., D)``; extent: ``(...)``.
    """
    threshold = ZERO_DISPLACEMENT * extent[..., None]
    moving = np.max(np.abs(positions - positions[..., :1, :]), axis=-2) > threshold
    if np.any(moving & (np.abs(displacement) <= threshold)):
        warnings.warn(
            "a demonstrated DoF moves but ends at its start (g == y0); the discrete DMP forcing "
            "term scales with (g - y0), so that DoF is reproduced as staying at rest",
            RuntimeWarning,
            stacklevel=3,
        )
