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

from ._checks import as_finite_array, check_float, check_trajectories, to_numpy

__all__ = ["returns_from_distances", "limit_violation", "JointGoalReward", "TaskGoalReward"]


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
        self.goal = as_finite_array(goal, "goal", ndim=1)
        self.w1 = check_float(w1, "w1", low=0.0, high=1.0)

    def _check(self, trajectories) -> np.ndarray:
        return check_trajectories(trajectories, n_dof=self.goal.shape[0])

    def __call__(self, trajectories) -> np.ndarray:
        """Returns ``(B,)`` of the trajectories ``(B, T, D)``."""
        return _returns(_squared_distances(self._check(trajectories), self.goal), self.w1)

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
        self.target = as_finite_array(target, "target", shape=(3,))
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
