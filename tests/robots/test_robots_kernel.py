"""The sparse FK kernel (lfd.robots.kernel) behind Robot.fk: every path against Pinocchio and NumPy.

The kernel compiles the constant joint transforms into non-zero terms, so arms whose joint
origins are signed permutations (the catalogue's) and arms with arbitrary rotations and
off-axis joint axes take different code paths; both are checked, with the block splitting.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest
import torch

from lfd.robots import ChainKinematics, Robot, available_robots, kernel, load_robot, make_transform


def _random_arm() -> Robot:
    """The Sawyer's dynamics with random joint origins, axes, base and tool (dense rotations)."""
    rng = np.random.default_rng(7)
    spec = load_robot("sawyer").spec
    n = spec.n_dof
    return Robot(
        dataclasses.replace(
            spec,
            name="random_arm",
            joint_xyz=rng.uniform(-0.2, 0.3, (n, 3)),
            joint_rpy=rng.uniform(-np.pi, np.pi, (n, 3)),
            joint_axis=rng.normal(size=(n, 3)),
            base_transform=make_transform(rng.uniform(-1, 1, 3), rng.uniform(-np.pi, np.pi, 3)),
            tool_transform=make_transform(rng.uniform(-0.1, 0.1, 3), rng.uniform(-np.pi, np.pi, 3)),
        )
    )


@pytest.mark.parametrize("name", [*available_robots(), "random", "no_tool"])
def test_tool_pose_equals_pinocchio_on_every_path(name, monkeypatch, pin_configuration):
    if name == "no_tool":  # identity tool: the last joint writes its columns and position in place
        robot = Robot(dataclasses.replace(load_robot("sawyer").spec, tool_transform=np.eye(4)))
    else:
        robot = _random_arm() if name == "random" else load_robot(name)
    model = pin.buildModelFromXML(robot.to_urdf())
    data = model.createData()
    frame = model.getFrameId("tool_link")
    q = robot.sample_q(301, torch.Generator().manual_seed(5))
    expected = []
    for row in q.numpy():
        pin.forwardKinematics(model, data, pin_configuration(model, row))
        expected.append(pin.updateFramePlacement(model, data, frame).homogeneous)
    monkeypatch.setattr(kernel, "BLOCK_ROWS", 128)  # three blocks, the last one short
    fast = robot.fk(q)  # no autograd: written straight into the output
    differentiable = robot.fk(q.clone().requires_grad_(True))
    np.testing.assert_allclose(fast.numpy(), np.array(expected), atol=1e-12)
    np.testing.assert_allclose(differentiable.detach().numpy(), fast.numpy(), atol=1e-14)
    assert fast.is_contiguous() and fast.shape == (301, 4, 4)


def test_dense_arm_agrees_with_chain_kinematics_and_has_gradients():
    robot = _random_arm()
    kin = ChainKinematics(robot.spec)
    q = robot.sample_q(5, torch.Generator().manual_seed(1)).requires_grad_(True)
    links = robot.fk(q, all_links=True)
    for k in range(5):
        np.testing.assert_allclose(kin.frames(q[k].detach().numpy()), links[k].detach().numpy(), atol=1e-12)
    # d(tool position)/dq from autograd equals the geometric Jacobian's linear rows
    position = robot.fk(q)[:, :3, 3]
    grads = torch.stack(
        [torch.autograd.grad(position[:, i].sum(), q, retain_graph=True)[0] for i in range(3)], 1
    )
    np.testing.assert_allclose(grads.numpy(), robot.jacobian(q.detach())[:, :3].numpy(), atol=1e-12)


def test_float32_and_nan_input():
    robot = load_robot("sawyer")
    q = robot.sample_q(10, torch.Generator().manual_seed(2))
    assert robot.fk(q.float()).dtype == torch.float32
    np.testing.assert_allclose(robot.fk(q.float()).numpy(), robot.fk(q).numpy(), atol=1e-5)
    bad = q.clone()
    bad[3, 2] = float("nan")
    with pytest.raises(ValueError, match="q contains NaN or inf"):
        robot.fk(bad)
    huge = torch.full((2, 7), 1e308, dtype=torch.float64)  # finite, but the sum overflows
    assert robot.fk(huge).shape == (2, 4, 4)


def test_snapping_keeps_exact_structure():
    terms = kernel._terms(np.array([6.123e-17, -1.0 + 1e-16, 0.3]))
    assert terms == ((1, -1.0), (2, 0.3))
