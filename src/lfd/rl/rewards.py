"""Rewards for PoWER: the goal-reaching reward of eq. 5.4 in joint and in task space.

For a trajectory with samples ``x_0 .. x_{T-1}`` (``T >= 2``) and a goal ``g`` the return is

.. code-block:: text

    Q = w1 * exp(-||g - x_{T-1}||^2) + (1 - w1) / (T - 1) * sum_{t = 0}^{T - 2} exp(-||g - x_t||^2)

i.e. the terminal reward plus the running rewards of the ``T - 1`` earlier samples, the
running part divided by its number of steps (never by the duration in seconds), so that
``0 < Q <= 1`` whatever the sampling rate. Distances are in the units of ``x``: radians in
joint space, metres in task space.

Choice of ``w1`` (default 0.99). When PoWER also learns the goal, the running part pulls
the return's maximiser away from the goal: it prefers trajectories that get close early
over ones that end exactly at the goal. The offset grows like ``(1 - w1) / w1`` times the
distance travelled: on the Sawyer example (``benchmarks/power_sawyer_example.py``, goal
learned from the reward alone) PoWER settles about 8 mm from the goal for ``w1 = 0.9``,
close to the 1 cm tolerance, which slows convergence (1.7x more rollouts on 5 tuning
goals), and under 1 mm for ``w1 = 0.99``; with ``w1 = 0.5`` it settles about 0.07 rad
from joint-space goals (tolerance 0.01 rad).

Any callable ``reward(trajectories (B, T, D)) -> returns (B,)`` with non-negative finite
returns can be given to :func:`lfd.rl.power` instead; the classes below also provide the
terminal ``error`` that PoWER's stopping rule uses.
"""

from __future__ import annotations

import numpy as np
import torch

from lfd.checks import check_float, finite_array, to_numpy

__all__ = [
    "JointGoalReward",
    "ObstacleReward",
    "TaskGoalReward",
    "ViaPointReward",
    "limit_violation",
    "returns_from_distances",
]


def check_trajectories(trajectories, name: str = "trajectories", *, n_dof: int | None = None) -> np.ndarray:
    """A batch of joint trajectories ``(B, T, D)`` with ``B >= 1``, ``T >= 2`` (``D = n_dof`` when
    given), as float64 without a copy; ``ValueError`` naming ``name`` otherwise."""
    array = finite_array(trajectories, name, shape=(None, None, n_dof), copy=False)
    if array.shape[0] < 1 or array.shape[1] < 2:
        raise ValueError(f"{name} must have shape (B >= 1, T >= 2, D), got {array.shape}")
    return array


def returns_from_distances(distances, w1: float) -> np.ndarray:
    """Eq. 5.4 returns from per-sample distances to the goal.

    Args:
        distances: ``(B, T)`` non-negative distances ``||g - x_t||`` (``T >= 2``), rad or m.
        w1: weight of the terminal reward, in ``[0, 1]``.

    Returns:
        ``(B,)`` returns in ``(0, 1]``.
    """
    distances = np.asarray(distances, dtype=np.float64)
    if distances.ndim != 2 or distances.shape[1] < 2:
        raise ValueError(f"distances must have shape (B, T >= 2), got {distances.shape}")
    return _returns(np.square(distances), check_float(w1, "w1", low=0.0, high=1.0))


def _returns(squared_distances: np.ndarray, w1: float) -> np.ndarray:
    """Eq. 5.4 from squared distances ``(B, T)`` (no checks: the rewards' inner loop)."""
    closeness = np.exp(-squared_distances)
    return w1 * closeness[:, -1] + (1.0 - w1) * closeness[:, :-1].mean(axis=1)


def _squared_distances(points: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """``||points - goal||^2`` over the last axis."""
    offset = points - goal
    return np.einsum("...i,...i->...", offset, offset)


def limit_violation(trajectories: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Largest joint-limit violation of each trajectory.

    Args:
        trajectories: ``(B, T, D)`` joint positions (rad).
        lower, upper: ``(D,)`` limits (rad; ``-inf`` / ``inf`` for unbounded joints).

    Returns:
        ``(B,)`` ``max_{t, d} max(lower_d - y_td, y_td - upper_d, 0)`` (rad); 0 within limits.
    """
    excess = np.maximum(lower - trajectories.min(axis=1), trajectories.max(axis=1) - upper)
    return np.maximum(excess.max(axis=1), 0.0)


class JointGoalReward:
    """Eq. 5.4 in joint space: distance between the joint vector and a joint-space goal.

    Args:
        goal: ``(D,)`` goal joint positions (rad).
        w1: weight of the terminal reward, in ``[0, 1]`` (see the module docstring).

    Calling the object on trajectories ``(B, T, D)`` (rad) returns ``(B,)`` returns;
    :meth:`error` gives the terminal distance to the goal (rad).
    """

    def __init__(self, goal, w1: float = 0.99):
        self.goal = finite_array(goal, "goal", ndim=1)
        self.w1 = check_float(w1, "w1", low=0.0, high=1.0)

    def _check(self, trajectories) -> np.ndarray:
        return check_trajectories(trajectories, n_dof=self.goal.shape[0])

    def __call__(self, trajectories) -> np.ndarray:
        """Returns ``(B,)`` of the trajectories ``(B, T, D)``."""
        return _returns(_squared_distances(self._check(trajectories), self.goal), self.w1)

    def per_step(self, trajectories) -> np.ndarray:
        """Per-sample rewards ``(B, T)`` of eq. 5.4 (they sum to the return): the returns-to-go of per-step PoWER."""
        closeness = np.exp(-_squared_distances(self._check(trajectories), self.goal))
        rewards = closeness * ((1.0 - self.w1) / (closeness.shape[1] - 1))
        rewards[:, -1] = self.w1 * closeness[:, -1]
        return rewards

    def error(self, trajectories) -> np.ndarray:
        """Terminal distance ``||x_{T-1} - g||`` (rad), shape ``(B,)``."""
        trajectories = self._check(trajectories)
        return np.linalg.norm(trajectories[:, -1] - self.goal, axis=-1)


class TaskGoalReward:
    """Eq. 5.4 in task space: end-effector distance to a Cartesian goal through forward kinematics.

    The end-effector positions of all rollouts and samples are computed in one batched
    ``robot.fk`` call on ``(B * T, D)`` joint vectors.

    Args:
        robot: object with ``fk(q (N, D)) -> (N, 4, 4)`` homogeneous transforms (metres),
            e.g. ``lfd.robots.load_robot("sawyer")``.
        target: ``(3,)`` goal position of the end effector (m), in the frame of ``robot.fk``.
        w1: weight of the terminal reward, in ``[0, 1]`` (see the module docstring).
    """

    def __init__(self, robot, target, w1: float = 0.99):
        if not callable(getattr(robot, "fk", None)):
            raise ValueError(f"robot must provide fk(q), got {type(robot).__name__}")
        self.robot = robot
        self.target = finite_array(target, "target", shape=(3,))
        self.w1 = check_float(w1, "w1", low=0.0, high=1.0)

    def _fk_positions(self, joints: np.ndarray) -> np.ndarray:
        """End-effector positions ``(..., 3)`` of joint vectors ``(..., D)``, in one FK call."""
        poses = to_numpy(self.robot.fk(torch.from_numpy(joints.reshape(-1, joints.shape[-1]))))
        return poses[:, :3, 3].astype(np.float64).reshape(*joints.shape[:-1], 3)

    def positions(self, trajectories) -> np.ndarray:
        """End-effector positions ``(B, T, 3)`` (m) of joint trajectories ``(B, T, D)`` (rad)."""
        return self._fk_positions(check_trajectories(trajectories))

    def __call__(self, trajectories) -> np.ndarray:
        """Returns ``(B,)`` of the joint trajectories ``(B, T, D)``."""
        return _returns(_squared_distances(self.positions(trajectories), self.target), self.w1)

    def error(self, trajectories) -> np.ndarray:
        """Terminal end-effector distance to the target (m), shape ``(B,)``."""
        final = check_trajectories(trajectories)[:, -1]
        return np.linalg.norm(self._fk_positions(final) - self.target, axis=-1)


class _CostReward:
    """Return ``exp(-sum_t c(t))`` of per-sample costs ``c (B, T) >= 0``; returns-to-go ``exp(-sum_{t' >= t} c(t'))``.

    Subclasses define ``costs(trajectories) -> (B, T)`` and ``error``. The return is the
    (improper) probability of success that EM policy searches weight rollouts with; the
    returns-to-go credit a sample only with the costs that follow it, which is what per-step
    PoWER needs (``Q(0)`` is the return).
    """

    def _check(self, trajectories) -> np.ndarray:
        return check_trajectories(trajectories, n_dof=self.n_dof)

    def __call__(self, trajectories) -> np.ndarray:
        """Returns ``(B,)`` in ``(0, 1]`` of the trajectories ``(B, T, D)``."""
        return np.exp(-self.costs(self._check(trajectories)).sum(axis=1))

    def returns_to_go(self, trajectories) -> np.ndarray:
        """``(B, T)`` returns-to-go ``Q(t) = exp(-sum_{t' >= t} c(t'))``; ``Q(0)`` is the return."""
        costs = self.costs(self._check(trajectories))
        return np.exp(-np.cumsum(costs[:, ::-1], axis=1)[:, ::-1])


def _interpolation(t, t_via: float, name: str) -> tuple[int, float]:
    """Sample index ``i`` and fraction ``a`` with ``t_via = (1 - a) t[i] + a t[i + 1]``."""
    t = finite_array(t, "t", ndim=1)
    t_via = check_float(t_via, name)
    if t.size < 2 or np.any(np.diff(t) <= 0) or not t[0] <= t_via <= t[-1]:
        raise ValueError(f"{name} must lie within the strictly increasing time grid t [{t[0]}, {t[-1]}] s")
    index = min(int(np.searchsorted(t, t_via, side="right")) - 1, t.size - 2)
    return index, float((t_via - t[index]) / (t[index + 1] - t[index]))


class ViaPointReward(_CostReward):
    """Pass through a via point at time ``t_via`` and end at the goal.

    Costs: ``||y(t_via) - p||^2 / width^2`` at the via point (``y(t_via)`` interpolated
    linearly between samples, the cost given to the sample before ``t_via``) and
    ``||y(T) - g||^2 / width^2`` at the last sample. The return is ``exp(-sum of costs)``.

    Args:
        t: ``(T,)`` time grid of the rollouts (s).
        t_via: via time (s), within ``t``.
        point: ``(D,)`` via point (units of ``y``: rad in joint space).
        goal: ``(D,)`` goal the motion must end at.
        width: distance scale of the costs (units of ``y``, > 0).

    :meth:`error` is ``max(||y(t_via) - p||, ||y(T) - g||)`` (units of ``y``).

    Example::

        reward = ViaPointReward(t, 0.5 * t[-1], point, goal=dmp.goal_)
        reward(trajectories), reward.error(trajectories)   # (B,), (B,)
    """

    def __init__(self, t, t_via: float, point, goal, width: float = 0.05):
        self.index, self.fraction = _interpolation(t, t_via, "t_via")
        self.n_steps = np.shape(t)[0]
        self.point = finite_array(point, "point", ndim=1)
        self.n_dof = self.point.shape[0]
        self.goal = finite_array(goal, "goal", shape=(self.n_dof,))
        self.width = check_float(width, "width", low=0.0, strict_low=True)

    def _distances(self, trajectories: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if trajectories.shape[1] != self.n_steps:
            raise ValueError(
                f"trajectories must have T = {self.n_steps} samples, got {trajectories.shape[1]}"
            )
        i, a = self.index, self.fraction
        at_via = (1.0 - a) * trajectories[:, i] + a * trajectories[:, i + 1]
        return np.linalg.norm(at_via - self.point, axis=-1), np.linalg.norm(
            trajectories[:, -1] - self.goal, axis=-1
        )

    def costs(self, trajectories: np.ndarray) -> np.ndarray:
        """Per-sample costs ``(B, T)``."""
        via, end = self._distances(trajectories)
        costs = np.zeros(trajectories.shape[:2])
        costs[:, self.index] += np.square(via / self.width)
        costs[:, -1] += np.square(end / self.width)
        return costs

    def error(self, trajectories) -> np.ndarray:
        """``max(via-point distance, terminal distance)`` ``(B,)`` (units of ``y``)."""
        return np.maximum(*self._distances(self._check(trajectories)))


class ObstacleReward(_CostReward):
    """Keep a clearance ``radius`` from a point obstacle and end at the goal.

    Costs: ``(max(0, radius - ||y(t) - c||) / width)^2`` at every sample (the penetration
    of the obstacle's ball), plus ``||y(T) - g||^2 / width^2`` at the last sample. Distances
    are over all DoF (joint space, rad) or over ``points(trajectories)`` if a mapping to a
    task space is given. The return is ``exp(-sum of costs)``.

    Args:
        centre: ``(P,)`` obstacle centre (units of the mapped points; rad in joint space).
        radius: clearance required (> 0, same units).
        goal: ``(D,)`` goal the motion must end at (units of ``y``).
        width: distance scale of the costs (> 0).
        points: optional ``points(trajectories (B, T, D)) -> (B, T, P)`` (e.g. forward
            kinematics); default the joint vector itself.

    :meth:`error` is ``max(largest penetration, ||y(T) - g||)``: 0 means collision-free
    and at the goal.
    """

    def __init__(self, centre, radius: float, goal, width: float = 0.05, points=None):
        self.centre = finite_array(centre, "centre", ndim=1)
        self.radius = check_float(radius, "radius", low=0.0, strict_low=True)
        self.goal = finite_array(goal, "goal", ndim=1)
        self.n_dof = self.goal.shape[0]
        if points is None and self.centre.shape[0] != self.n_dof:
            raise ValueError(
                f"centre must have {self.n_dof} entries in joint space, got {self.centre.shape[0]}"
            )
        if points is not None and not callable(points):
            raise ValueError(f"points must be callable, got {type(points).__name__}")
        self.points = points
        self.width = check_float(width, "width", low=0.0, strict_low=True)

    def _distances(self, trajectories: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        mapped = (
            trajectories if self.points is None else np.asarray(self.points(trajectories), dtype=np.float64)
        )
        penetration = np.maximum(self.radius - np.linalg.norm(mapped - self.centre, axis=-1), 0.0)
        return penetration, np.linalg.norm(trajectories[:, -1] - self.goal, axis=-1)

    def costs(self, trajectories: np.ndarray) -> np.ndarray:
        """Per-sample costs ``(B, T)``."""
        penetration, end = self._distances(trajectories)
        costs = np.square(penetration / self.width)
        costs[:, -1] += np.square(end / self.width)
        return costs

    def clearance(self, trajectories) -> np.ndarray:
        """Smallest distance to the obstacle centre minus the radius ``(B,)`` (negative: collision)."""
        trajectories = self._check(trajectories)
        mapped = (
            trajectories if self.points is None else np.asarray(self.points(trajectories), dtype=np.float64)
        )
        return np.linalg.norm(mapped - self.centre, axis=-1).min(axis=1) - self.radius

    def error(self, trajectories) -> np.ndarray:
        """``max(largest penetration, terminal distance)`` ``(B,)``."""
        penetration, end = self._distances(self._check(trajectories))
        return np.maximum(penetration.max(axis=1), end)
