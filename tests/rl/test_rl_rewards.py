"""Eq. 5.4 rewards, joint-limit violations and their input validation."""

import math

import numpy as np
import pytest
import torch

from lfd.rl import JointGoalReward, TaskGoalReward, limit_violation, returns_from_distances


def test_returns_match_hand_computation_of_eq_5_4():
    distances = np.array([[0.5, 0.2, 0.1], [1.0, 0.0, 2.0]])
    w1 = 0.3
    # r(T) = w1 exp(-d_T^2); r(t < T) = (1 - w1) / (number of running steps) exp(-d_t^2)
    first = 0.3 * math.exp(-0.01) + 0.7 / 2 * (math.exp(-0.25) + math.exp(-0.04))
    second = 0.3 * math.exp(-4.0) + 0.7 / 2 * (math.exp(-1.0) + 1.0)
    np.testing.assert_allclose(returns_from_distances(distances, w1), [first, second], rtol=1e-12)


def test_running_part_is_normalised_by_step_count_not_duration():
    coarse = np.full((1, 11), 0.3)
    fine = np.full((1, 1001), 0.3)
    np.testing.assert_allclose(returns_from_distances(coarse, 0.2), returns_from_distances(fine, 0.2))
    np.testing.assert_allclose(returns_from_distances(coarse, 0.2), math.exp(-0.09))


def test_w1_extremes_select_terminal_or_running_part():
    distances = np.array([[1.0, 1.0, 0.0]])
    assert returns_from_distances(distances, 1.0)[0] == pytest.approx(1.0)
    assert returns_from_distances(distances, 0.0)[0] == pytest.approx(math.exp(-1.0))


def test_joint_reward_uses_euclidean_joint_distance_and_terminal_error():
    goal = np.array([1.0, -1.0])
    trajectories = np.array([[[0.0, 0.0], [1.0, -1.0]], [[1.0, -1.0], [1.3, -0.6]]])
    reward = JointGoalReward(goal, w1=0.6)
    expected = [0.6 * 1.0 + 0.4 * math.exp(-2.0), 0.6 * math.exp(-0.25) + 0.4 * 1.0]
    np.testing.assert_allclose(reward(trajectories), expected, rtol=1e-12)
    np.testing.assert_allclose(reward.error(trajectories), [0.0, 0.5], atol=1e-12)


def test_task_reward_equals_per_sample_forward_kinematics(sawyer):
    rng = np.random.default_rng(0)
    trajectories = rng.uniform(-1.0, 1.0, size=(3, 5, 7))
    target = np.array([0.4, -0.3, 0.2])
    reward = TaskGoalReward(sawyer, target, w1=0.7)
    positions = np.array(
        [[sawyer.fk(torch.tensor(q[None]))[0, :3, 3].numpy() for q in traj] for traj in trajectories]
    )
    distances = np.linalg.norm(positions - target, axis=-1)
    np.testing.assert_allclose(reward.positions(trajectories), positions, atol=1e-12)
    np.testing.assert_allclose(reward(trajectories), returns_from_distances(distances, 0.7), rtol=1e-12)
    np.testing.assert_allclose(reward.error(trajectories), distances[:, -1], atol=1e-12)


def test_limit_violation_is_the_largest_excess_in_radians():
    lower, upper = np.array([-1.0, -np.inf]), np.array([1.0, np.inf])
    trajectories = np.array([[[0.0, 5.0], [0.5, -9.0]], [[1.25, 0.0], [-1.5, 0.0]]])
    np.testing.assert_allclose(limit_violation(trajectories, lower, upper), [0.0, 0.5])


@pytest.mark.parametrize("w1", [-0.1, 1.5, float("nan"), "0.5"])
def test_w1_outside_unit_interval_is_rejected(w1):
    with pytest.raises(ValueError, match="w1"):
        JointGoalReward(np.zeros(2), w1=w1)
    with pytest.raises(ValueError, match="w1"):
        returns_from_distances(np.zeros((1, 2)), w1)


def test_bad_goals_and_shapes_are_rejected(sawyer):
    with pytest.raises(ValueError, match="goal"):
        JointGoalReward([0.0, float("nan")])
    with pytest.raises(ValueError, match="goal"):
        JointGoalReward(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="target"):
        TaskGoalReward(sawyer, [0.1, 0.2])
    with pytest.raises(ValueError, match="target"):
        TaskGoalReward(sawyer, [0.1, float("inf"), 0.0])
    with pytest.raises(ValueError, match="robot"):
        TaskGoalReward(object(), [0.1, 0.2, 0.3])
    reward = JointGoalReward(np.zeros(2))
    with pytest.raises(ValueError, match="trajectories"):
        reward(np.zeros((4, 10, 3)))
    with pytest.raises(ValueError, match="trajectories"):
        reward(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="trajectories"):
        reward(np.zeros((1, 1, 2)))
    with pytest.raises(ValueError, match="distances"):
        returns_from_distances(np.zeros(5), 0.5)
