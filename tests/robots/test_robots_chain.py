"""Single-configuration NumPy kinematics (lfd.robots.chain) against the batched torch Robot."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
import torch

from lfd.robots import ChainKinematics, available_robots, chain, load_robot


def test_doctest():
    result = doctest.testmod(chain, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


@pytest.mark.parametrize("name", available_robots())
def test_numpy_kinematics_equals_robot_fk(name):
    robot = load_robot(name)
    kin = ChainKinematics(robot.spec)
    q = robot.sample_q(20, torch.Generator().manual_seed(3)).numpy()
    frames = robot.fk(q, all_links=True).numpy()
    jacobians = robot.jacobian(q).numpy()
    for k in range(len(q)):
        np.testing.assert_allclose(kin.frames(q[k]), frames[k], atol=1e-12)
        np.testing.assert_allclose(kin.jacobian(q[k]), jacobians[k], atol=1e-12)
        np.testing.assert_allclose(kin.tool_position(q[k]), frames[k, -1, :3, 3], atol=1e-12)


def test_a_wrong_joint_changes_the_pose():
    robot = load_robot("sawyer")
    kin = ChainKinematics(robot.spec)
    q = robot.home.numpy()
    moved = q + np.eye(7)[3] * 0.2
    assert np.linalg.norm(kin.tool_position(moved) - kin.tool_position(q)) > 1e-3
