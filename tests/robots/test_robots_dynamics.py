"""Recursive Newton-Euler against Pinocchio and PyBullet built from the generated URDF."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pybullet as p
import pytest
import torch

from lfd.robots import available_robots

ROBOT_NAMES = available_robots()
GRAVITIES = [(0.0, 0.0, -9.81), (1.0, -2.0, -9.0)]


def random_state(robot, batch: int, seed: int):
    """Positions within the limits, velocities up to 2 rad/s, accelerations up to 5 rad/s^2."""
    gen = torch.Generator().manual_seed(seed)
    q = robot.sample_q(batch, gen)
    qd = 4.0 * torch.rand(batch, robot.n_dof, generator=gen, dtype=torch.float64) - 2.0
    qdd = 10.0 * torch.rand(batch, robot.n_dof, generator=gen, dtype=torch.float64) - 5.0
    return q, qd, qdd


@pytest.mark.parametrize("gravity", GRAVITIES)
@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_rne_matches_pinocchio(robots, pin_configuration, name, gravity):
    robot = robots[name]
    model = pin.buildModelFromXML(robot.to_urdf())
    model.gravity.linear = np.array(gravity)
    data = model.createData()
    assert model.nv == robot.n_dof
    q, qd, qdd = random_state(robot, 100, seed=0)
    ours = robot.inverse_dynamics(q, qd, qdd, gravity=gravity).numpy()
    states = zip(q.numpy(), qd.numpy(), qdd.numpy())
    theirs = np.array([pin.rnea(model, data, pin_configuration(model, a), b, c) for a, b, c in states])
    assert np.abs(theirs).max() > 1.0  # non-trivial torques
    np.testing.assert_allclose(ours, theirs, atol=1e-8, rtol=0)


@pytest.mark.parametrize("gravity", GRAVITIES)
@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_rne_matches_pybullet(robots, bullet, name, gravity):
    robot = robots[name]
    body = bullet(robot)
    p.setGravity(*gravity, physicsClientId=body.client)
    q, qd, qdd = random_state(robot, 100, seed=1)
    ours = robot.inverse_dynamics(q, qd, qdd, gravity=gravity).numpy()
    theirs = np.array(
        [
            p.calculateInverseDynamics(
                body.body, a.tolist(), b.tolist(), c.tolist(), physicsClientId=body.client
            )
            for a, b, c in zip(q.numpy(), qd.numpy(), qdd.numpy())
        ]
    )
    np.testing.assert_allclose(ours, theirs, atol=1e-6, rtol=0)


def test_rne_static_without_gravity_is_zero(robots):
    robot = robots["sawyer"]
    q = robot.sample_q(10, torch.Generator().manual_seed(2))
    zero = torch.zeros_like(q)
    torch.testing.assert_close(
        robot.inverse_dynamics(q, zero, zero, gravity=(0, 0, 0)), zero, atol=1e-14, rtol=0
    )


def test_rne_float32_close_to_float64(robots):
    robot = robots["pr2_right_arm"]
    q, qd, qdd = random_state(robot, 50, seed=3)
    tau64 = robot.inverse_dynamics(q, qd, qdd)
    tau32 = robot.inverse_dynamics(q.float(), qd, qdd)
    assert tau32.dtype == torch.float32
    torch.testing.assert_close(tau32.double(), tau64, atol=1e-3, rtol=1e-5)


@pytest.mark.parametrize("name", ["wam4", "human_arm"])
def test_gradcheck_rne(robots, name):
    robot = robots[name]
    state = tuple(x.requires_grad_(True) for x in random_state(robot, 3, seed=4))
    assert torch.autograd.gradcheck(robot.inverse_dynamics, state)


def test_rne_bad_inputs(robots):
    robot = robots["wam4"]
    q = np.zeros((2, 4))
    with pytest.raises(ValueError, match=r"qd must have shape \(B, 4\)"):
        robot.inverse_dynamics(q, np.zeros((2, 3)), q)
    with pytest.raises(ValueError, match="qdd contains NaN"):
        robot.inverse_dynamics(q, q, np.full((2, 4), np.nan))
    with pytest.raises(ValueError, match="same shape"):
        robot.inverse_dynamics(q, np.zeros((3, 4)), q)
    with pytest.raises(ValueError, match="gravity"):
        robot.inverse_dynamics(q, q, q, gravity=(0.0, -9.81))
