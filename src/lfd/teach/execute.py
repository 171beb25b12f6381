"""Run a joint trajectory on the simulated arm in PyBullet under position control.

The arm is the generated URDF in its own ``p.DIRECT`` client (gravity on, fixed base,
``URDF_USE_INERTIA_FROM_FILE``). Each commanded sample is clipped into the URDF
position limits and sent with ``POSITION_CONTROL``, the joint's URDF effort limit as
the maximum force and its velocity limit as the maximum velocity; the physics runs at
240 Hz, several steps per sample. After the last sample the target is held for
``settle`` seconds.

Example::

    >>> import numpy as np
    >>> from lfd.robots import load_robot
    >>> from lfd.teach.execute import execute_joint_trajectory
    >>> robot = load_robot("wam4")
    >>> t = np.linspace(0.0, 2.0, 50)
    >>> q = robot.home.numpy() + np.outer(t / 2.0, [0.3, 0.2, 0.0, -0.2])
    >>> run = execute_joint_trajectory(robot, t, q)
    >>> run.q.shape, bool(np.abs(run.q[-1] - q[-1]).max() < 0.01)
    ((50, 4), True)
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass

import numpy as np
import pybullet as p

from lfd.robots import Robot

__all__ = ["ExecutedPath", "execute_joint_trajectory"]

_PHYSICS_HZ = 240.0


@dataclass(frozen=True)
class ExecutedPath:
    """What the simulated arm did: ``t`` (T,) s, measured ``q`` (T, n) rad and ``tool``
    (T, 3) m at the commanded sample times, and ``q_final``/``tool_final`` after settling."""

    t: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    q_final: np.ndarray
    tool_final: np.ndarray
    clipped_samples: int


def execute_joint_trajectory(robot: Robot, t, q, settle: float = 0.5, gravity: float = -9.81) -> ExecutedPath:
    """Execute ``q`` (T, n) rad at times ``t`` (T,) s; see the module docstring.

    Raises:
        ValueError: wrong shapes, NaN, times not increasing.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    n = robot.n_dof
    if t.ndim != 1 or q.shape != (t.shape[0], n) or t.shape[0] < 2:
        raise ValueError(
            f"execute_joint_trajectory needs t (T,) and q (T, {n}) with T >= 2, got {t.shape} and {q.shape}"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))) or np.any(np.diff(t) <= 0):
        raise ValueError("execute_joint_trajectory needs finite q and strictly increasing finite t")
    spec = robot.spec
    lower, upper = np.asarray(spec.lower), np.asarray(spec.upper)
    limited = ~np.asarray(spec.continuous)
    client = p.connect(p.DIRECT)
    try:
        fd, path = tempfile.mkstemp(suffix=".urdf", prefix=f"lfd_teach_exec_{robot.name}_")
        os.close(fd)
        try:
            robot.to_urdf(path)
            body = p.loadURDF(
                path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client
            )
        finally:
            os.unlink(path)
        p.setGravity(0, 0, gravity, physicsClientId=client)
        p.setTimeStep(1.0 / _PHYSICS_HZ, physicsClientId=client)
        for j in range(n):
            p.resetJointState(body, j, float(q[0, j]), physicsClientId=client)
        clipped = 0

        def command(target: np.ndarray) -> None:
            for j in range(n):
                p.setJointMotorControl2(
                    body,
                    j,
                    p.POSITION_CONTROL,
                    targetPosition=float(target[j]),
                    force=float(spec.effort_limits[j]),
                    maxVelocity=float(spec.velocity_limits[j]),
                    physicsClientId=client,
                )

        def measure() -> tuple[np.ndarray, np.ndarray]:
            states = p.getJointStates(body, list(range(n)), physicsClientId=client)
            tool = p.getLinkState(body, n, computeForwardKinematics=True, physicsClientId=client)[4]
            return np.array([s[0] for s in states]), np.array(tool)

        qs, tools = [], []
        elapsed = t[0]
        for k in range(t.shape[0]):
            target = q[k].copy()
            outside = limited & ((target < lower) | (target > upper))
            clipped += bool(outside.any())
            target = np.where(limited, np.clip(target, lower, upper), target)
            command(target)
            if k > 0:
                steps = max(1, int(round((t[k] - elapsed) * _PHYSICS_HZ)))
                elapsed += steps / _PHYSICS_HZ
                for _ in range(steps):
                    p.stepSimulation(physicsClientId=client)
            qm, tm = measure()
            qs.append(qm)
            tools.append(tm)
        for _ in range(int(round(settle * _PHYSICS_HZ))):
            p.stepSimulation(physicsClientId=client)
        q_final, tool_final = measure()
    finally:
        p.disconnect(physicsClientId=client)
    return ExecutedPath(t.copy(), np.array(qs), np.array(tools), q_final, tool_final, clipped)
