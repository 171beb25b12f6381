"""Reach tests (Workspace), IK nearest a reference (solve_near), FK positions of any batch
shape, cached robot constants and IK option forwarding."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.robots import IKResult, Workspace, solve_ik, solve_near


@pytest.fixture(scope="module")
def sawyer(robots):
    return robots["sawyer"]


@pytest.fixture(scope="module")
def workspace(sawyer):
    return Workspace(sawyer, n_samples=20_000, n_seeds=8)


# ---------------------------------------------------------------------------- fk_positions
def test_fk_positions_takes_any_leading_shape(sawyer):
    q = sawyer.sample_q(24, torch.Generator().manual_seed(0))
    flat = sawyer.fk(q)[:, :3, 3]
    assert torch.equal(sawyer.fk_positions(q), flat)
    assert torch.equal(sawyer.fk_positions(q.reshape(2, 3, 4, 7)), flat.reshape(2, 3, 4, 3))
    single = sawyer.fk_positions(q[0].numpy())
    assert single.shape == (3,) and single.dtype == torch.float64
    assert torch.allclose(single, flat[0])
    assert sawyer.fk_positions(q.float()).dtype == torch.float32
    with pytest.raises(ValueError, match=r"\(\.\.\., 7\)"):
        sawyer.fk_positions(np.zeros((5, 6)))


def test_robot_constants_are_built_once(sawyer):
    for name in ("lower", "upper", "continuous", "home", "velocity_limits", "effort_limits"):
        assert getattr(sawyer, name) is getattr(sawyer, name), name
    assert np.array_equal(sawyer.lower.numpy(), sawyer.spec.lower)


def test_robot_ik_forwards_options_to_solve_ik(sawyer):
    target = sawyer.fk(sawyer.sample_q(4, torch.Generator().manual_seed(1)))
    ours = sawyer.ik(target, max_iters=3, restarts=0, tol_pos=1e-3)
    reference = solve_ik(sawyer, target, max_iters=3, restarts=0, tol_pos=1e-3)
    assert torch.equal(ours.q, reference.q) and torch.equal(ours.success, reference.success)
    with pytest.raises(TypeError, match="restart_count"):
        sawyer.ik(target, restart_count=2)


# ---------------------------------------------------------------------------- solve_near
def test_solve_near_returns_the_solution_nearest_the_reference(sawyer):
    reference = np.radians([0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0])
    nearby = reference + np.array(
        [[0.10, -0.05, 0.08, 0.05, -0.10, 0.06, 0.02], [-0.08, 0.04, -0.05, -0.06, 0.05, 0.02, -0.04]]
    )
    poses = sawyer.fk(nearby)
    far = poses[:1].clone()
    far[0, :3, 3] += torch.tensor([3.0, 0.0, 0.0])  # 3 m away: no solution
    result = solve_near(sawyer, torch.cat([poses, far]).numpy(), reference, n_seeds=6, seed=0)
    assert isinstance(result, IKResult)
    assert result.q.shape == (3, 7) and result.success.dtype == torch.bool
    assert result.success.tolist() == [True, True, False]
    assert torch.equal(result.attempts, torch.full((3,), 6))
    # the solutions stay on the reference's branch: no farther from it than the known ones
    # (the arm is redundant, so a solution nearer than `nearby` may exist)
    distance = np.linalg.norm(result.q[:2].numpy() - reference, axis=1)
    assert np.all(distance <= np.linalg.norm(nearby - reference, axis=1) + 1e-3)
    assert torch.allclose(sawyer.fk(result.q[:2]), poses, atol=1e-3)
    assert float(result.pos_error[2]) > 1.0 and float(result.pos_error[:2].max()) <= 1e-4
    with pytest.raises(ValueError, match=r"poses must have shape \(G, 4, 4\)"):
        solve_near(sawyer, np.eye(4), reference)
    with pytest.raises(ValueError, match="reference must have shape"):
        solve_near(sawyer, poses.numpy(), reference[:6])


# ---------------------------------------------------------------------------- Workspace
def test_workspace_reaches_fk_goals_and_rejects_far_ones(sawyer, workspace):
    q = sawyer.sample_q(3, torch.Generator().manual_seed(4))
    poses = sawyer.fk(q).numpy()
    for pose in poses:
        test = workspace.test(pose[:3, 3], pose[:3, :3])
        assert test.reachable and test.pose_ik and test.reason == "reachable"
        assert test.shoulder_distance <= test.max_reach + 1e-9
    direction = np.array([1.0, 0.0, 0.0])
    beyond = workspace.shoulders[360] + 1.2 * workspace.max_reach * direction
    far = workspace.test(beyond)
    assert not far.reachable and not far.position_ik and far.reason.startswith("unreachable")
    assert far.shoulder_distance > far.max_reach
    with pytest.raises(ValueError, match="goal must be 3 finite numbers"):
        workspace.test([0.1, np.nan, 0.0])


def test_workspace_reach_and_shoulder_match_the_link_frames(sawyer, workspace):
    """The shoulder positions are link 1's origin as joint 0 turns; the maximum reach bounds
    every sampled tool-to-shoulder distance and is nearly attained."""
    q = sawyer.sample_q(5000, torch.Generator().manual_seed(7))
    frames = sawyer.fk(q, all_links=True)
    distances = (frames[:, -1, :3, 3] - frames[:, 1, :3, 3]).norm(dim=1)
    assert float(distances.max()) <= workspace.max_reach + 1e-9
    assert float(distances.max()) > 0.97 * workspace.max_reach
    axis_xy = sawyer.fk(sawyer.home[None], all_links=True)[
        0, 0, :2, 3
    ].numpy()  # link 0 lies on joint 0's axis
    radii = np.linalg.norm(workspace.shoulders[:, :2] - axis_xy, axis=1)
    assert (
        np.ptp(radii) < 1e-6 and np.ptp(workspace.shoulders[:, 2]) < 1e-9
    )  # a circle about joint 0's vertical axis
    on_shoulder = workspace.test(workspace.shoulders[100])
    assert on_shoulder.shoulder_distance == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="shoulder_link"):
        Workspace(sawyer, shoulder_link=9)
