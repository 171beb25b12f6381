"""The joint motors and joint state of an arm body in PyBullet, shared by every world holding an arm.

* :func:`command_joints`: position control of joints ``0..n-1`` towards a target (rad) with an
  optional velocity feed-forward (rad/s), the torque capped at each joint's force limit (N m)
  and the speed at its velocity limit;
* :class:`ArmJoints`: ``command``, ``step_physics``, ``joint_state`` and the context manager of
  a world, for :class:`lfd.sim.tracking.ArmWorld` (the arm alone) and
  :class:`lfd.sim.scene.ReachScene` (arm, table, object).
"""

from __future__ import annotations

import numpy as np

from lfd.sim._pybullet import pybullet as p

__all__ = ["ArmJoints", "command_joints"]


def command_joints(
    client: int,
    body: int,
    target: np.ndarray,
    velocity: np.ndarray | None,
    forces: np.ndarray,
    max_velocities: np.ndarray,
    position_gain: float | None = None,
    velocity_gain: float | None = None,
) -> None:
    """Position control of joints ``0..n-1`` of ``body`` towards ``target (n,)`` rad.

    ``velocity (n,)`` rad/s is the feed-forward (clipped to ``max_velocities``; None: none
    given, PyBullet's default 0); ``forces (n,)`` N m cap the motor torques; a finite
    ``max_velocities[j]`` caps joint ``j``'s speed. Gains None keep PyBullet's defaults.
    Takes effect at the next physics step.
    """
    if velocity is not None:
        velocity = np.clip(velocity, -max_velocities, max_velocities)
    for j in range(len(target)):
        kw: dict[str, float] = {}
        if velocity is not None:
            kw["targetVelocity"] = float(velocity[j])
        if np.isfinite(max_velocities[j]):
            kw["maxVelocity"] = float(max_velocities[j])
        if position_gain is not None:
            kw["positionGain"] = position_gain
        if velocity_gain is not None:
            kw["velocityGain"] = velocity_gain
        p.setJointMotorControl2(
            body,
            j,
            p.POSITION_CONTROL,
            targetPosition=float(target[j]),
            force=float(forces[j]),
            physicsClientId=client,
            **kw,
        )


class ArmJoints:
    """The joint motors and joint state of one arm body in a PyBullet client, shared by every world
    that holds an arm (:class:`lfd.sim.tracking.ArmWorld`, :class:`lfd.sim.scene.ReachScene`).

    A subclass sets ``client``, ``n_joints``, ``forces`` and ``max_velocities`` ``(n_joints,)``,
    ``position_gain`` and ``velocity_gain`` (None: PyBullet's defaults) and the attribute named by
    ``_arm_body`` that holds the arm's body id.
    """

    _arm_body = "body"

    def command(self, q: np.ndarray, qd: np.ndarray | None = None) -> None:
        """Command the joints towards ``q (n,)`` rad (feed-forward ``qd (n,)`` rad/s) within the limits
        (:func:`command_joints`)."""
        command_joints(
            self.client,
            getattr(self, self._arm_body),
            q,
            qd,
            self.forces,
            self.max_velocities,
            self.position_gain,
            self.velocity_gain,
        )

    def step_physics(self, steps: int = 1) -> None:
        """Advance the physics ``steps`` steps."""
        for _ in range(steps):
            p.stepSimulation(physicsClientId=self.client)

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions and velocities, each ``(n_joints,)`` float64."""
        body = getattr(self, self._arm_body)
        states = p.getJointStates(body, list(range(self.n_joints)), physicsClientId=self.client)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()
