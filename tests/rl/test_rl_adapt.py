"""Goal adaptation of a learned Sawyer DMP in joint and task space."""

import dataclasses

import numpy as np
import pytest

from lfd.rl import adapt_to_goal, goal_configuration

OFFSET = np.array([0.25, -0.2, 0.15, 0.3, -0.2, 0.25, -0.3])


def test_joint_space_goal_is_reached_within_limits(sawyer_dmp, sawyer):
    goal = sawyer_dmp.goal_ + OFFSET
    result = adapt_to_goal(sawyer_dmp, goal, robot=sawyer, seed=0)
    assert result.converged and result.within_limits
    assert np.linalg.norm(result.trajectory[-1] - goal) <= 0.01
    assert bool(sawyer.within_limits(result.trajectory).all())
    np.testing.assert_allclose(result.trajectory[0], sawyer_dmp.y0_)


def test_task_space_goal_is_reached_within_one_centimetre(sawyer_dmp, sawyer):
    reachable = sawyer_dmp.goal_ + OFFSET
    target = sawyer.fk(reachable[None])[0, :3, 3].numpy()
    result = adapt_to_goal(sawyer_dmp, target, robot=sawyer, space="task", seed=0)
    final = sawyer.fk(result.trajectory[-1:])[0, :3, 3].numpy()
    assert result.converged and result.within_limits
    assert np.linalg.norm(final - target) <= 0.01
    assert result.error == pytest.approx(np.linalg.norm(final - target))


def test_pose_target_uses_orientation_when_reachable(sawyer_dmp, sawyer):
    pose = sawyer.fk((sawyer_dmp.goal_ + OFFSET)[None])[0].numpy()
    q = goal_configuration(sawyer, pose, sawyer_dmp.goal_)
    reached = sawyer.fk(q[None])[0].numpy()
    np.testing.assert_allclose(reached[:3, 3], pose[:3, 3], atol=1e-3)
    np.testing.assert_allclose(reached[:3, :3], pose[:3, :3], atol=1e-2)


class _PoseFailingRobot:
    """Stands in for a robot whose IK fails for any orientation: records the IK targets."""

    n_dof = 7

    def __init__(self, robot):
        self.robot, self.targets = robot, []

    def ik(self, target, q0):
        self.targets.append(np.shape(target))
        result = self.robot.ik(target, q0)
        return dataclasses.replace(result, success=result.success & (np.shape(target)[1:] == (3,)))


def test_pose_target_falls_back_to_position_only_ik(sawyer_dmp, sawyer):
    pose = sawyer.fk((sawyer_dmp.goal_ + OFFSET)[None])[0].numpy()
    robot = _PoseFailingRobot(sawyer)
    q = goal_configuration(robot, pose, sawyer_dmp.goal_)
    assert robot.targets == [(1, 4, 4), (1, 3)]
    np.testing.assert_allclose(sawyer.fk(q[None])[0, :3, 3].numpy(), pose[:3, 3], atol=1e-3)


def test_unreachable_target_gives_best_effort_without_convergence(sawyer_dmp, sawyer):
    far = np.array([1.11, -0.551, -0.04])  # the protocol's goal 3: beyond the Sawyer's reach
    result = adapt_to_goal(sawyer_dmp, far, robot=sawyer, space="task", max_iter=5, seed=0)
    assert not result.converged and result.error > 0.05
    assert np.all(np.isfinite(result.trajectory))
    assert result.within_limits == bool(sawyer.within_limits(result.trajectory).all())


def test_bad_goals_are_rejected(sawyer_dmp, sawyer):
    with pytest.raises(ValueError, match="goal"):
        adapt_to_goal(sawyer_dmp, np.full(7, np.nan), robot=sawyer)
    with pytest.raises(ValueError, match="goal"):
        adapt_to_goal(sawyer_dmp, np.zeros(6), robot=sawyer)
    with pytest.raises(ValueError, match="limits"):
        adapt_to_goal(sawyer_dmp, np.full(7, 3.5), robot=sawyer)
    with pytest.raises(ValueError, match="robot"):
        adapt_to_goal(sawyer_dmp, np.zeros(3), space="task")
    with pytest.raises(ValueError, match="goal"):
        adapt_to_goal(sawyer_dmp, np.zeros(7), robot=sawyer, space="task")
    with pytest.raises(ValueError, match="space"):
        adapt_to_goal(sawyer_dmp, np.zeros(7), space="cartesian")
    with pytest.raises(ValueError, match="w1"):
        adapt_to_goal(sawyer_dmp, sawyer_dmp.goal_, w1=2.0)
    with pytest.raises(ValueError, match="n_rollouts"):
        adapt_to_goal(sawyer_dmp, sawyer_dmp.goal_, n_rollouts=0)
