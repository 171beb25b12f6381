"""The reward for refining an imitated skill: a task term in the robot's task space plus a term that keeps
the skill close to the demonstrated shape.

Costs per sample (the return is ``exp(-sum of costs)``, with per-step returns-to-go, like the other cost
rewards of :mod:`lfd.rl.rewards`):

- ``task="reach"``: ``||p(T) - target||^2 / width^2`` at the last sample (``p`` the tool position by FK, m);
- ``task="via_point"``: ``||p(t_via) - target||^2 / width^2`` at the via time (interpolated between samples)
  plus ``||p(T) - end||^2 / width^2``: pass the point and still end where the demonstration ends;
- ``task="avoid"``: ``(max(0, radius - ||p(t) - target||) / width)^2`` at every sample (the tool's
  penetration of a ball around ``target``) plus the same end term;
- shape, every task: ``shape_weight * ||q(t) - q_ref(t)||^2 / (shape_scale^2 T)`` at every sample, i.e.
  ``shape_weight * RMSE^2 / shape_scale^2`` in total (``q_ref`` the demonstrated joint trajectory, rad).

:meth:`SkillReward.error` is the task error in metres (reach: end distance; via point: the larger of the
via and end distances; avoid: the larger of the end distance and the deepest penetration), which the
searches' stopping rule compares with their ``tol``; :meth:`SkillReward.terms` reports both terms.
"""

from __future__ import annotations

import numpy as np
import torch

from lfd.checks import check_choice, check_float, finite_array, to_numpy

from .rewards import _CostReward, _interpolation, check_trajectories

__all__ = ["SKILL_TASKS", "SkillReward"]

#: Tasks of :class:`SkillReward`.
SKILL_TASKS = ("reach", "via_point", "avoid")


class SkillReward(_CostReward):
    """Task term plus shape term (module docstring) for joint trajectories ``(B, T, D)`` of ``robot``.

    Args:
        robot: object with ``fk(q (N, D)) -> (N, 4, 4)`` (m), e.g. ``lfd.robots.load_robot("wam4")``.
        task: one of :data:`SKILL_TASKS`.
        target: ``(3,)`` m, robot base frame: the reach target, the via point or the obstacle centre.
        reference: ``(T, D)`` demonstrated joint trajectory (rad) on the rollouts' time grid.
        t: ``(T,)`` time grid (s) of the rollouts.
        t_via: via time (s) within ``t`` (``task="via_point"``; default the middle of ``t``).
        radius: clearance from ``target`` (m, ``task="avoid"``).
        width: distance scale of the task costs (m, > 0).
        shape_weight: weight of the shape term (>= 0; 0 ignores the demonstrated shape).
        shape_scale: joint RMSE (rad, > 0) that costs ``shape_weight``.

    Raises:
        ValueError: an unknown task or a bad argument (named in the message).
    """

    def __init__(
        self,
        robot,
        task: str,
        target,
        reference,
        t,
        *,
        t_via: float | None = None,
        radius: float = 0.05,
        width: float = 0.02,
        shape_weight: float = 1.0,
        shape_scale: float = 0.1,
    ):
        check_choice(task, "task", SKILL_TASKS)
        if not callable(getattr(robot, "fk", None)):
            raise ValueError(f"robot must provide fk(q), got {type(robot).__name__}")
        self.robot, self.task = robot, task
        self.target = finite_array(target, "target", shape=(3,))
        self.reference = finite_array(reference, "reference", ndim=2)
        self.n_steps, self.n_dof = self.reference.shape
        t = finite_array(t, "t", shape=(self.n_steps,))
        self.index, self.fraction = _interpolation(
            t, 0.5 * (t[0] + t[-1]) if t_via is None else t_via, "t_via"
        )
        self.radius = check_float(radius, "radius", low=0.0, strict_low=True)
        self.width = check_float(width, "width", low=0.0, strict_low=True)
        self.shape_weight = check_float(shape_weight, "shape_weight", low=0.0)
        self.shape_scale = check_float(shape_scale, "shape_scale", low=0.0, strict_low=True)
        self.end = self._positions(self.reference[None, -1:])[0, 0]

    def _positions(self, trajectories: np.ndarray) -> np.ndarray:
        """Tool positions ``(B, T, 3)`` (m), in one FK call."""
        flat = torch.from_numpy(np.ascontiguousarray(trajectories.reshape(-1, trajectories.shape[-1])))
        poses = to_numpy(self.robot.fk(flat))
        return poses[:, :3, 3].astype(np.float64).reshape(*trajectories.shape[:-1], 3)

    def _check(self, trajectories) -> np.ndarray:
        trajectories = check_trajectories(trajectories, n_dof=self.n_dof)
        if trajectories.shape[1] != self.n_steps:
            raise ValueError(
                f"trajectories must have T = {self.n_steps} samples, got {trajectories.shape[1]}"
            )
        return trajectories

    def _task(self, trajectories: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-sample task costs ``(B, T)`` and the task error ``(B,)`` (m)."""
        p = self._positions(trajectories)
        costs = np.zeros(trajectories.shape[:2])
        if self.task == "reach":
            distance = np.linalg.norm(p[:, -1] - self.target, axis=-1)
            costs[:, -1] = np.square(distance / self.width)
            return costs, distance
        end = np.linalg.norm(p[:, -1] - self.end, axis=-1)
        costs[:, -1] = np.square(end / self.width)
        if self.task == "via_point":
            i, a = self.index, self.fraction
            via = np.linalg.norm((1.0 - a) * p[:, i] + a * p[:, i + 1] - self.target, axis=-1)
            costs[:, i] += np.square(via / self.width)
            return costs, np.maximum(via, end)
        depth = np.maximum(0.0, self.radius - np.linalg.norm(p - self.target, axis=-1))
        costs += np.square(depth / self.width)
        return costs, np.maximum(end, depth.max(axis=1))

    def _shape(self, trajectories: np.ndarray) -> np.ndarray:
        """Per-sample squared joint deviations ``(B, T)`` (rad^2) from the reference."""
        offset = trajectories - self.reference
        return np.einsum("btd,btd->bt", offset, offset)

    def costs(self, trajectories: np.ndarray) -> np.ndarray:
        """Per-sample costs ``(B, T)`` (task + shape)."""
        task, _ = self._task(trajectories)
        shape = self.shape_weight * self._shape(trajectories) / (self.shape_scale**2 * self.n_steps)
        return task + shape

    def error(self, trajectories) -> np.ndarray:
        """Task error ``(B,)`` (m)."""
        return self._task(self._check(trajectories))[1]

    def terms(self, trajectories) -> dict[str, np.ndarray]:
        """``{"task_error_m": (B,), "shape_rmse_rad": (B,)}`` of trajectories ``(B, T, D)``."""
        trajectories = self._check(trajectories)
        return {
            "task_error_m": self._task(trajectories)[1],
            "shape_rmse_rad": np.sqrt(self._shape(trajectories).mean(axis=1)),
        }
