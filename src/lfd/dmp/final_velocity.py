"""DMP with a final velocity (hitting, striking): Mülling, Kober, Kroemer, Peters, IJRR 2013.

The transformation system follows a moving target ``p(t)``, the quintic polynomial from the
start ``(y0, yd0, ydd0)`` at ``t = 0`` to the goal ``(g, gd, gdd)`` at ``t = tau``:

.. code-block:: text

    tau^2 ydd = alpha_z (beta_z (p - y) + tau (pd - yd)) + tau^2 pdd + K f(s),   K = alpha_z beta_z

(Mülling et al. eq. 6; ``movement_primitives.dmp.DMPWithFinalVelocity`` with its weights
``K w``). Written for the error ``e = y - p`` this is the linear spring-damper of
:class:`lfd.dmp.DMP` with start and goal 0 and forcing ``K f(s)`` (its ``"pastor"`` form with
``g = y0``), so ``y = p + e`` is evaluated with the exact linear rollout map of
:mod:`lfd.dmp.transform` -- no Euler integration, no time step -- and fitted with the exact
trajectory fit of ``e``. Changing the goal, the final velocity or ``tau`` changes only ``p``.

Boundary derivatives come from the demonstration by second-order finite differences
(:func:`lfd.dmp.fitting.demo_derivatives`); ``movement_primitives`` takes backward first-order
differences and sets the start velocity and acceleration to zero, which lags its final
velocity by half a sample (docs/dmp.md, "Final velocity").

Rollout times must lie within ``[t[0], t[0] + tau]``: after ``tau`` the hitting motion is over
(``movement_primitives`` then switches the target to a fixed ``g``, a jump in ``pd``).

Example::

    >>> import numpy as np
    >>> from lfd.dmp import FinalVelocityDMP
    >>> t = np.linspace(0.0, 1.0, 201)
    >>> y = np.stack([t**2, np.sin(2 * t)], axis=-1)           # ends moving: yd(1) = [2, 2 cos 2]
    >>> dmp = FinalVelocityDMP(n_basis=30).fit(t, y)
    >>> bool(np.abs(dmp.rollout() - y).max() < 1e-4)
    True
    >>> y, yd, _ = dmp.rollout(goal_velocity=[3.0, 0.0], return_derivatives=True)
    >>> np.round(yd[-1], 3)                                     # hits with the new velocity
    array([3., 0.])
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from lfd import checks

from ._base import Primitive
from .discrete import DMP
from .fitting import DEFAULT_RIDGE, check_demonstration, demo_derivatives

__all__ = ["FinalVelocityDMP", "quintic"]


def quintic(theta: np.ndarray, derivative: int = 0) -> np.ndarray:
    """Quintic Hermite basis ``(T, 6)`` at normalised times ``theta = t / tau`` ``(T,)``.

    Columns weigh ``y0, tau yd0, tau^2 ydd0, g, tau gd, tau^2 gdd``; ``derivative`` 1 or 2 gives
    the derivatives with respect to ``theta`` (divide by ``tau`` or ``tau^2`` for time).
    """
    s = np.asarray(theta, dtype=np.float64)[:, None]
    # coefficients of 1, s, ..., s^5 for each basis polynomial
    c = np.array(
        [
            [1, 0, 0, -10, 15, -6],
            [0, 1, 0, -6, 8, -3],
            [0, 0, 0.5, -1.5, 1.5, -0.5],
            [0, 0, 0, 10, -15, 6],
            [0, 0, 0, -4, 7, -3],
            [0, 0, 0, 0.5, -1, 0.5],
        ]
    ).T  # (power, basis)
    for _ in range(derivative):
        c = c[1:] * np.arange(1, c.shape[0])[:, None]
    return (s ** np.arange(c.shape[0])) @ c


class FinalVelocityDMP(Primitive):
    """Discrete DMP that reaches its goal with a given velocity (and acceleration) at ``tau``.

    Args:
        n_basis, alpha_z, beta_z, alpha_s, overlap, ridge: as :class:`lfd.dmp.DMP`
            (``alpha_s = log(100)`` and ``overlap = 0.8`` give ``movement_primitives``' basis).

    Attributes (after :meth:`fit`; ``(D,)`` per vector, ``(B, D)`` for a batch):
        weights_: ``(D, K)`` / ``(B, D, K)`` forcing weights, units of ``y``
            (``movement_primitives``' weights are ``alpha_z beta_z`` times these).
        y0_, yd0_, ydd0_: start position, velocity (units/s), acceleration (units/s^2).
        goal_, goal_velocity_, goal_acceleration_: the same at the end.
        tau_: duration in seconds; n_steps_: number of demonstration samples.
    """

    _KIND = "lfd.dmp.FinalVelocityDMP"
    _VECTORS = ("y0", "yd0", "ydd0", "goal", "goal_velocity", "goal_acceleration")
    _MISSING_PARAMS: ClassVar[dict] = {}
    _PARAMS = ("n_basis", "alpha_z", "beta_z", "alpha_s", "overlap", "ridge")

    def __init__(
        self,
        n_basis: int = 20,
        alpha_z: float = 25.0,
        beta_z: float | None = None,
        alpha_s: float | None = None,
        overlap: float = 0.8,
        ridge: float = DEFAULT_RIDGE,
    ):
        gains = {"alpha_z": alpha_z, "beta_z": beta_z, "alpha_s": alpha_s, "overlap": overlap}
        self._set_params(n_basis, gains, ridge=ridge)
        self._error = DMP(**self._dmp_params(formulation="pastor"))

    def fit(self, t, y) -> FinalVelocityDMP:
        """Learn from one demonstration ``(T, D)`` or a batch ``(B, T, D)`` sharing ``t``.

        Args:
            t: ``(T,)`` sample times in seconds, strictly increasing, ``T >= 3``.
            y: positions; the boundary velocities and accelerations are estimated from them.

        Returns:
            ``self``.

        Raises:
            ValueError: bad shapes, NaN/inf, fewer than 3 samples, ``t`` not increasing.
        """
        t, y = check_demonstration(t, y)
        tau = float(t[-1] - t[0])
        dy, ddy = demo_derivatives(t, y)
        self.y0_, self.yd0_, self.ydd0_ = y[..., 0, :], dy[..., 0, :], ddy[..., 0, :]
        self.goal_, self.goal_velocity_, self.goal_acceleration_ = (
            y[..., -1, :],
            dy[..., -1, :],
            ddy[..., -1, :],
        )
        self.tau_, self.n_steps_ = tau, int(t.shape[0])
        target = self._target(t - t[0], tau, *(getattr(self, n + "_") for n in self._VECTORS))
        error = y - target
        error[..., 0, :] = error[..., -1, :] = 0.0  # zero by construction, up to rounding
        self.weights_ = self._error.fit(t, error).weights_
        return self

    @staticmethod
    def _target(times, tau, y0, yd0, ydd0, goal, gd, gdd, derivative: int = 0) -> np.ndarray:
        """The polynomial ``p`` (or its time derivative) at ``times`` ``(T,)``: ``(..., T, D)``."""
        coefficients = np.stack(
            np.broadcast_arrays(y0, tau * yd0, tau**2 * ydd0, goal, tau * gd, tau**2 * gdd), -2
        )
        return np.einsum("tk,...kd->...td", quintic(times / tau, derivative), coefficients) / tau**derivative

    def rollout(
        self,
        t=None,
        y0=None,
        goal=None,
        goal_velocity=None,
        tau=None,
        weights=None,
        return_derivatives: bool = False,
        yd0=None,
        ydd0=None,
        goal_acceleration=None,
    ):
        """Positions ``(T, D)`` (``(B, T, D)`` if any input is batched), numpy.

        Every argument left as ``None`` takes the learned value.

        Args:
            t: ``(T,)`` output times in seconds within ``[t[0], t[0] + tau]``; default
                ``linspace(0, tau, n_steps_)``.
            y0, goal: ``(D,)`` or ``(B, D)`` start and goal positions.
            goal_velocity: ``(D,)`` or ``(B, D)`` velocity at ``tau``, units/s.
            tau: duration in seconds.
            weights: ``(D, K)`` or ``(B, D, K)``.
            return_derivatives: also return velocity and acceleration.
            yd0, ydd0, goal_acceleration: the other boundary derivatives (units/s, units/s^2).

        Raises:
            ValueError: bad shapes, NaN/inf, ``tau <= 0``, times beyond ``tau``, or a missing
                value on an unfitted DMP.
        """
        names = ("y0", "yd0", "ydd0", "goal", "goal_velocity", "goal_acceleration")
        given = (y0, yd0, ydd0, goal, goal_velocity, goal_acceleration)
        vectors = [checks.finite_array(self._fitted(n, v), n, ndim=(1, 2)) for n, v in zip(names, given)]
        tau = checks.positive_float(float(self._fitted("tau", tau)), "tau")
        weights = checks.finite_array(self._fitted("weights", weights), "weights", ndim=(2, 3))
        width = weights.shape[-2]
        if weights.shape[-1] != self.n_basis or any(v.shape[-1] != width for v in vectors):
            raise ValueError(
                f"weights must have shape (D, {self.n_basis}) and every boundary vector D = {width} values, "
                f"got weights {weights.shape} and {[v.shape for v in vectors]}"
            )
        if t is None:
            t = np.linspace(0.0, tau, self._fitted("n_steps", None))
        times = checks.time_grid(t, min_samples=1)
        times = times - times[0]
        if times[-1] > tau * (1 + 1e-12):
            raise ValueError(f"t must span at most tau = {tau} s (the hit is at tau), got {times[-1]} s")
        times = np.minimum(times, tau)
        zero = np.zeros(width)
        error = self._error.rollout(
            t=times, y0=zero, goal=zero, tau=tau, weights=weights, return_derivatives=return_derivatives
        )
        parts = error if return_derivatives else (error,)
        out = [self._target(times, tau, *vectors, derivative=k) + part for k, part in enumerate(parts)]
        return tuple(out) if return_derivatives else out[0]
