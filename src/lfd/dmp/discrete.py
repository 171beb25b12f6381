"""Discrete (point-to-point) dynamic movement primitive, scikit-learn style."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import torch

from lfd import checks

from ._base import Primitive
from .canonical import discrete_activations, discrete_phase
from .fitting import (
    DEFAULT_RIDGE,
    check_demonstration,
    demo_derivatives,
    forcing_target,
    lwr_weights,
)
from .formulation import DEFAULT_FORMULATION, check_formulation, unscale_weights
from .functional import cached_trajectory_fit, grid_key, rollout_with_gains
from .stepping import advance, coupled_rollout

__all__ = ["DMP", "FIT_METHODS"]

#: Weight estimators accepted by ``fit(..., method=...)``; see :mod:`lfd.dmp.fitting`.
FIT_METHODS = ("trajectory", "lwr")


def check_method(method: str) -> str:
    """``method`` if it is one of :data:`FIT_METHODS`, else ``ValueError``."""
    return checks.check_choice(method, "method", FIT_METHODS)


class DMP(Primitive):
    """Multi-DoF discrete DMP with one shared phase (the thesis's formulation, ``docs/dmp.md``).

    ``tau dz = alpha_z (beta_z (g - y) - z) + F(s)``, ``tau dy = z``, ``tau ds = -alpha_s s``,
    ``f(s) = (sum_i w_i psi_i(s) / sum_i psi_i(s)) s``, ``psi_i = exp(-h_i (s - c_i)^2)``,
    centres evenly spaced in time over ``[0, tau]``, widths from the neighbour spacing.
    The forcing input ``F`` depends on ``formulation`` (:mod:`lfd.dmp.formulation`):
    ``"pastor"`` (default) ``F = K f(s) - K (g - y0) s`` with ``K = alpha_z beta_z``, which
    represents DoFs that end where they began; ``"ijspeert"`` ``F = f(s) (g - y0)``, which
    rescales the motion with a new goal but keeps a DoF with ``g == y0`` at rest.

    Args:
        n_basis: number of basis functions ``K`` per DoF (>= 1).
        alpha_z: damping gain (default 25).
        beta_z: spring gain (default ``alpha_z / 4``, critically damped).
        alpha_s: canonical-system decay (default ``alpha_z / 3``).
        overlap: activation of a basis at its neighbour's centre, in ``(0, 1)`` (default
            0.8: wide bases suit the default least-squares fit; use ~0.5 or less with
            ``fit(..., method="lwr")``).
        formulation: ``"pastor"`` (default) or ``"ijspeert"``; see :mod:`lfd.dmp.formulation`.
        ridge: Tikhonov strength of the ``"trajectory"`` fit, relative to the largest squared
            singular value of the response matrix (default ``1e-6``, chosen by measurement,
            see :class:`lfd.dmp.fitting.TrajectoryFit`); 0 is the plain pseudo-inverse.

    Attributes (after :meth:`fit`; shapes for one demonstration / a batch of ``B``):
        weights_: ``(D, K)`` / ``(B, D, K)`` forcing weights (units of ``y`` for
            ``"pastor"``, dimensionless for ``"ijspeert"``).
        y0_: ``(D,)`` / ``(B, D)`` demonstrated start (first sample).
        yd0_: ``(D,)`` / ``(B, D)`` start velocity in units/s (zero unless ``fit(yd0=...)``).
        goal_: ``(D,)`` / ``(B, D)`` demonstrated goal (last sample).
        tau_: duration ``t[-1] - t[0]`` of the demonstration in seconds.
        n_steps_: number of demonstration samples (default rollout length).

    Rollouts are exact for the spring-damper and use a first-order hold on the forcing
    term between samples (see :mod:`lfd.dmp.transform`); the first sample is the start,
    at rest.
    """

    _KIND = "lfd.dmp.DMP"
    _VECTORS = ("y0", "yd0", "goal")
    # files saved before these arguments existed: the formulation and the (unregularised) fit they used
    _MISSING_PARAMS: ClassVar[dict] = {"formulation": "ijspeert", "ridge": 0.0}

    def __init__(
        self,
        n_basis: int = 20,
        alpha_z: float = 25.0,
        beta_z: float | None = None,
        alpha_s: float | None = None,
        overlap: float = 0.8,
        formulation: str = DEFAULT_FORMULATION,
        ridge: float = DEFAULT_RIDGE,
    ):
        gains = {"alpha_z": alpha_z, "beta_z": beta_z, "alpha_s": alpha_s, "overlap": overlap}
        self._set_params(n_basis, gains, check_formulation(formulation), ridge)

    def fit(self, t, y, method: str = "trajectory", yd0=None) -> DMP:
        """Learn the forcing weights from one demonstration or a batch sharing ``t``.

        The start ``y0_`` is the first sample, the goal ``goal_`` the last, ``tau_`` the
        duration. ``method`` chooses the weight estimator (see :mod:`lfd.dmp.fitting`):

        - ``"trajectory"`` (default): least squares on the positions through the exact
          linear rollout map (end point emphasised); best reproduction, no numerical
          differentiation of the demonstration.
        - ``"lwr"``: the thesis's per-basis locally weighted regression of the forcing target,
          with velocities/accelerations from second-order finite differences (valid on
          non-uniform grids).

        Both are vectorised over the batch; the inputs are not modified.

        Zero-length motion (``g == y0``): the default ``"pastor"`` formulation reproduces a
        DoF that moves and returns to its start like any other. With ``"ijspeert"`` the
        forcing term scales with ``g - y0``, so such a DoF gets zero weights and stays at
        rest in every rollout; a stationary DoF is still reproduced exactly, one that moved
        triggers a ``RuntimeWarning`` (see :func:`lfd.dmp.formulation.unscale_weights`).

        Args:
            t: ``(T,)`` sample times in seconds, strictly increasing, ``T >= 3``.
            y: ``(T, D)`` positions, or ``(B, T, D)`` for ``B`` demonstrations.
            method: ``"trajectory"`` or ``"lwr"``.
            yd0: start velocity of the demonstration in units/s: ``None`` (default) starts
                at rest, ``"demo"`` estimates it from the samples (second-order finite
                differences), or a ``(D,)``/``(B, D)`` array. Learned as ``yd0_``, the
                default start velocity of :meth:`rollout`.

        Returns:
            ``self``.

        Raises:
            ValueError: bad shapes, NaN/inf, fewer than 3 samples, ``t`` not strictly
                increasing, unknown ``method``.
        """
        check_method(method)
        t, y = check_demonstration(t, y)
        tau = float(t[-1] - t[0])
        y0, goal = y[..., 0, :], y[..., -1, :]
        start_velocity = self._start_velocity(t, y, yd0)
        if method == "trajectory":
            solver = cached_trajectory_fit(grid_key(t), tau, self.n_basis, self.gains, self.ridge)
            scaled = solver.weights(y, goal, tau * start_velocity)
        else:
            dy, ddy = demo_derivatives(t, y)
            target = forcing_target(y, dy, ddy, goal, tau, self.alpha_z, self.beta_z)
            theta = torch.from_numpy((t - t[0]) / tau)
            activations = discrete_activations(theta, self.n_basis, self.alpha_s, self.overlap).numpy()
            scaled = lwr_weights(activations, discrete_phase(theta, self.alpha_s).numpy(), target)
        stiffness = self.alpha_z * self.beta_z
        self.weights_ = unscale_weights(scaled, y, y0, goal, self.formulation, stiffness)
        self.y0_, self.goal_, self.tau_, self.n_steps_ = y0, goal, tau, int(t.shape[0])
        self.yd0_ = start_velocity
        return self

    @staticmethod
    def _start_velocity(t: np.ndarray, y: np.ndarray, yd0) -> np.ndarray:
        """``(..., D)`` start velocity in units/s for :meth:`fit`."""
        if yd0 is None:
            return np.zeros_like(y[..., 0, :])
        if isinstance(yd0, str):
            if yd0 != "demo":
                raise ValueError(f"yd0 must be None, 'demo' or an array, got {yd0!r}")
            return demo_derivatives(t, y)[0][..., 0, :]
        velocity = checks.finite_array(yd0, "yd0", ndim=(1, 2))
        try:
            return np.broadcast_to(velocity, y[..., 0, :].shape).copy()
        except ValueError:
            raise ValueError(f"yd0 must have shape {y[..., 0, :].shape}, got {velocity.shape}") from None

    def _restore(self, fitted: dict) -> None:
        weights = np.asarray(fitted.get("weights", []))
        fitted = {"yd0": np.zeros(weights.shape[:-1]), **fitted}  # files from before yd0: at rest
        super()._restore(fitted)

    def rollout(
        self,
        t=None,
        y0=None,
        goal=None,
        tau=None,
        weights=None,
        return_derivatives: bool = False,
        yd0=None,
        coupling=None,
    ):
        """Generate a trajectory, optionally with a new start, goal, duration or weights.

        Every argument left as ``None`` takes the learned value. Batched inputs broadcast
        (e.g. one ``y0``/``goal`` and ``weights`` of shape ``(B, D, K)``) and share one
        cached linear operator, so ``B`` weight sets cost one matrix product.

        Args:
            t: ``(T,)`` output times in seconds, strictly increasing, the motion starting at
                ``t[0]``; default ``linspace(0, tau, n_steps_)``.
            y0: ``(D,)`` or ``(B, D)`` start position (at rest).
            goal: ``(D,)`` or ``(B, D)`` goal position.
            tau: duration in seconds (temporal scaling): a float, or a tensor ``()``/``(B,)``.
            weights: ``(D, K)`` or ``(B, D, K)`` forcing weights.
            return_derivatives: also return velocity and acceleration.
            yd0: ``(D,)`` or ``(B, D)`` start velocity in units/s (default ``yd0_``: zero
                unless the fit was given one; an unfitted DMP starts at rest).
            coupling: coupling terms (:mod:`lfd.dmp.coupling`, e.g. obstacle avoidance,
                joint limits). They make the motion nonlinear, so the rollout is then
                integrated step-wise (:func:`lfd.dmp.stepping.integrate`, same discretisation
                as the closed form, vectorised over the batch; numpy only, and with
                ``return_derivatives`` the acceleration is by finite differences).

        Returns:
            Positions ``(T, D)`` (``(B, T, D)`` if any input is batched); with
            ``return_derivatives`` the tuple ``(y, dy/dt [1/s], d2y/dt2 [1/s^2])``. numpy
            arrays, or tensors if any input is a tensor (see :func:`lfd.dmp.rollout_batch`).

        Raises:
            ValueError: shape mismatch (``y0``/``goal`` width vs ``D``, weights vs
                ``(D, K)``), NaN/inf, ``tau <= 0``, bad ``t``, or a missing value on an
                unfitted DMP.
        """
        y0, goal, tau, weights = (
            self._fitted(name, value)
            for name, value in (("y0", y0), ("goal", goal), ("tau", tau), ("weights", weights))
        )
        if np.shape(weights)[-1:] != (self.n_basis,):
            raise ValueError(
                f"weights must end with K = {self.n_basis} basis functions, got shape {tuple(np.shape(weights))}"
            )
        if t is None:
            if getattr(tau, "ndim", 0) != 0:
                raise ValueError("t is required when tau has one value per sample")
            t = np.linspace(0.0, checks.positive_float(float(tau), "tau"), self._fitted("n_steps", None))
        times = checks.time_grid(
            t.detach().cpu().numpy() if isinstance(t, torch.Tensor) else t, min_samples=1
        )
        if yd0 is None and self.is_fitted and np.any(self.yd0_ != 0):
            yd0 = self.yd0_
        if coupling:
            return coupled_rollout(
                times,
                y0,
                goal,
                tau,
                weights,
                yd0,
                coupling,
                return_derivatives,
                n_basis=self.n_basis,
                gains=self.gains,
                formulation=self.formulation,
            )
        return rollout_with_gains(
            y0,
            goal,
            weights,
            times,
            tau,
            self.gains,
            return_derivatives,
            formulation=self.formulation,
            yd0=yd0,
        )

    def step(
        self, state, dt: float, goal=None, *, y0=None, tau=None, weights=None, coupling=(), substeps: int = 1
    ):
        """Advance a running movement by ``dt`` seconds (online execution; pure function).

        Args:
            state: :class:`lfd.dmp.DMPState` (``y``, ``yd`` in units/s, elapsed ``t`` in s);
                start with ``DMPState(y0, yd0)``.
            dt: step in seconds.
            goal: current goal ``(D,)``/``(B, D)`` (may differ from step to step; default ``goal_``).
            y0: start of the movement (default ``y0_``); tau, weights: default the learned ones.
            coupling: coupling terms evaluated at the start of each sub-step.
            substeps: equal sub-steps (the closed-form rollout on a grid with step ``dt``
                seconds uses ``lfd.dmp.transform.substeps(dt / tau)``).

        Returns:
            The new :class:`lfd.dmp.DMPState`. :class:`lfd.dmp.DMPRunner` keeps the state for you.
        """
        y0, goal, tau, weights = (
            self._fitted(name, value)
            for name, value in (("y0", y0), ("goal", goal), ("tau", tau), ("weights", weights))
        )
        return advance(
            state,
            dt,
            y0=checks.finite_array(y0, "y0", ndim=(1, 2)),
            goal=checks.finite_array(goal, "goal", ndim=(1, 2)),
            weights=checks.finite_array(weights, "weights", ndim=(2, 3)),
            tau=checks.positive_float(float(tau), "tau"),
            n_basis=self.n_basis,
            gains=self.gains,
            formulation=self.formulation,
            coupling=coupling,
            substeps=substeps,
        )
