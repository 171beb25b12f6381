"""Forward kinematics and Jacobian against PyBullet, finite differences and autograd."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.robots import available_robots, load_robot, rotation_log

ROBOT_NAMES = available_robots()
DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


def rotation_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angles (rad) between rotations (..., 3, 3), accurate near zero."""
    rel = torch.as_tensor(np.swapaxes(a, -1, -2) @ b).reshape(-1, 3, 3)
    return rotation_log(rel).norm(dim=1).numpy()


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_fk_matches_pybullet(robots, bullet, name):
    robot = robots[name]
    body = bullet(robot)
    q = robot.sample_q(200, torch.Generator().manual_seed(0))
    ours = robot.fk(q, all_links=True).numpy()
    theirs = np.empty_like(ours)
    for b, qb in enumerate(q.numpy()):
        body.set_q(qb)
        theirs[b] = body.link_frames()
    assert np.abs(ours[..., :3, 3] - theirs[..., :3, 3]).max() < 1e-6
    assert rotation_angle(ours[..., :3, :3], theirs[..., :3, :3]).max() < 1e-6
    np.testing.assert_allclose(robot.fk(q).numpy(), ours[:, -1], atol=1e-15)


def _fk_twist(robot, q: torch.Tensor, dq: torch.Tensor) -> torch.Tensor:
    """Central-difference twist (B, 6): tool point velocity and angular velocity along dq."""
    plus, minus = robot.fk(q + dq), robot.fk(q - dq)
    linear = (plus[:, :3, 3] - minus[:, :3, 3]) / 2
    angular = rotation_log(plus[:, :3, :3] @ minus[:, :3, :3].transpose(1, 2)) / 2
    return torch.cat((linear, angular), dim=1)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_jacobian_matches_finite_differences(robots, name):
    robot = robots[name]
    q = robot.sample_q(100, torch.Generator().manual_seed(1))
    jac = robot.jacobian(q)
    eps = 1e-6
    for j in range(robot.n_dof):
        dq = torch.zeros_like(q)
        dq[:, j] = eps
        torch.testing.assert_close(_fk_twist(robot, q, dq) / eps, jac[:, :, j], atol=1e-8, rtol=0)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_jacobian_matches_autograd(robots, name):
    robot = robots[name]
    q = robot.sample_q(20, torch.Generator().manual_seed(2)).requires_grad_(True)
    pose = robot.fk(q)
    rows = [
        torch.autograd.grad(pose[:, r, c].sum(), q, retain_graph=True)[0] for r in range(3) for c in range(4)
    ]
    d_pose = torch.stack(rows, dim=1).reshape(20, 3, 4, robot.n_dof)  # d pose[:, r, c] / d q_j
    rotation = pose[:, :3, :3].detach()
    linear = d_pose[:, :, 3, :]
    skew = torch.einsum("brcj,bkc->brkj", d_pose[:, :, :3, :], rotation)  # dR/dq_j R^T
    angular = torch.stack((skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]), dim=1)
    torch.testing.assert_close(
        torch.cat((linear, angular), dim=1), robot.jacobian(q.detach()), atol=1e-12, rtol=0
    )


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_gradcheck_fk(robots, name):
    robot = robots[name]
    q = robot.sample_q(3, torch.Generator().manual_seed(3)).requires_grad_(True)
    assert torch.autograd.gradcheck(lambda x: robot.fk(x, all_links=True), (q,))


def test_kinematics_equals_fk_and_jacobian(robots):
    robot = robots["pr2_right_arm"]
    q = robot.sample_q(30, torch.Generator().manual_seed(4))
    pose, jac = robot.kinematics(q)
    torch.testing.assert_close(pose, robot.fk(q), atol=0, rtol=0)
    torch.testing.assert_close(jac, robot.jacobian(q), atol=0, rtol=0)


@pytest.mark.parametrize("device", DEVICES)
@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_dtype_and_device_follow_input(robots, device, dtype):
    robot = robots["sawyer"]
    q64 = robot.sample_q(64, torch.Generator().manual_seed(5))
    q = q64.to(device=device, dtype=dtype)
    outputs = [robot.fk(q), robot.fk(q, all_links=True), robot.jacobian(q), robot.inverse_dynamics(q, q, q)]
    outputs.append(robot.clamp(q))
    for out in outputs:
        assert out.dtype == dtype and out.device.type == device
    tol = 1e-5 if dtype == torch.float32 else 1e-12
    torch.testing.assert_close(outputs[0].cpu().double(), robot.fk(q64), atol=tol, rtol=0)
    assert robot.within_limits(q).device.type == device


def test_numpy_and_integer_inputs_become_float64(robots):
    robot = robots["wam4"]
    q = np.zeros((2, 4))
    assert robot.fk(q).dtype == torch.float64
    assert robot.fk(np.zeros((2, 4), dtype=np.int64)).dtype == torch.float64
    assert robot.fk([[0, 0, 0, 0]]).dtype == torch.float64
    assert robot.fk(q.astype(np.float32)).dtype == torch.float32


def test_batch_rows_are_independent(robots):
    robot = robots["human_arm"]
    q = robot.sample_q(10, torch.Generator().manual_seed(6))
    together = robot.fk(q, all_links=True)
    for i in range(10):
        torch.testing.assert_close(robot.fk(q[i : i + 1], all_links=True)[0], together[i], atol=1e-15, rtol=0)


def test_empty_batch(robots):
    robot = robots["pr2_right_arm"]
    empty = np.zeros((0, 7))
    assert robot.fk(empty).shape == (0, 4, 4) and robot.fk(empty, all_links=True).shape == (0, 8, 4, 4)
    assert robot.jacobian(empty).shape == (0, 6, 7)
    assert robot.inverse_dynamics(empty, empty, empty).shape == (0, 7)
    result = robot.ik(np.zeros((0, 4, 4)))
    assert result.q.shape == (0, 7) and result.success.shape == (0,)


@pytest.mark.parametrize(
    ("q", "message"),
    [
        (np.zeros((3, 6)), r"shape \(B, 7\) for robot 'sawyer'"),
        (np.zeros(7), r"shape \(B, 7\)"),
        (np.zeros((1, 2, 7)), r"shape \(B, 7\)"),
        (np.array([[0, 0, np.nan, 0, 0, 0, 0]]), "NaN or inf"),
        (np.array([[0, 0, np.inf, 0, 0, 0, 0]]), "NaN or inf"),
    ],
)
def test_bad_q_raises(robots, q, message):
    robot = robots["sawyer"]
    for method in (robot.fk, robot.jacobian, robot.within_limits, robot.clamp, robot.kinematics):
        with pytest.raises(ValueError, match=message):
            method(q)
    with pytest.raises(ValueError, match=message):
        robot.inverse_dynamics(q, q, q)


def test_limits_clamp_and_continuous_wrap():
    robot = load_robot("pr2_right_arm")
    q = torch.tensor([[-5.0, 2.0, 1.0, 0.5, 4.0, 0.3, -7.0], robot.home.tolist()], dtype=torch.float64)
    assert robot.within_limits(q).tolist() == [False, True]
    clamped = robot.clamp(q)
    assert bool(robot.within_limits(clamped).all())
    np.testing.assert_allclose(clamped[0, [0, 1, 2, 3, 5]], [-2.2854, 1.3963, 0.8, 0.0, 0.0])
    np.testing.assert_allclose(clamped[0, [4, 6]], [4.0 - 2 * np.pi, -7.0 + 2 * np.pi])
    assert bool(((clamped >= robot.lower) & (clamped <= robot.upper)).all())
    torch.testing.assert_close(clamped[1], q[1])
    unwrapped = torch.tensor([[0, 0, 0, 0, 4.0, 0, -7.0]], dtype=torch.float64)
    torch.testing.assert_close(robot.fk(robot.clamp(unwrapped)), robot.fk(unwrapped))


def test_sample_q_is_reproducible_and_within_limits(robots):
    robot = robots["pr2_right_arm"]
    a = robot.sample_q(500, torch.Generator().manual_seed(7))
    b = robot.sample_q(500, torch.Generator().manual_seed(7))
    torch.testing.assert_close(a, b, atol=0, rtol=0)
    assert bool(((a >= robot.lower) & (a <= robot.upper)).all())


def test_large_batches_match_row_by_row(robots):
    robot = robots["pr2_right_arm"]  # above the CPU block size: computed block by block
    q = robot.sample_q(17_000, torch.Generator().manual_seed(8))
    rows = torch.tensor([0, 5, 16_383, 16_384, 16_999])
    pose, jac = robot.kinematics(q)
    torch.testing.assert_close(pose[rows], robot.fk(q[rows]), atol=1e-14, rtol=0)
    torch.testing.assert_close(jac[rows], robot.jacobian(q[rows]), atol=1e-14, rtol=0)
    torch.testing.assert_close(
        robot.fk(q, all_links=True)[rows], robot.fk(q[rows], all_links=True), atol=1e-14, rtol=0
    )
    torch.testing.assert_close(robot.jacobian(q)[rows], jac[rows], atol=0, rtol=0)
    tau = robot.inverse_dynamics(q, q, q)
    torch.testing.assert_close(
        tau[rows], robot.inverse_dynamics(q[rows], q[rows], q[rows]), atol=1e-10, rtol=0
    )
    q.requires_grad_(True)
    robot.fk(q)[:, :3, 3].sum().backward()
    torch.testing.assert_close(
        q.grad[rows], robot.jacobian(q[rows].detach())[:, :3].sum(1), atol=1e-12, rtol=0
    )


@pytest.mark.parametrize("dtype", [torch.float16, torch.bfloat16])
@pytest.mark.parametrize("grad", [False, True])
def test_fk_leaves_autocast_and_half_precision(robots, dtype, grad):
    """Inside mixed-precision autocast (a policy's loss), FK runs in float32: the same poses as
    outside it, not half-precision matrix products (~3 digits: millimetres at the tool)."""
    robot = robots["sawyer"]
    q = robot.sample_q(64, torch.Generator().manual_seed(3)).float().requires_grad_(grad)
    expected = robot.fk(q)
    with torch.autocast("cpu", dtype=dtype):
        actual = robot.fk(q)
        from_half = robot.fk(q.detach().to(dtype))
    assert actual.dtype == from_half.dtype == torch.float32
    torch.testing.assert_close(actual, expected, rtol=0, atol=1e-6)
    torch.testing.assert_close(from_half, robot.fk(q.detach().to(dtype).float()), rtol=0, atol=1e-6)
