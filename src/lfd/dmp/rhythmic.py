"""Rhythmic (periodic) dynamic movement primitive."""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import torch

from lfd import checks

from ._base import Primitive
from .canonical import rhythmic_activations, rhythmic_features
from .discrete import check_method
from .fitting import (
    DEFAULT_RIDGE,
    TrajectoryFit,
    check_demonstration,
    demo_derivatives,
    forcing_target,
    lwr_weights,
)
from .functional import evaluate
from .gains import Gains
from .transform import RolloutOperator, build_refined_operator

__all__ = ["RhythmicDMP", "rhythmic_operator"]


def rhythmic_operator(
    t: np.ndarray, tau, n_basis: int, gains: Gains, dtype=torch.float64, device=None
) -> RolloutOperator:
    """Rollout operator of a rhythmic DMP on the time grid ``t`` (seconds) for ``tau`` (seconds).

    The phase is ``phi = (t - t[0]) / tau`` (radians), so one period lasts ``2 pi tau``.
    Built in float64, returned in ``dtype`` on ``device``.
    """
    tau = torch.as_tensor(tau, dtype=torch.float64)
    phi = torch.as_tensor(t - t[0], dtype=torch.float64) / tau[..., None]

    def features_of(phase):
        return rhythmic_features(phase, n_basis, gains.overlap)

    return build_refined_operator(phi, features_of, tau, gains.alpha_z, gains.beta_z).to(dtype, device)


class RhythmicDMP(Primitive):
    """Multi-DoF rhythmic DMP: a spring-damper around an anchor driven by a periodic force.

    ``tau dz = alpha_z (beta_z (g - y) - z) + f(phi)``, ``tau dy = z``, ``tau dphi = 1``,
    ``f = r sum_i w_i psi_i / sum_i psi_i``, ``psi_i = exp(h (cos(phi - c_i) - 1))`` (von
    Mises bases, ``c_i = 2 pi i / K``). One period lasts ``2 pi tau`` seconds; ``g`` is the
    anchor (mean position) and ``r`` the amplitude (default 1).

    Args:
        n_basis: number of basis functions ``K`` per DoF (>= 1).
        alpha_z: damping gain (default 25).
        beta_z: spring gain (default ``alpha_z / 4``).
        overlap: activation of a basis at its neighbour's centre, in ``(0, 1)`` (sets ``h``).
        ridge: relative Tikhonov strength of the ``"trajectory"`` fit, as in :class:`lfd.dmp.DMP`.

    Attributes (after :meth:`fit`; one demonstration / a batch of ``B``):
        weights_: ``(D, K)`` / ``(B, D, K)`` forcing weights (for ``r = 1``).
        goal_: ``(D,)`` / ``(B, D)`` anchor, the time-average of the demonstration.
        y0_, yd0_: ``(D,)`` / ``(B, D)`` demonstrated start position and velocity (units/s).
        tau_: ``period / (2 pi)`` in seconds.
        duration_: ``t[-1] - t[0]`` of the demonstration in seconds.
        n_steps_: number of demonstration samples.
    """

    _KIND = "lfd.dmp.RhythmicDMP"
    _VECTORS = ("y0", "yd0", "goal")
    _SCALARS: ClassVar[dict] = {**Primitive._SCALARS, "duration": checks.positive_float}

    _MISSING_PARAMS: ClassVar[dict] = {"ridge": 0.0}  # files saved before ridge existed: pinv fit
    _PARAMS = ("n_basis", "alpha_z", "beta_z", "overlap", "ridge")
    _GAINS = Gains

    def __init__(
        self,
        n_basis: int = 20,
        alpha_z: float = 25.0,
        beta_z: float | None = None,
        overlap: float = 0.8,
        ridge: float = DEFAULT_RIDGE,
    ):
        self._set_params(n_basis, {"alpha_z": alpha_z, "beta_z": beta_z, "overlap": overlap}, ridge=ridge)

    @property
    def period_(self) -> float:
        """Learned period ``2 pi tau_`` in seconds."""
        return 2.0 * math.pi * self._fitted("tau", None)

    def fit(self, t, y, period: float | None = None, method: str = "trajectory") -> RhythmicDMP:
        """Learn the periodic forcing term from a demonstration.

        Args:
            t: ``(T,)`` sample times in seconds, strictly increasing, ``T >= 3``.
            y: ``(T, D)`` or ``(B, T, D)`` positions.
            period: period in seconds; default ``t[-1] - t[0]``, i.e. the samples cover
                exactly one period *including* its end point (``y[-1] ~ y[0]``).
            method: ``"trajectory"`` (least squares on positions from the demonstrated
                start state) or ``"lwr"`` (locally weighted regression of the forcing
                target); see :mod:`lfd.dmp.fitting`.

        Returns:
            ``self``.
        """
        check_method(method)
        t, y = check_demonstration(t, y)
        duration = float(t[-1] - t[0])
        tau = (duration if period is None else checks.positive_float(period, "period")) / (2.0 * math.pi)
        goal = np.trapezoid(y, t, axis=-2) / duration
        dy, ddy = demo_derivatives(t, y)
        if method == "trajectory":
            solver = TrajectoryFit.from_operator(
                rhythmic_operator(t, tau, self.n_basis, self.gains), self.ridge
            )
            self.weights_ = solver.weights(y, goal, tau * dy[..., 0, :])
        else:
            target = forcing_target(y, dy, ddy, goal, tau, self.alpha_z, self.beta_z)
            phi = torch.from_numpy((t - t[0]) / tau)
            activations = rhythmic_activations(phi, self.n_basis, self.overlap).numpy()
            self.weights_ = lwr_weights(activations, np.ones_like(t), target)
        self.y0_, self.yd0_, self.goal_ = y[..., 0, :], dy[..., 0, :], goal
        self.tau_, self.duration_, self.n_steps_ = tau, duration, int(t.shape[0])
        return self

    def rollout(
        self,
        t=None,
        y0=None,
        goal=None,
        tau=None,
        weights=None,
        return_derivatives: bool = False,
        yd0=None,
        r: float = 1.0,
    ):
        """Generate a periodic trajectory; the same keywords as :meth:`lfd.dmp.DMP.rollout`, plus ``r``.

        Defaults reproduce the demonstration, transformed: the start state is the
        demonstrated one mapped to the new anchor, amplitude and tempo,
        ``y0 = goal + r (y0_ - goal_)`` and ``yd0 = r yd0_ tau_ / tau``. Since the system is
        linear, ``rollout(r=a)`` is then exactly ``goal + a (rollout() - goal)``.

        Backend as :func:`lfd.dmp.rollout_batch`: numpy in, float64 numpy out (validated);
        if any of ``y0, goal, weights, tau, yd0`` is a ``torch.Tensor`` the result is a tensor,
        differentiable w.r.t. them (``tau`` as a tensor ``()`` or ``(B,)``).

        Args:
            t: ``(T,)`` output times in seconds (strictly increasing, start at ``t[0]``);
                default ``n_steps_`` samples over ``duration_ * tau / tau_``.
            y0, yd0: ``(D,)`` or ``(B, D)`` start position (units) and velocity (units/s).
            goal: ``(D,)`` or ``(B, D)`` anchor.
            tau: ``period / (2 pi)`` in seconds: a float, or a tensor ``()``/``(B,)``.
            weights: ``(D, K)`` or ``(B, D, K)``.
            return_derivatives: also return velocity (units/s) and acceleration (units/s^2).
            r: amplitude of the forcing term (finite, may be 0 or negative).

        Returns:
            Positions ``(T, D)`` or ``(B, T, D)`` (or the derivative triple).

        Raises:
            ValueError: shape mismatch, NaN/inf, ``tau <= 0``, bad ``t``, non-finite ``r``, or
                a missing value on an unfitted DMP.
        """
        if (
            isinstance(r, bool)
            or not isinstance(r, (int, float, np.floating, np.integer))
            or not np.isfinite(r)
        ):
            raise ValueError(f"r must be a finite number, got {r!r}")
        weights = self._fitted("weights", weights)
        if tuple(np.shape(weights))[-1:] != (self.n_basis,) or len(np.shape(weights)) not in (2, 3):
            raise ValueError(
                f"weights must have shape (D, K = {self.n_basis}) or (B, D, K), got {tuple(np.shape(weights))}"
            )
        n_dims = np.shape(weights)[-2]
        tau = self._fitted("tau", tau)
        tensor_tau = isinstance(tau, torch.Tensor)
        if not tensor_tau:
            tau = checks.positive_float(tau, "tau")
        goal = self._fitted("goal", goal)
        if not isinstance(goal, torch.Tensor):
            goal = checks.finite_array(goal, "goal", ndim=(1, 2))
        if tuple(goal.shape)[-1:] != (n_dims,) or goal.ndim not in (1, 2):
            raise ValueError(f"goal must have shape ({n_dims},) or (B, {n_dims}), got {tuple(goal.shape)}")
        if y0 is None:
            offset = self._fitted("y0", None) - self.goal_
            if isinstance(goal, torch.Tensor):
                offset = torch.as_tensor(offset, dtype=goal.dtype, device=goal.device)
            y0 = goal + r * offset
        if yd0 is None:
            demo = r * self._fitted("yd0", None) * self.tau_
            if tensor_tau:
                yd0 = torch.as_tensor(demo, dtype=tau.dtype, device=tau.device) / tau[..., None]
            else:
                yd0 = demo / tau
        if t is None:
            if tensor_tau and tau.ndim > 0:
                raise ValueError("t is required when tau has one value per sample")
            t = np.linspace(0.0, self._fitted("duration", None) * float(tau) / self.tau_, self.n_steps_)
        times = checks.time_grid(
            t.detach().cpu().numpy() if isinstance(t, torch.Tensor) else t, min_samples=1
        )

        def make_operator(grid, tau_value, n_basis, dtype, device):
            return rhythmic_operator(grid, tau_value, n_basis, self.gains, dtype, device)

        def scale(w, start, anchor, out=None):
            return w * float(r) if out is None else torch.mul(w, float(r), out=out)

        return evaluate(y0, goal, weights, times, tau, make_operator, scale, yd0, return_derivatives)
