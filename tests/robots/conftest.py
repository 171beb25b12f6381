"""Fixtures for the robot-model tests: catalogue robots, PyBullet bodies, Pinocchio models."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from lfd.robots import Robot, available_robots, load_robot


@pytest.fixture(scope="session")
def robots() -> dict[str, Robot]:
    return {name: load_robot(name) for name in available_robots()}


class BulletBody:
    """A robot's generated URDF loaded (fixed base) into its own PyBullet DIRECT client."""

    def __init__(self, robot: Robot, path) -> None:
        self.robot = robot
        robot.to_urdf(path)
        self.client = p.connect(p.DIRECT)
        self.body = p.loadURDF(
            str(path), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=self.client
        )
        for link in range(-1, p.getNumJoints(self.body, physicsClientId=self.client)):
            p.changeDynamics(
                self.body,
                link,
                linearDamping=0.0,
                angularDamping=0.0,
                jointDamping=0.0,
                physicsClientId=self.client,
            )

    def set_q(self, q) -> None:
        for j, angle in enumerate(np.asarray(q, dtype=float)):
            p.resetJointState(self.body, j, float(angle), physicsClientId=self.client)

    def link_frames(self) -> np.ndarray:
        """(n + 1, 4, 4) world link frames of links 0..n (URDF link frames, not inertial frames)."""
        frames = np.tile(np.eye(4), (self.robot.n_dof + 1, 1, 1))
        for link in range(self.robot.n_dof + 1):
            state = p.getLinkState(
                self.body, link, computeForwardKinematics=True, physicsClientId=self.client
            )
            quat = np.asarray(state[5]) / np.linalg.norm(state[5])
            frames[link, :3, :3] = np.reshape(p.getMatrixFromQuaternion(quat.tolist()), (3, 3))
            frames[link, :3, 3] = state[4]
        return frames

    def close(self) -> None:
        p.disconnect(physicsClientId=self.client)


@pytest.fixture
def bullet(tmp_path):
    """Factory: ``bullet(robot) -> BulletBody``; clients are disconnected at teardown."""
    bodies = []

    def make(robot: Robot) -> BulletBody:
        bodies.append(BulletBody(robot, tmp_path / f"{robot.name}.urdf"))
        return bodies[-1]

    yield make
    for body in bodies:
        body.close()


def _pin_configuration(model, q: np.ndarray) -> np.ndarray:
    config = np.zeros(model.nq)
    for joint in list(model.joints)[1:]:
        angle = q[joint.idx_v]
        if joint.nq == 2:
            config[joint.idx_q : joint.idx_q + 2] = [np.cos(angle), np.sin(angle)]
        else:
            config[joint.idx_q] = angle
    return config


@pytest.fixture(scope="session")
def pin_configuration():
    """``pin_configuration(model, q (n,))``: Pinocchio configuration, continuous joints as (cos, sin)."""
    return _pin_configuration
