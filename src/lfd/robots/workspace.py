"""Reach tests: can a robot put its tool at a goal, and how far is the goal from its shoulder?

:class:`Workspace` answers for one robot: full-pose and position-only IK from several seeds,
and the goal's distance from the shoulder against the arm's maximum reach, so that a goal
without an IK solution is told apart as *beyond the reach* or *within it but unsolved*.
Pure torch + NumPy; metres and radians, world frame.

Example::

    >>> import numpy as np
    >>> from lfd.robots import Workspace, load_robot
    >>> robot = load_robot("sawyer")
    >>> workspace = Workspace(robot, n_samples=20_000, n_seeds=8)
    >>> workspace.test((0.237, -0.466, -0.04)).reachable, workspace.test((1.11, -0.551, -0.04)).reason[:11]
    (True, 'unreachable')
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch

from .ik import solve_near

if TYPE_CHECKING:
    from .robot import Robot

__all__ = ["ReachTest", "Workspace"]


@dataclass(frozen=True)
class ReachTest:
    """Whether a goal can be reached.

    Attributes:
        reachable: a position-only IK solution exists (the pose one may still fail).
        pose_ik: a full-pose IK solution (goal position + task orientation) exists.
        position_ik: a position-only IK solution exists.
        shoulder_distance: distance (m) from the goal to the nearest shoulder position.
        max_reach: the arm's maximum reach from the shoulder (m).
        reason: human-readable verdict for the tables.
    """

    reachable: bool
    pose_ik: bool
    position_ik: bool
    shoulder_distance: float
    max_reach: float
    reason: str


class Workspace:
    """Reach test of goals for one robot.

    The shoulder is the origin of link ``shoulder_link`` (joint 1's axis for the Sawyer);
    it moves with joint 0, so a goal's distance is to the nearest of its positions over
    joint 0's range (721 samples). The maximum reach is the largest tool-to-shoulder
    distance over ``n_samples`` uniform configurations (seeded by ``seed``).

    Args:
        robot: a :class:`lfd.robots.Robot`.
        shoulder_link: index of the shoulder link in ``robot.fk(q, all_links=True)``.
        n_samples: configurations sampled for the maximum reach.
        n_seeds: IK seeds per goal (the home pose, then uniform ones).
        seed: seed of the sampling and of the IK seeds.
    """

    def __init__(
        self, robot: Robot, shoulder_link: int = 1, n_samples: int = 100_000, n_seeds: int = 32, seed: int = 0
    ) -> None:
        if not 0 <= shoulder_link < robot.n_dof:
            raise ValueError(
                f"Workspace.shoulder_link: expected 0 <= link < {robot.n_dof}, got {shoulder_link}"
            )
        if n_samples < 1 or n_seeds < 1:
            raise ValueError(f"Workspace: need n_samples >= 1 and n_seeds >= 1, got {n_samples}, {n_seeds}")
        self.robot, self.n_seeds, self.seed = robot, n_seeds, seed
        gen = torch.Generator().manual_seed(seed)
        frames = robot.fk(robot.sample_q(n_samples, gen), all_links=True)
        self.max_reach = float((frames[:, -1, :3, 3] - frames[:, shoulder_link, :3, 3]).norm(dim=1).max())
        sweep = robot.home.repeat(721, 1)
        sweep[:, 0] = torch.linspace(float(robot.lower[0]), float(robot.upper[0]), 721, dtype=sweep.dtype)
        self.shoulders = robot.fk(sweep, all_links=True)[:, shoulder_link, :3, 3].numpy()

    def test(self, goal: Sequence[float], rotation: np.ndarray | None = None) -> ReachTest:
        """Reach test of ``goal (3,)`` (m), with the tool orientation ``rotation (3, 3)`` if given."""
        goal = np.asarray(goal, dtype=np.float64)
        if goal.shape != (3,) or not np.all(np.isfinite(goal)):
            raise ValueError(f"Workspace.test: goal must be 3 finite numbers (m), got {goal!r}")
        distance = float(np.linalg.norm(self.shoulders - goal, axis=1).min())
        home = self.robot.home.numpy()
        result = self.robot.ik(
            torch.from_numpy(goal[None]).expand(self.n_seeds, 3),
            q0=self._seeds(home),
            position_only=True,
            restarts=0,
        )
        position_ok = bool(result.success.any())
        pose_ok = False
        if rotation is not None:
            pose = np.eye(4)
            pose[:3, :3], pose[:3, 3] = rotation, goal
            pose_ok = bool(solve_near(self.robot, pose[None], home, self.n_seeds, self.seed).success[0])
        if position_ok:
            reason = (
                "reachable"
                if pose_ok or rotation is None
                else "reachable (position only; no IK solution with the task orientation)"
            )
        elif distance > self.max_reach:
            reason = f"unreachable: {distance:.3f} m from the shoulder > {self.max_reach:.3f} m maximum reach"
        else:
            reason = f"no IK solution ({distance:.3f} m from the shoulder, within the {self.max_reach:.3f} m reach)"
        return ReachTest(position_ok, pose_ok, position_ok, distance, self.max_reach, reason)

    def _seeds(self, home: np.ndarray) -> torch.Tensor:
        gen = torch.Generator().manual_seed(self.seed)
        return torch.cat([torch.from_numpy(home)[None], self.robot.sample_q(self.n_seeds - 1, gen)])
