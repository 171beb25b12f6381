"""Generated URDF: loads in PyBullet and Pinocchio with the documented link/joint contract."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pybullet as p
import pytest

from lfd.robots import available_robots, load_robot

ROBOT_NAMES = available_robots()


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_urdf_pybullet_contract(robots, bullet, name):
    robot = robots[name]
    spec = robot.spec
    body = bullet(robot)
    n = robot.n_dof
    assert p.getNumJoints(body.body, physicsClientId=body.client) == n + 1
    assert p.getBodyInfo(body.body, physicsClientId=body.client)[0].decode() == "base_link"
    for j in range(n + 1):
        info = p.getJointInfo(body.body, j, physicsClientId=body.client)
        joint_name, joint_type, link_name = info[1].decode(), info[2], info[12].decode()
        lower, upper, effort, velocity = info[8:12]
        if j == n:
            assert (joint_name, joint_type, link_name) == ("tool_joint", p.JOINT_FIXED, "tool_link")
            continue
        assert (joint_name, joint_type, link_name) == (
            robot.joint_names[j],
            p.JOINT_REVOLUTE,
            spec.link_names[j],
        )
        if spec.continuous[j]:
            assert lower > upper  # PyBullet's marker for an unlimited (continuous) joint
        else:
            assert (lower, upper) == (spec.lower[j], spec.upper[j])
        assert (effort, velocity) == (spec.effort_limits[j], spec.velocity_limits[j])
        mass = p.getDynamicsInfo(body.body, j, physicsClientId=body.client)[0]
        assert mass == pytest.approx(spec.link_masses[j], rel=1e-12)
    assert p.getDynamicsInfo(body.body, n, physicsClientId=body.client)[0] == 0.0


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_urdf_pinocchio_model(robots, name):
    robot = robots[name]
    spec = robot.spec
    model = pin.buildModelFromXML(robot.to_urdf())
    assert model.nv == robot.n_dof
    assert list(model.names)[1:] == list(robot.joint_names)
    assert model.existFrame("tool_link") and model.existFrame("base_link")
    for j, joint in enumerate(list(model.joints)[1:]):
        assert joint.nq == (2 if spec.continuous[j] else 1)
        assert model.inertias[j + 1].mass == pytest.approx(spec.link_masses[j], rel=1e-12)
        if not spec.continuous[j]:
            assert model.lowerPositionLimit[joint.idx_q] == pytest.approx(spec.lower[j], abs=1e-15)
            assert model.upperPositionLimit[joint.idx_q] == pytest.approx(spec.upper[j], abs=1e-15)
        np.testing.assert_allclose(model.inertias[j + 1].lever, spec.link_coms[j], atol=1e-12)
        np.testing.assert_allclose(model.inertias[j + 1].inertia, spec.link_inertias[j], atol=1e-12)


def test_to_urdf_writes_atomically(tmp_path):
    robot = load_robot("sawyer")
    path = tmp_path / "nested" / "sawyer.urdf"
    text = robot.to_urdf(path)
    assert path.read_text() == text and text.startswith("<?xml")
    path.write_text("stale")
    robot.to_urdf(path)
    assert path.read_text() == text
    assert sorted(f.name for f in path.parent.iterdir()) == ["sawyer.urdf"]


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_urdf_simulates_stably(robots, bullet, name):
    robot = robots[name]
    body = bullet(robot)
    p.setGravity(0, 0, -9.81, physicsClientId=body.client)
    body.set_q(robot.home.numpy())
    p.setJointMotorControlArray(
        body.body,
        list(range(robot.n_dof)),
        p.POSITION_CONTROL,
        targetPositions=robot.home.tolist(),
        forces=robot.effort_limits.tolist(),
        physicsClientId=body.client,
    )
    for _ in range(240):
        p.stepSimulation(physicsClientId=body.client)
    states = p.getJointStates(body.body, list(range(robot.n_dof)), physicsClientId=body.client)
    q = np.array([s[0] for s in states])
    assert np.all(np.isfinite(q))
    assert np.abs(q - robot.home.numpy()).max() < 0.1
