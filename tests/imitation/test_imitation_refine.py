"""lfd.imitation.refine: a demonstrated WAM reach refined by each policy search to a target 10 cm from its
end point and through a via point, both within 1 cm; an unreachable target refused before any rollout."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.dmp import DMP
from lfd.imitation.refine import refine_skill
from lfd.robots import load_robot


@pytest.fixture(scope="module")
def demo():
    robot = load_robot("wam4")
    t = np.linspace(0.0, 2.0, 200)
    s = t / t[-1]
    q = robot.home.numpy() + np.outer(10 * s**3 - 15 * s**4 + 6 * s**5, [0.4, 0.3, 0.2, 0.8])
    return robot, DMP(n_basis=20).fit(t, q), q


def _tool(robot, q):
    return robot.fk(torch.from_numpy(np.ascontiguousarray(q)))[:, :3, 3].numpy()


@pytest.mark.parametrize("method", ["power", "pibb", "cmaes"])
def test_reach_a_target_10_cm_away_within_1_cm(demo, method):
    robot, dmp, q = demo
    offset = np.array([0.06, 0.06, -0.05])
    target = _tool(robot, q[-1:])[0] + 0.1 * offset / np.linalg.norm(offset)
    result = refine_skill(robot, dmp, task="reach", target=target, method=method, seed=1)
    reached = _tool(robot, result.trajectory[-1:])[0]
    assert result.converged and np.linalg.norm(reached - target) <= 0.01
    assert result.task_error_m == pytest.approx(np.linalg.norm(reached - target), abs=1e-12)
    assert (
        1 < result.rollouts <= 400 and result.shape_rmse_rad > 0
    )  # it searched, and moved away from the demo
    assert (result.trajectory >= robot.lower.numpy() - 1e-9).all()
    assert result.history[0]["task_error_m"] == pytest.approx(0.1, abs=1e-6)


def test_via_point_is_passed_within_1_cm_and_the_end_kept(demo):
    robot, dmp, q = demo
    t = np.linspace(0.0, float(dmp.tau_), int(dmp.n_steps_))
    middle = _tool(robot, q[100:101])[0]
    target = middle + [0.0, 0.05, 0.05]
    result = refine_skill(robot, dmp, task="via_point", target=target, t_via=t[100], method="power", seed=0)
    tool = _tool(robot, result.trajectory)
    assert result.converged and np.linalg.norm(tool[100] - target) <= 0.0101
    assert np.linalg.norm(tool[-1] - _tool(robot, q[-1:])[0]) <= 0.0101


def test_unreachable_target_is_refused_before_searching(demo):
    robot, dmp, _ = demo
    with pytest.raises(ValueError, match=r"refine.target \[3.0, 0.0, 0.0\] is out of reach of wam4"):
        refine_skill(robot, dmp, task="reach", target=[3.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="refine.method must be one of"):
        refine_skill(robot, dmp, task="reach", target=[0.3, 0.2, 0.2], method="sgd")


def test_a_search_that_converges_early_ends_its_progress_bar_saying_so(demo, capsys):
    robot, dmp, q = demo
    offset = np.array([0.06, 0.06, -0.05])
    target = _tool(robot, q[-1:])[0] + 0.1 * offset / np.linalg.norm(offset)
    result = refine_skill(robot, dmp, task="reach", target=target, seed=1, progress=True)
    assert result.converged and result.rollouts < 400
    last = capsys.readouterr().err.replace("\r", "\n").strip().splitlines()[-1]
    assert "100%" in last and f"converged after {result.rollouts} of 400 rollouts" in last, last
