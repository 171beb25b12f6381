"""The one joint-trajectory tracker (lfd.sim.tracking): its callers' schedules and limits."""

from __future__ import annotations

import doctest

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim import tracking
from lfd.sim.tracking import ArmWorld, execute_joint_trajectory, sample_steps, track_trajectory


def test_doctest():
    result = doctest.testmod(tracking, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


def test_sample_steps_follow_the_sample_times():
    t = np.array([0.0, 0.1, 0.1 + 1e-4, 0.5])
    steps = sample_steps(t, 240.0)
    assert steps[0] == 0 and min(steps[1:]) >= 1
    assert abs(sum(steps) / 240.0 - (t[-1] - t[0])) <= 0.5 / 240.0


def test_targets_outside_the_limits_are_clipped_and_counted():
    robot = load_robot("wam4")
    upper = robot.upper.numpy()
    t = np.linspace(0.0, 1.0, 20)
    q = np.tile(robot.home.numpy(), (20, 1))
    q[10:, 1] = upper[1] + 0.5  # beyond the limit for the second half
    run = execute_joint_trajectory(robot, t, q)
    assert run.clipped_samples == 10
    assert run.q.shape == (20, 4) and run.tool.shape == (20, 3)
    assert run.q[:, 1].max() <= upper[1] + 1e-2


def test_feed_forward_and_settling_in_an_arm_world():
    robot = load_robot("sawyer")
    q0 = robot.home.numpy()
    q = q0 + np.linspace(0.0, 0.3, 25)[:, None]
    with ArmWorld(robot, timestep=0.004, position_gain=0.3, velocity_gain=1.0) as world:
        run = track_trajectory(
            world, q, [0] + [10] * 24, velocity=np.gradient(q, 0.04, axis=0), settle_steps=250, record=False
        )
    assert run.q.shape == (0, 7)
    assert np.abs(run.q_final - q[-1]).max() < 0.01


def test_wrong_schedule_raises():
    robot = load_robot("wam4")
    with ArmWorld(robot, timestep=1 / 240) as world, pytest.raises(ValueError, match="track_trajectory"):
        track_trajectory(world, np.zeros((5, 4)), [1, 1])
    with pytest.raises(ValueError, match="strictly increasing"):
        execute_joint_trajectory(robot, [0.0, 0.0], np.zeros((2, 4)))
