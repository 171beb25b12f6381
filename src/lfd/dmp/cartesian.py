"""Cartesian DMP: position and unit-quaternion orientation.

A pose is ``[x, y, z, qw, qx, qy, qz]`` (metres, unit quaternion). The position is an
ordinary 3-D discrete :class:`~lfd.dmp.DMP` (the exact linear rollout map, any
``formulation``). The orientation error ``e = 2 log(g * conj(q))`` (rotation vector from
the current orientation to the goal, radians) drives one of two orientation systems:

``orientation="ude"`` -- Ude, Nemec, Petric, Morimoto, "Orientation in Cartesian space
dynamic movement primitives", ICRA 2014:

.. code-block:: text

    tau d(eta)/dt = alpha_z (beta_z e - eta) + F(s),     tau dq/dt = 1/2 eta * q

(``eta = tau * omega``, world frame). Nonlinear (the quaternion kinematics), so it is
integrated: sub-steps of at most ``tau / 1000``, midpoint (RK2) rule with every update
``q <- exp(dt / tau * eta) q`` (unit norm to rounding). Weights: least squares of the
forcing target from the demonstration's angular velocity and acceleration (finite
differences), as Ude et al. and ``movement_primitives`` do.

``orientation="log"`` (default) -- Koutras & Doulgeri, "A correct formulation for the
orientation dynamic movement primitives for robot control in the Cartesian space", CoRL
2019: the linear DMP acts on ``y = -e`` itself (goal 0) and ``q = exp(y) * g``. Rotations
about a fixed axis give the same motion as ``"ude"``; in general the dynamics stay linear,
so the exact rollout map and the exact trajectory fit of :class:`~lfd.dmp.DMP` apply (no
integration, no differentiation of quaternions), and ``q`` is a unit quaternion by
construction. Chosen as default by measurement (docs/dmp.md, "Cartesian DMP").

In both, the forcing input ``F`` follows ``formulation`` with ``e0 = 2 log(g * conj(q0))`` in
the role of ``g - y0`` (``"pastor"``: ``K f(s) - K e0 s``; ``"ijspeert"``: ``f(s) * e0``).

Example::

    >>> import numpy as np
    >>> from lfd.dmp import CartesianDMP
    >>> from lfd.dmp.quaternion import exp
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> position = np.stack([t, np.sin(t), 0 * t], -1)
    >>> pose = np.concatenate([position, exp(np.outer(t, [0.0, 0.0, 1.2]))], -1)   # (101, 7)
    >>> dmp = CartesianDMP(n_basis=20).fit(t, pose)
    >>> out = dmp.rollout()
    >>> out.shape, bool(np.allclose(np.linalg.norm(out[:, 3:], axis=-1), 1.0))
    ((101, 7), True)
"""

from __future__ import annotations

import numpy as np
import torch

from lfd import checks

from . import quaternion as quat
from ._base import DISCRETE_PARAMS, DMPBase
from .canonical import discrete_features
from .discrete import DMP
from .fitting import DEFAULT_RIDGE
from .formulation import DEFAULT_FORMULATION, scale_weights, unscale_weights

__all__ = ["CartesianDMP"]

#: Orientation systems accepted by ``CartesianDMP(orientation=...)``; the first is the default.
ORIENTATIONS = ("log", "ude")

#: Integration sub-steps per ``tau`` (at least) for the ``"ude"`` orientation.
ORIENTATION_STEPS_PER_TAU = 1000


def _check_pose(name: str, value, ndims=(1, 2)) -> np.ndarray:
    pose = checks.finite_array(value, name, ndim=ndims)
    if pose.shape[-1] != 7:
        raise ValueError(f"{name} must end with 7 values [x, y, z, qw, qx, qy, qz], got shape {pose.shape}")
    norms = np.linalg.norm(pose[..., 3:], axis=-1)
    if np.any(np.abs(norms - 1.0) > 1e-3):
        raise ValueError(
            f"{name} quaternions must have unit norm (|q| = 1 within 1e-3), got norms up to {norms.max():.4g}"
        )
    return np.concatenate([pose[..., :3], quat.normalise(pose[..., 3:])], axis=-1)


class CartesianDMP(DMPBase):
    """Discrete DMP of a Cartesian pose: 3-D position + unit-quaternion orientation.

    Args:
        n_basis: basis functions per dimension (position and orientation alike).
        alpha_z, beta_z, alpha_s, overlap: gains, as in :class:`lfd.dmp.DMP`.
        formulation: ``"pastor"`` (default) or ``"ijspeert"`` (both parts).
        orientation: ``"log"`` (default, linear in the quaternion log) or ``"ude"`` (Ude 2014).
        ridge: relative Tikhonov strength of both fits (see :class:`lfd.dmp.DMP`).

    Attributes (after :meth:`fit`; leading ``(B,)`` for a batch of demonstrations):
        position_: the fitted 3-D :class:`lfd.dmp.DMP` of the position.
        orientation_: the 3-D linear DMP of ``-2 log(g conj(q))`` whose weights drive the orientation.
        weights_: ``(6, K)`` / ``(B, 6, K)`` forcing weights, position rows then orientation
            rows (orientation in radians for ``"pastor"``).
        start_, goal_: ``(7,)`` / ``(B, 7)`` first and last demonstrated pose.
        tau_: duration in seconds; n_steps_: number of demonstration samples.
        start_error_: ``(3,)`` / ``(B, 3)`` demonstrated ``2 log(g conj(q0))``, unwrapped (may
            exceed pi); new start/goal pairs are turned the same way round.
    """

    _PARAMS = (*DISCRETE_PARAMS, "orientation")

    def __init__(
        self,
        n_basis: int = 20,
        alpha_z: float = 25.0,
        beta_z: float | None = None,
        alpha_s: float | None = None,
        overlap: float = 0.8,
        formulation: str = DEFAULT_FORMULATION,
        ridge: float = DEFAULT_RIDGE,
        orientation: str = "log",
    ):
        self.orientation = checks.check_choice(orientation, "orientation", ORIENTATIONS)
        gains = {"alpha_z": alpha_z, "beta_z": beta_z, "alpha_s": alpha_s, "overlap": overlap}
        self._set_params(n_basis, gains, formulation, ridge)
        self.position_ = DMP(**self._dmp_params())

    # ------------------------------------------------------------------ fitting
    def fit(self, t, pose) -> CartesianDMP:
        """Learn from one demonstration ``(T, 7)`` or a batch ``(B, T, 7)`` sharing ``t``.

        Args:
            t: ``(T,)`` sample times in seconds, strictly increasing, ``T >= 3``.
            pose: ``[x, y, z, qw, qx, qy, qz]`` per sample (metres, unit quaternions; the sign
                of each quaternion may flip between samples, it is made continuous).

        Returns:
            ``self``.

        Raises:
            ValueError: bad shapes, NaN/inf, non-unit quaternions, bad ``t``.
        """
        times = checks.time_grid(t, min_samples=3)
        pose = _check_pose("pose", pose, (2, 3))
        if pose.shape[-2] != times.shape[0]:
            raise ValueError(
                f"pose must have shape (T, 7) or (B, T, 7) with T = len(t) = {times.shape[0]}, got {pose.shape}"
            )
        q = quat.continuous(pose[..., 3:])
        self.position_.fit(times, pose[..., :3])
        tau = float(times[-1] - times[0])
        goal = q[..., -1, :]
        # (..., T, 3) e = 2 log(g q*), unwrapped backwards from the goal (e = 0 there) so that
        # rotations of more than pi stay continuous
        error = quat.log(quat.multiply(goal[..., None, :], quat.conjugate(q)))
        error = np.flip(quat.unwrap(np.flip(error, axis=-2)), axis=-2)
        # y = -e behaves as the position of a linear DMP with goal 0 (exactly so for rotations
        # about a fixed axis): its exact trajectory fit gives the orientation weights
        self.orientation_ = DMP(**self._dmp_params()).fit(times, -error)
        w_rot = (
            self.orientation_.weights_ if self.orientation == "log" else self._ude_weights(times, q, error)
        )
        self.weights_ = np.concatenate([self.position_.weights_, w_rot], axis=-2)
        self.start_ = np.concatenate([pose[..., 0, :3], q[..., 0, :]], axis=-1)
        self.goal_ = np.concatenate([pose[..., -1, :3], goal], axis=-1)
        self.tau_, self.n_steps_ = tau, int(times.shape[0])
        self.start_error_ = error[..., 0, :]  # may exceed pi for demonstrations that rotate more
        return self

    def _ude_weights(self, times: np.ndarray, q: np.ndarray, error: np.ndarray) -> np.ndarray:
        """Ude et al.'s fit: least squares of ``F = tau^2 d(omega)/dt - alpha_z (beta_z e - tau omega)``."""
        tau = float(times[-1] - times[0])
        rotvec = quat.log(quat.multiply(q[..., 2:, :], quat.conjugate(q[..., :-2, :])))
        omega = np.empty_like(error)
        omega[..., 1:-1, :] = rotvec / (times[2:] - times[:-2])[:, None]
        first = quat.log(quat.multiply(q[..., 1, :], quat.conjugate(q[..., 0, :]))) / (times[1] - times[0])
        last = quat.log(quat.multiply(q[..., -1, :], quat.conjugate(q[..., -2, :]))) / (times[-1] - times[-2])
        omega[..., 0, :] = 2 * first - omega[..., 1, :]  # second-order one-sided ends
        omega[..., -1, :] = 2 * last - omega[..., -2, :]
        omega_dot = np.gradient(omega, times, axis=-2, edge_order=2)
        a, b = self.gains.alpha_z, self.gains.beta_z
        target = tau**2 * omega_dot - a * (b * error - tau * omega)
        theta = torch.from_numpy((times - times[0]) / tau)
        x = discrete_features(theta, self.n_basis, self.gains.alpha_s, self.gains.overlap).numpy()  # (T, K)
        u, sigma, vh = np.linalg.svd(x, full_matrices=False)
        gain = sigma / (sigma**2 + max(self.ridge, 1e-14) * sigma[0] ** 2)
        v = np.einsum("kt,...td->...dk", (vh.T * gain) @ u.T, target)
        e0 = error[..., 0, :]
        return unscale_weights(v, error, np.zeros_like(e0), e0, self.formulation, a * b)

    # ------------------------------------------------------------------ rollout
    def rollout(self, t=None, start=None, goal=None, tau=None, weights=None) -> np.ndarray:
        """Poses ``(T, 7)`` (``(B, T, 7)`` if any input is batched) with unit quaternions.

        Args:
            t: ``(T,)`` output times in seconds from ``t[0]``; default ``n_steps_`` samples over ``tau``.
            start, goal: ``(7,)`` or ``(B, 7)`` poses (default the demonstrated ones); the
                motion starts at rest.
            tau: duration in seconds (temporal scaling).
            weights: ``(6, K)`` or ``(B, 6, K)`` (default ``weights_``).

        Raises:
            ValueError: bad shapes, NaN, non-unit quaternions, ``tau <= 0``, or unfitted
                without all arguments.
        """
        if not self.is_fitted and any(x is None for x in (start, goal, tau, weights)):
            raise ValueError("start, goal, tau and weights are required: the CartesianDMP is not fitted")
        start = _check_pose("start", self.start_ if start is None else start)
        goal = _check_pose("goal", self.goal_ if goal is None else goal)
        tau = checks.positive_float(float(self.tau_ if tau is None else tau), "tau")
        weights = checks.finite_array(self.weights_ if weights is None else weights, "weights", ndim=(2, 3))
        if weights.shape[-2:] != (6, self.n_basis):
            raise ValueError(
                f"weights must have shape (6, {self.n_basis}) or (B, 6, {self.n_basis}), got {weights.shape}"
            )
        times = np.linspace(0.0, tau, self.n_steps_) if t is None else checks.time_grid(t, min_samples=1)
        batch = np.broadcast_shapes(start.shape[:-1], goal.shape[:-1], weights.shape[:-2])
        position = np.asarray(
            self.position_.rollout(
                t=times, y0=start[..., :3], goal=goal[..., :3], tau=tau, weights=weights[..., :3, :]
            )
        )
        position = np.broadcast_to(position, (*batch, times.shape[0], 3))
        q0, qg, w_rot = start[..., 3:], goal[..., 3:], weights[..., 3:, :]
        if self.orientation == "ude":
            orientation = self._integrate_ude(times - times[0], q0, qg, tau, w_rot, batch)
        else:
            e0 = quat.log(quat.multiply(qg, quat.conjugate(q0)))
            if self.is_fitted:  # the same way round as the demonstration (it may have turned > pi)
                pair = np.stack(np.broadcast_arrays(self.start_error_, e0), axis=-2)
                e0 = quat.unwrap(pair)[..., 1, :]
            y = self.orientation_.rollout(t=times, y0=-e0, goal=np.zeros_like(e0), tau=tau, weights=w_rot)
            y = np.broadcast_to(np.asarray(y), (*batch, times.shape[0], 3))
            orientation = quat.normalise(
                quat.multiply(quat.exp(y), np.broadcast_to(qg, (*batch, 4))[..., None, :])
            )
        return np.concatenate([position, orientation], axis=-1)

    def _integrate_ude(self, times, q0, goal, tau, weights, batch) -> np.ndarray:
        """Integrate the quaternion system (midpoint rule, sub-steps <= tau / 1000): ``(*batch, T, 4)``."""
        q = np.broadcast_to(q0, (*batch, 4)).copy()
        goal = np.broadcast_to(goal, (*batch, 4))
        a, b = self.gains.alpha_z, self.gains.beta_z
        e0 = quat.log(quat.multiply(goal, quat.conjugate(q)))
        weights = np.broadcast_to(weights, (*batch, 3, self.n_basis))
        v = scale_weights(weights, np.zeros_like(e0), e0, self.formulation, a * b)
        eta = np.zeros((*batch, 3))
        out = [q.copy()]
        for t0, t1 in zip(times[:-1], times[1:]):
            n = max(1, int(np.ceil((t1 - t0) / tau * ORIENTATION_STEPS_PER_TAU * (1 - 1e-4))))
            h = (t1 - t0) / n
            edges = t0 + h * np.arange(n + 1)
            theta = torch.from_numpy(np.concatenate([edges, edges[:-1] + 0.5 * h]) / tau)
            x = discrete_features(theta, self.n_basis, self.gains.alpha_s, self.gains.overlap).numpy()
            force = np.einsum("tk,...dk->t...d", x, v)  # (2n + 1, *batch, 3)
            for i in range(n):

                def derivative(qi, etai, fi):
                    e = quat.log(quat.multiply(goal, quat.conjugate(qi)))
                    return (a * (b * e - etai) + fi) / tau

                mid_eta = eta + 0.5 * h * derivative(q, eta, force[i])
                mid_q = quat.multiply(quat.exp(0.5 * h / tau * eta), q)
                eta_next = eta + h * derivative(mid_q, mid_eta, force[n + 1 + i])
                q = quat.normalise(quat.multiply(quat.exp(h / tau * mid_eta), q))
                eta = eta_next
            out.append(q.copy())
        return np.stack(out, axis=-2)
