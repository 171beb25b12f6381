"""Batched numerical IK and the WAM closed form, checked by independent forward kinematics."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from lfd.robots import load_robot, rotation_log, wam4_ik_closed_form
from lfd.robots.spec import make_transform


def pose_errors(robot, q, target):
    """Position (m) and rotation (rad) errors of FK(q) against (B, 4, 4) targets, via scipy."""
    pose = robot.fk(q).numpy()
    target = np.asarray(target)
    pos = np.linalg.norm(pose[:, :3, 3] - target[:, :3, 3], axis=1)
    rel = np.swapaxes(target[:, :3, :3], 1, 2) @ pose[:, :3, :3]
    return pos, Rotation.from_matrix(rel).magnitude()


@pytest.mark.parametrize(
    "count",
    [pytest.param(200, id="200"), pytest.param(1000, id="1000", marks=pytest.mark.slow)],
)
@pytest.mark.parametrize("name", ["pr2_right_arm", "sawyer"])
def test_ik_solves_random_reachable_poses(robots, name, count):
    robot = robots[name]
    targets = robot.fk(robot.sample_q(count, torch.Generator().manual_seed(10)))
    result = robot.ik(targets)
    pos, rot = pose_errors(robot, result.q, targets)
    ok = result.success.numpy()
    assert ok.mean() >= 0.99
    assert pos[ok].max() < 1e-4 and rot[ok].max() < 1e-3
    np.testing.assert_allclose(result.pos_error.numpy(), pos, atol=1e-9)
    np.testing.assert_allclose(result.rot_error.numpy(), rot, atol=1e-7)
    assert bool(robot.within_limits(result.q).all())
    assert bool(((result.q >= robot.lower) & (result.q <= robot.upper)).all())


@pytest.mark.parametrize("name", ["wam4", "human_arm", "sawyer"])
def test_ik_position_only(robots, name):
    robot = robots[name]
    positions = robot.fk(robot.sample_q(100, torch.Generator().manual_seed(11)))[:, :3, 3]
    result = robot.ik(positions)
    assert result.success.float().mean() >= 0.99
    reached = robot.fk(result.q)[:, :3, 3]
    assert (reached - positions).norm(dim=1)[result.success].max() < 1e-4
    assert bool((result.rot_error == 0).all())


def test_ik_wam_full_pose_of_reachable_targets(robots):
    robot = robots["wam4"]  # 4 DoF: 6-D targets are reachable only when made by FK
    targets = robot.fk(robot.sample_q(100, torch.Generator().manual_seed(12)))
    result = robot.ik(targets)
    assert result.success.float().mean() >= 0.99
    pos, rot = pose_errors(robot, result.q, targets)
    assert pos[result.success.numpy()].max() < 1e-4 and rot[result.success.numpy()].max() < 1e-3


def test_ik_reports_unreachable_targets_with_their_residual(robots):
    robot = robots["sawyer"]
    reachable = robot.fk(robot.sample_q(3, torch.Generator().manual_seed(13)))
    far = make_transform((3.0, 0.0, 0.5))
    targets = torch.cat((reachable, torch.as_tensor(far)[None]))
    result = robot.ik(targets, restarts=8)
    assert result.success.tolist() == [True, True, True, False]
    pos, rot = pose_errors(robot, result.q, targets)
    np.testing.assert_allclose(result.pos_error.numpy(), pos, atol=1e-9)
    np.testing.assert_allclose(result.rot_error.numpy(), rot, atol=1e-7)
    assert pos[3] > 1.5  # the arm reaches about 1.1 m from its shoulder
    assert int(result.attempts[3]) == 9 and bool(robot.within_limits(result.q).all())


def test_ik_spec_sawyer_goals_goal3_unreachable(robots):
    goals = [[0.237, -0.466, -0.04], [-0.217, -0.474, -0.04], [1.110, -0.551, -0.04], [-0.179, -0.678, -0.04],
             [0.217, -0.680, -0.04], [0.035, -0.573, -0.04]]  # fmt: skip
    result = robots["sawyer"].ik(np.array(goals))
    assert result.success.tolist() == [True, True, False, True, True, True]
    assert float(result.pos_error[2]) > 0.05


def test_ik_float32_and_reproducible(robots):
    robot = robots["pr2_right_arm"]
    targets = robot.fk(robot.sample_q(50, torch.Generator().manual_seed(14))).float()
    first, second = robot.ik(targets, seed=3), robot.ik(targets, seed=3)
    assert first.q.dtype == torch.float32
    torch.testing.assert_close(first.q, second.q, atol=0, rtol=0)
    assert first.success.float().mean() >= 0.98
    pos, rot = pose_errors(robot, first.q.double(), targets.double())
    ok = first.success.numpy()
    assert pos[ok].max() < 2e-4 and rot[ok].max() < 2e-3  # float32 round-off on top of the tolerances


def test_ik_initial_guess(robots):
    robot = robots["sawyer"]
    q_true = robot.sample_q(20, torch.Generator().manual_seed(15))
    targets = robot.fk(q_true)
    near = robot.ik(targets, q0=q_true + 0.01, restarts=0)
    assert bool(near.success.all()) and bool((near.attempts == 1).all())
    assert (near.q - q_true).abs().max() < 0.1
    assert robot.ik(targets[:1], q0=robot.home, restarts=0).q.shape == (1, 7)  # (n,) guess broadcast
    with pytest.raises(ValueError, match="20 rows"):
        robot.ik(targets, q0=q_true[:5])
    with pytest.raises(ValueError, match=r"q0 must have shape \(B, 7\)"):
        robot.ik(targets, q0=np.zeros((20, 6)))


@pytest.mark.parametrize(
    ("target", "message"),
    [
        (np.zeros((2, 3, 3)), r"\(B, 4, 4\)"),
        (np.zeros(3), r"\(B, 3\)"),
        (np.full((1, 3), np.nan), "NaN or inf"),
    ],
)
def test_ik_bad_targets(robots, target, message):
    with pytest.raises(ValueError, match=message):
        robots["wam4"].ik(target)


def test_ik_bad_options(robots):
    with pytest.raises(ValueError, match="max_iters"):
        robots["wam4"].ik(np.zeros((1, 3)), max_iters=0)


def test_rotation_log_matches_scipy_including_near_pi():
    rng = np.random.default_rng(0)
    axes = rng.normal(size=(400, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, np.pi, 100), np.pi - 10.0 ** rng.uniform(-12, -1, 100),
                             10.0 ** rng.uniform(-12, -1, 100), np.full(100, np.pi)])  # fmt: skip
    vectors = axes * angles[:, None]
    matrices = torch.as_tensor(Rotation.from_rotvec(vectors).as_matrix())
    ours = rotation_log(matrices).numpy()
    ours_again = Rotation.from_rotvec(ours).as_matrix()
    np.testing.assert_allclose(np.linalg.norm(ours, axis=1), angles, atol=1e-9)
    np.testing.assert_allclose(ours_again, matrices.numpy(), atol=1e-9)


# ---------------------------------------------------------------------- WAM closed form


@pytest.mark.parametrize("q3", [0.0, 0.7, -2.0])
def test_wam_closed_form_reproduces_targets(robots, q3):
    robot = robots["wam4"]
    q = robot.sample_q(500, torch.Generator().manual_seed(16))
    q[:, 2] = q3
    position = robot.fk(q)[:, :3, 3]
    solutions, valid = wam4_ik_closed_form(position, q3=q3)
    assert solutions.shape == (500, 4, 4) and valid.shape == (500, 4)
    assert bool(valid.any(dim=1).all())
    assert bool(torch.isnan(solutions[~valid]).all()) and not bool(torch.isnan(solutions[valid]).any())
    flat = solutions[valid]
    assert bool(robot.within_limits(flat).all()) and bool((flat[:, 2] == q3).all())
    index = valid.nonzero()[:, 0]
    torch.testing.assert_close(robot.fk(flat)[:, :3, 3], position[index], atol=1e-12, rtol=0)
    distance = (solutions - q[:, None]).abs().amax(dim=2).nan_to_num(nan=np.inf)
    assert float(distance.min(dim=1).values.max()) < 1e-9  # the generating configuration is among them


def test_wam_closed_form_joint1_and_four_branches(robots):
    robot = robots["wam4"]
    q = torch.tensor([[1.0, 0.4, 0.0, 1.2]], dtype=torch.float64)
    position = robot.fk(q)[:, :3, 3]
    solutions, valid = wam4_ik_closed_form(position)
    assert valid.tolist() == [[True, True, True, True]]
    azimuth = float(torch.atan2(position[0, 1], position[0, 0]))
    q1 = solutions[0, :, 0].numpy()
    assert np.allclose(np.cos(q1 - azimuth), [1, -1, 1, -1])  # shoulder branch: atan2(y, x) or its opposite
    assert len({round(float(v), 6) for v in solutions[0, :, 3]}) == 2  # elbow up / down


def test_wam_closed_form_unreachable_and_errors(robots):
    solutions, valid = wam4_ik_closed_form(np.array([[2.0, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    assert not bool(valid.any()) and bool(torch.isnan(solutions).all())
    with pytest.raises(ValueError, match="outside joint 3"):
        wam4_ik_closed_form(np.zeros((1, 3)), q3=3.0)
    with pytest.raises(ValueError, match="catalogue 'wam4'"):
        wam4_ik_closed_form(np.zeros((1, 3)), robot=robots["human_arm"])
    with pytest.raises(ValueError, match=r"\(B, 3\)"):
        wam4_ik_closed_form(np.zeros((1, 4)))


def test_wam_closed_form_with_base_transform():
    base = make_transform((0.5, -0.2, 0.8), (0.1, 0.0, 0.3))
    robot = load_robot("wam4", base_transform=base)
    q = robot.sample_q(100, torch.Generator().manual_seed(17))
    q[:, 2] = 0.0
    position = robot.fk(q)[:, :3, 3]
    solutions, valid = wam4_ik_closed_form(position, robot=robot)
    reached = robot.fk(solutions[valid])[:, :3, 3]
    torch.testing.assert_close(reached, position[valid.nonzero()[:, 0]], atol=1e-12, rtol=0)
