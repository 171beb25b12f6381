"""lfd.rl.skill.SkillReward: the task terms against hand-computed FK distances, the shape term against the
RMSE, and the returns against exp(-sum of costs)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.rl.skill import SkillReward
from lfd.robots import load_robot


@pytest.fixture(scope="module")
def wam():
    robot = load_robot("wam4")
    t = np.linspace(0.0, 1.0, 21)
    q = robot.home.numpy() + np.outer(t, [0.3, 0.2, 0.1, 0.6])
    return robot, t, q


def _tool(robot, q):
    return robot.fk(torch.from_numpy(np.ascontiguousarray(q)))[:, :3, 3].numpy()


def test_reach_term_is_the_end_distance_and_shape_the_rmse(wam):
    robot, t, q = wam
    target = _tool(robot, q[-1:])[0] + [0.03, 0.0, -0.04]
    reward = SkillReward(robot, "reach", target, q, t, width=0.02, shape_weight=2.0, shape_scale=0.1)
    moved = q + 0.05  # every joint 0.05 rad off
    batch = np.stack([q, moved])
    terms = reward.terms(batch)
    expected_end = np.linalg.norm(_tool(robot, batch[:, -1]) - target, axis=-1)
    np.testing.assert_allclose(terms["task_error_m"], expected_end, rtol=1e-12)
    np.testing.assert_allclose(
        terms["shape_rmse_rad"], [0.0, 0.05 * 2], rtol=1e-12
    )  # sqrt(4 joints * 0.05^2)
    cost = (expected_end / 0.02) ** 2 + 2.0 * terms["shape_rmse_rad"] ** 2 / 0.1**2
    np.testing.assert_allclose(reward(batch), np.exp(-cost), rtol=1e-10)
    np.testing.assert_allclose(reward.error(batch), expected_end)


def test_via_point_and_avoid_terms(wam):
    robot, t, q = wam
    tool = _tool(robot, q)
    via = SkillReward(robot, "via_point", tool[10] + [0.0, 0.0, 0.05], q, t, t_via=t[10])
    assert via.error(q[None])[0] == pytest.approx(0.05, abs=1e-12)  # ends where the demo ends
    centre = tool[10] + [0.0, 0.0, 0.01]
    avoid = SkillReward(robot, "avoid", centre, q, t, radius=0.04)
    deepest = 0.04 - np.linalg.norm(tool - centre, axis=-1).min()  # at most 1 cm from the centre
    assert deepest >= 0.03 and avoid.error(q[None])[0] == pytest.approx(deepest, abs=1e-12)
    clear = SkillReward(robot, "avoid", tool[10] + [0.0, 0.0, 0.5], q, t, radius=0.04)
    assert clear.error(q[None])[0] == pytest.approx(0.0, abs=1e-12)


def test_bad_arguments_name_the_field(wam):
    robot, t, q = wam
    with pytest.raises(ValueError, match="task must be one of"):
        SkillReward(robot, "throw", [0, 0, 0], q, t)
    with pytest.raises(ValueError, match="target"):
        SkillReward(robot, "reach", [0, np.nan, 0], q, t)
    with pytest.raises(ValueError, match="t_via"):
        SkillReward(robot, "via_point", [0, 0, 0], q, t, t_via=5.0)
    with pytest.raises(ValueError, match="T = 21"):
        SkillReward(robot, "reach", [0, 0, 0], q, t).error(q[None, :10])
