"""Dual-arm Cartesian DMP with the relative-pose coupling (Gams et al., IROS 2013).

A pose of both arms is ``[left (7), right (7)]`` = ``[x, y, z, qw, qx, qy, qz] x 2`` (metres,
unit quaternions). Each arm is a :class:`lfd.dmp.CartesianDMP` with Ude's orientation system
(``orientation="ude"``: its angular velocity is the state that a coupling acceleration acts
on); weights ``(12, K)`` are ``[left position, left rotation, right position, right rotation]``,
the order of ``movement_primitives.dmp.DualCartesianDMP``.

Without coupling the two arms are independent and :meth:`DualCartesianDMP.rollout` is the two
Cartesian rollouts. With a :class:`RelativePoseCoupling` the arms are integrated together
(midpoint rule, sub-steps of at most ``tau / 1000``) with, per arm,

.. code-block:: text

    tau^2 dv/dt = alpha_z (beta_z (g - p) - tau v) + F_p(s) + Cdd_p,    dp/dt = v + Cd_p / tau
    tau^2 dw/dt = alpha_z (beta_z e - tau w) + F_r(s) + Cdd_r,          dq/dt = 1/2 (w + Cd_r / tau) q

(``e = 2 log(g conj(q))``, ``F`` the forcing input of ``formulation``). The coupling pulls the
right arm's pose in the left arm's frame towards a desired relative pose: with the errors
``E`` of position and rotation vector expressed in the world, ``Cdd = +-lf (c2 k E) - lf d v``
(``d = 2 sqrt(k c2)``, the sign opposite for the two arms) and ``Cd = +-lf c1 k E``.

``movement_primitives`` adds ``Cd / tau`` to its velocity *state* at every Euler step, so its
``c1`` term is an impulse per step and its trajectory changes with ``int_dt`` (``c1 = 1``:
docs/dmp.md, "Dual-arm Cartesian DMP"); here ``Cd`` is Gams' velocity offset, the same for any
step. With ``c1 = 0`` both solve the same equations and its Euler solution converges to ours
(``tests/dmp/test_dmp_dual_cartesian.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from lfd import checks

from . import _io
from . import quaternion as quat
from ._base import Primitive
from .canonical import discrete_features
from .cartesian import ORIENTATION_STEPS_PER_TAU, CartesianDMP, _check_pose
from .fitting import DEFAULT_RIDGE
from .formulation import DEFAULT_FORMULATION, scale_weights

__all__ = ["DualCartesianDMP", "RelativePoseCoupling"]


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vectors ``v`` ``(..., 3)`` rotated by unit quaternions ``q = [w, u]``: ``v + 2 w (u x v) + 2 u x (u x v)``."""
    w, u = q[..., :1], q[..., 1:]
    uv = np.cross(u, v)
    return v + 2.0 * (w * uv + np.cross(u, uv))


def _split(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(..., 14)`` -> positions ``(..., 2, 3)`` and quaternions ``(..., 2, 4)``."""
    arms = pose.reshape(*pose.shape[:-1], 2, 7)
    return arms[..., :3], arms[..., 3:]


@dataclass(frozen=True)
class RelativePoseCoupling:
    """Couples the right arm's pose in the left arm's frame to ``desired`` (Gams et al. 2013).

    Args:
        desired: ``(7,)`` pose ``[x, y, z, qw, qx, qy, qz]`` of the right tool in the left tool frame.
        leader_follower: ``(lf_left, lf_right)``: which arm adapts (1, 1: both; 0, 1: only the right).
        k: spring constant; c1: velocity-offset gain; c2: acceleration gain (damping ``2 sqrt(k c2)``).
        couple_position, couple_orientation: which parts of the pose are coupled.
    """

    desired: tuple[float, ...]
    leader_follower: tuple[float, float] = (1.0, 1.0)
    k: float = 1.0
    c1: float = 0.0
    c2: float = 30.0
    couple_position: bool = True
    couple_orientation: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "desired", tuple(_check_pose("desired", self.desired, (1,)).tolist()))
        lf = checks.finite_array(self.leader_follower, "leader_follower", ndim=(1,))
        if lf.shape != (2,):
            raise ValueError(f"leader_follower must be 2 numbers (left, right), got {self.leader_follower!r}")
        object.__setattr__(self, "leader_follower", tuple(lf.tolist()))
        for name in ("k", "c2"):
            checks.positive_float(getattr(self, name), name)
        if not np.isfinite(self.c1) or self.c1 < 0:
            raise ValueError(f"c1 must be a finite number >= 0, got {self.c1!r}")

    def __call__(self, pose: np.ndarray, velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Velocity offsets ``Cd`` and accelerations ``Cdd`` ``(..., 12)`` at poses ``(..., 14)`` and
        velocities ``(..., 12)`` (``[v_left, w_left, v_right, w_right]``, world frame, per second)."""
        (p_l, p_r), (q_l, q_r) = (np.moveaxis(x, -2, 0) for x in _split(pose))
        desired = np.asarray(self.desired)
        actual_position = _rotate(quat.conjugate(q_l), p_r - p_l)
        actual_rotation = quat.multiply(quat.conjugate(q_l), q_r)
        error_position = _rotate(q_l, desired[:3] - actual_position) * self.couple_position
        rotation = quat.multiply(
            np.broadcast_to(desired[3:], actual_rotation.shape), quat.conjugate(actual_rotation)
        )
        error_rotation = _rotate(q_l, quat.log(rotation)) * self.couple_orientation
        force = -self.k * np.concatenate([error_position, error_rotation], axis=-1)  # on the left arm
        lf_l, lf_r = self.leader_follower
        damping = 2.0 * np.sqrt(self.k * self.c2)
        active = np.repeat([self.couple_position, self.couple_orientation], 3).astype(float)
        cd = self.c1 * np.concatenate([lf_l * force, -lf_r * force], axis=-1)
        cdd = np.concatenate(
            [
                lf_l * (self.c2 * force - damping * velocity[..., :6] * active),
                lf_r * (-self.c2 * force - damping * velocity[..., 6:] * active),
            ],
            axis=-1,
        )
        return cd, cdd


class DualCartesianDMP(Primitive):
    """Two Cartesian DMPs (left, right arm) with an optional relative-pose coupling.

    Args:
        n_basis, alpha_z, beta_z, alpha_s, overlap, formulation, ridge: as :class:`lfd.dmp.CartesianDMP`
            (both arms, orientation system ``"ude"``).

    Attributes (after :meth:`fit`; leading ``(B,)`` for a batch of demonstrations):
        left_, right_: the fitted :class:`lfd.dmp.CartesianDMP` of each arm.
        weights_: ``(12, K)`` / ``(B, 12, K)``; start_, goal_: ``(14,)`` / ``(B, 14)`` poses;
        tau_: duration in seconds; n_steps_: number of demonstration samples.
    """

    _KIND = "lfd.dmp.DualCartesianDMP"
    _VECTORS = ("start", "goal")

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
        self._set_params(n_basis, gains, formulation, ridge)
        self.left_, self.right_ = (CartesianDMP(**self._dmp_params(), orientation="ude") for _ in range(2))

    def fit(self, t, pose) -> DualCartesianDMP:
        """Learn from one demonstration ``(T, 14)`` or a batch ``(B, T, 14)`` sharing ``t``.

        Raises:
            ValueError: bad shapes, NaN/inf, non-unit quaternions, bad ``t``.
        """
        pose = checks.finite_array(pose, "pose", ndim=(2, 3))
        if pose.shape[-1] != 14:
            raise ValueError(
                f"pose must end with 14 values (left and right [x, y, z, qw, qx, qy, qz]), got {pose.shape}"
            )
        self.left_.fit(t, pose[..., :7])
        self.right_.fit(t, pose[..., 7:])
        self._collect()
        return self

    def _collect(self) -> None:
        self.weights_ = np.concatenate([self.left_.weights_, self.right_.weights_], axis=-2)
        self.start_ = np.concatenate([self.left_.start_, self.right_.start_], axis=-1)
        self.goal_ = np.concatenate([self.left_.goal_, self.right_.goal_], axis=-1)
        self.tau_, self.n_steps_ = self.left_.tau_, self.left_.n_steps_

    def rollout(self, t=None, start=None, goal=None, tau=None, weights=None, coupling=None) -> np.ndarray:
        """Poses ``(T, 14)`` (``(B, T, 14)`` if any input is batched), starting at rest.

        Args:
            t: ``(T,)`` output times in seconds from ``t[0]``; default ``n_steps_`` samples over ``tau``.
            start, goal: ``(14,)`` or ``(B, 14)`` poses of both arms.
            tau: duration in seconds; weights: ``(12, K)`` or ``(B, 12, K)``.
            coupling: a :class:`RelativePoseCoupling` (or any callable ``(pose, velocity) -> (Cd, Cdd)``
                on ``(..., 14)``/``(..., 12)``), or None for independent arms.

        Raises:
            ValueError: bad shapes, NaN, non-unit quaternions, ``tau <= 0``, or unfitted without all arguments.
        """
        if not self.is_fitted and any(x is None for x in (start, goal, tau, weights)):
            raise ValueError("start, goal, tau and weights are required: the DualCartesianDMP is not fitted")
        start = self._pose("start", self.start_ if start is None else start)
        goal = self._pose("goal", self.goal_ if goal is None else goal)
        tau = checks.positive_float(float(self.tau_ if tau is None else tau), "tau")
        weights = checks.finite_array(self.weights_ if weights is None else weights, "weights", ndim=(2, 3))
        if weights.shape[-2:] != (12, self.n_basis):
            raise ValueError(
                f"weights must have shape (12, {self.n_basis}) or (B, 12, {self.n_basis}), got {weights.shape}"
            )
        times = np.linspace(0.0, tau, self.n_steps_) if t is None else checks.time_grid(t, min_samples=1)
        if coupling is None:
            arms = [
                arm.rollout(
                    t=times, start=start[..., s], goal=goal[..., s], tau=tau, weights=weights[..., w, :]
                )
                for arm, s, w in (
                    (self.left_, slice(0, 7), slice(0, 6)),
                    (self.right_, slice(7, 14), slice(6, 12)),
                )
            ]
            batch = np.broadcast_shapes(*(a.shape[:-2] for a in arms))
            return np.concatenate([np.broadcast_to(a, (*batch, *a.shape[-2:])) for a in arms], axis=-1)
        return self._integrate(times - times[0], start, goal, tau, weights, coupling)

    @staticmethod
    def _pose(name: str, value) -> np.ndarray:
        pose = checks.finite_array(value, name, ndim=(1, 2))
        if pose.shape[-1] != 14:
            raise ValueError(f"{name} must have 14 values (two poses), got shape {pose.shape}")
        return np.concatenate([_check_pose(name, pose[..., :7]), _check_pose(name, pose[..., 7:])], axis=-1)

    def _integrate(self, times, start, goal, tau, weights, coupling) -> np.ndarray:
        """Both arms together, midpoint rule with sub-steps <= tau / 1000: ``(*batch, T, 14)``."""
        batch = np.broadcast_shapes(start.shape[:-1], goal.shape[:-1], weights.shape[:-2])
        a, b = self.gains.alpha_z, self.gains.beta_z
        (p, q), (g_p, g_q) = (
            _split(np.broadcast_to(start, (*batch, 14)).copy()),
            _split(np.broadcast_to(goal, (*batch, 14))),
        )
        e0 = quat.log(quat.multiply(g_q, quat.conjugate(q)))  # (*batch, 2, 3)
        offsets = np.concatenate([g_p - p, e0], axis=-1).reshape(*batch, 12)  # "g - y0" of each row
        w = np.broadcast_to(weights, (*batch, 12, self.n_basis))
        v_scaled = scale_weights(w, np.zeros_like(offsets), offsets, self.formulation, a * b)
        velocity = np.zeros((*batch, 12))  # [v_l, w_l, v_r, w_r], world frame, per second

        def accelerations(p, q, velocity, force):
            pose = np.concatenate([p, q], axis=-1).reshape(*batch, 14)
            cd, cdd = coupling(pose, velocity)
            spring = np.concatenate([g_p - p, quat.log(quat.multiply(g_q, quat.conjugate(q)))], -1).reshape(
                *batch, 12
            )
            acc = (a * (b * spring - tau * velocity) + force + cdd) / tau**2
            rates = (velocity + cd / tau).reshape(*batch, 2, 6)
            return acc, rates[..., :3], rates[..., 3:]

        def advance(p, q, linear, angular, h):
            return p + h * linear, quat.normalise(quat.multiply(quat.exp(h * angular), q))

        out = [np.concatenate([p, q], axis=-1).reshape(*batch, 14)]
        counts = [
            max(1, int(np.ceil((t1 - t0) / tau * ORIENTATION_STEPS_PER_TAU * (1 - 1e-4))))
            for t0, t1 in zip(times[:-1], times[1:])
        ]
        steps = [
            (t0 + (t1 - t0) / n * np.arange(n), (t1 - t0) / n) for t0, t1, n in zip(times, times[1:], counts)
        ]
        starts = np.concatenate([[0.0], *(edges for edges, _ in steps)])[1:]
        lengths = np.concatenate([[0.0], *(np.full(len(edges), h) for edges, h in steps)])[1:]
        theta = torch.from_numpy(np.concatenate([starts, starts + 0.5 * lengths]) / tau)
        x = discrete_features(theta, self.n_basis, self.gains.alpha_s, self.gains.overlap).numpy()
        force = np.einsum("tk,...dk->t...d", x, v_scaled)  # (2 S, *batch, 12): sub-step starts, midpoints
        total, i = len(starts), 0
        for n in counts:
            for _ in range(n):
                h = lengths[i]
                acc, linear, angular = accelerations(p, q, velocity, force[i])
                mid_p, mid_q = advance(p, q, linear, angular, 0.5 * h)
                mid_acc, mid_linear, mid_angular = accelerations(
                    mid_p, mid_q, velocity + 0.5 * h * acc, force[total + i]
                )
                p, q = advance(p, q, mid_linear, mid_angular, h)
                velocity = velocity + h * mid_acc
                i += 1
            out.append(np.concatenate([p, q], axis=-1).reshape(*batch, 14))
        return np.stack(out, axis=-2)

    # ------------------------------------------------------------------ persistence
    # save() is Primitive's: the hyper-parameters, weights_, start_, goal_, tau_ and n_steps_

    @classmethod
    def load(cls, path) -> DualCartesianDMP:
        """Read a file written by :meth:`save` (``ValueError`` naming the file on bad contents)."""
        params, fitted = _io.read_json(path, cls._KIND)
        try:
            dmp = cls(**params)
            if fitted is not None:
                weights = checks.finite_array(fitted["weights"], "weights", ndim=(2, 3))
                start, goal = dmp._pose("start", fitted["start"]), dmp._pose("goal", fitted["goal"])
                tau, n_steps = (
                    checks.positive_float(fitted["tau"], "tau"),
                    checks.positive_int(fitted["n_steps"], "n_steps"),
                )
                if weights.shape[-2:] != (12, dmp.n_basis):
                    raise ValueError(f"weights have shape {weights.shape}, expected (12, {dmp.n_basis})")
                for arm, rows, cols in (
                    (dmp.left_, slice(0, 6), slice(0, 7)),
                    (dmp.right_, slice(6, 12), slice(7, 14)),
                ):
                    arm.weights_, arm.start_, arm.goal_ = (
                        weights[..., rows, :],
                        start[..., cols],
                        goal[..., cols],
                    )
                    arm.tau_, arm.n_steps_ = tau, n_steps
                dmp._collect()
        except (TypeError, KeyError, ValueError) as exc:
            raise ValueError(f"{path}: bad DualCartesianDMP file: {exc}") from exc
        return dmp
