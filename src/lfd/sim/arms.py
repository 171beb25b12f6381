"""Simulated arms driven by joint-velocity commands, and trajectory replay in PyBullet.

Both arms hold ``B`` independent copies of a :class:`lfd.robots.Robot` and share one
interface (``reset(q0 (B, n)) -> q``, ``step(qd (B, n)) -> q``, ``close()``, ``dt``), so a
controller such as :func:`lfd.model_reaching.closed_loop.closed_loop_reach` runs on either:

* :class:`KinematicArm`: ``q <- clamp(q + dt qd)``, exact and fast;
* :class:`PyBulletArm`: one :class:`~lfd.sim.scene.ReachScene` per arm with the robot's
  generated URDF, position control with velocity feed-forward.

A whole joint trajectory is replayed by :func:`lfd.sim.tracking.replay_in_pybullet`.
Units: rad, rad/s, s, m.
"""

from __future__ import annotations

import numpy as np
import torch

from lfd.sim.scene import ReachScene

__all__ = ["ARMS", "KinematicArm", "PyBulletArm"]


class KinematicArm:
    """Kinematic simulation of ``B`` arms: ``q <- clamp(q + dt qd)`` (rad, rad/s, s)."""

    def __init__(self, robot, dt: float) -> None:
        self.robot, self.dt = robot, float(dt)
        self.q = torch.zeros(0, robot.n_dof, dtype=torch.float64)

    def reset(self, q0: np.ndarray) -> np.ndarray:
        """Start every arm at ``q0 (B, n)``; returns the joints ``(B, n)``."""
        self.q = self.robot.clamp(torch.as_tensor(np.asarray(q0, dtype=np.float64)))
        return self.q.numpy().copy()

    def step(self, qd: np.ndarray) -> np.ndarray:
        """Apply joint velocities ``(B, n)`` for one period; returns the new joints ``(B, n)``."""
        self.q = self.robot.clamp(self.q + self.dt * torch.as_tensor(qd, dtype=torch.float64))
        return self.q.numpy().copy()

    def close(self) -> None:
        """Nothing to release."""


class PyBulletArm:
    """``B`` PyBullet worlds with the robot's generated URDF (one :class:`ReachScene` each).

    Velocity commands are integrated into a joint reference ``q_ref <- clamp(q_ref + dt qd)``
    that the joints track by position control with ``qd`` as velocity feed-forward, for
    ``dt`` seconds (``substeps`` physics steps) per step; the measured joints are returned.
    """

    def __init__(self, robot, dt: float, substeps: int = 10) -> None:
        self.robot, self.dt, self.substeps = robot, float(dt), substeps
        self.scenes: list[ReachScene] = []
        self.reference = torch.zeros(0, robot.n_dof, dtype=torch.float64)

    def reset(self, q0: np.ndarray) -> np.ndarray:
        """Build one world per row of ``q0 (B, n)`` with the arm there; returns the joints ``(B, n)``."""
        self.close()
        self.reference = self.robot.clamp(torch.as_tensor(np.asarray(q0, dtype=np.float64)))
        self.scenes = [
            ReachScene(self.robot, image_size=8, control_dt=self.dt, substeps=self.substeps, **LEGACY_PHYSICS)
            for _ in range(len(q0))
        ]
        for scene, q in zip(self.scenes, self.reference.numpy()):
            scene.set_joints(q)
        return self.joints()

    def joints(self) -> np.ndarray:
        """Measured joints ``(B, n)`` (rad)."""
        return np.stack([scene.joint_state()[0] for scene in self.scenes])

    def step(self, qd: np.ndarray) -> np.ndarray:
        """Track joint velocities ``(B, n)`` for one period; returns the measured joints ``(B, n)``."""
        qd = np.asarray(qd, dtype=np.float64)
        self.reference = self.robot.clamp(self.reference + self.dt * torch.from_numpy(qd))
        for scene, target, v in zip(self.scenes, self.reference.numpy(), qd):
            scene.step(target, v)
        return self.joints()

    def close(self) -> None:
        """Disconnect every world."""
        for scene in self.scenes:
            scene.close()
        self.scenes = []


#: Actuation of :class:`PyBulletArm` (the Sawyer protocol, thesis ch. 5): 300 N m on every joint, no
#: velocity cap, no self-collision (see docs/decisions).
LEGACY_PHYSICS = {"max_force": 300.0, "limit_velocity": False, "self_collision": False}

#: Arm class per ``simulator`` name (``configs/eval/sawyer.yaml``).
ARMS = {"kinematic": KinematicArm, "pybullet": PyBulletArm}
