"""Checks of a teach session: argument vectors, joint limits, swept collisions, the scene.

* :func:`check_vector` (from :mod:`lfd.checks`): a user-given vector (position, joint angles) as finite floats.
* :func:`check_joint_limits`: the sliders' configuration within the joint limits.
* :func:`sweep`: a move is collision-checked along its straight joint-space segment, not
  only at its end, so one update cannot jump through a thin obstacle.
* :func:`validate_scene`: the start pose within the limits and collision-free, no obstacle
  overlapping the robot base, the goal reachable.

Every failure raises ``ValueError`` naming the offending field or joint.
"""

from __future__ import annotations

import math

import numpy as np

from lfd.checks import check_vector
from lfd.robots import Robot
from lfd.sim.collision import CollisionReport, CollisionWorld

from .scene import TeachScene

__all__ = ["check_joint_limits", "check_vector", "sweep", "validate_scene"]


def check_joint_limits(robot: Robot, q: np.ndarray) -> None:
    """Raise ``ValueError`` naming the first non-continuous joint of ``q (n,)`` rad outside
    its limits (1e-9 rad tolerance)."""
    spec = robot.spec
    for j in range(robot.n_dof):
        if not spec.continuous[j] and not spec.lower[j] - 1e-9 <= q[j] <= spec.upper[j] + 1e-9:
            raise ValueError(
                f"joint {j} ({spec.joint_names[j]}) = {q[j]:.4f} rad is outside "
                f"[{spec.lower[j]:.4f}, {spec.upper[j]:.4f}]"
            )


def sweep(world: CollisionWorld, q_from: np.ndarray, q_to: np.ndarray, resolution: float) -> CollisionReport:
    """Collision report of the straight joint-space motion ``q_from -> q_to`` (n,) rad,
    checked every ``resolution`` rad of the largest joint change (end included, checked
    first: most refusals are there); the first collision found, else the end's report."""
    steps = max(1, int(math.ceil(float(np.max(np.abs(q_to - q_from))) / resolution)))
    for s in np.linspace(0.0, 1.0, steps + 1)[1:][::-1]:
        report = world.check(q_from + s * (q_to - q_from))
        if report.in_collision:
            return report
    return report


def validate_scene(
    robot: Robot, robot_name: str, scene: TeachScene, start: np.ndarray, world: CollisionWorld
) -> None:
    """Check ``scene`` and the ``start (n,)`` pose against ``robot`` in ``world``.

    Raises:
        ValueError: start outside the limits or in collision, an obstacle overlapping the
            robot base, a goal no configuration within the limits reaches (IK, 64 restarts).
    """
    spec = robot.spec
    bad = np.where(~spec.continuous & ((start < spec.lower - 1e-9) | (start > spec.upper + 1e-9)))[0]
    if bad.size:
        j = int(bad[0])
        raise ValueError(
            f"scene field 'start': joint {j} = {start[j]:.3f} rad is outside "
            f"[{spec.lower[j]:.3f}, {spec.upper[j]:.3f}]"
        )
    for i, box in enumerate(scene.obstacles):
        if world.base_overlaps(box):
            raise ValueError(
                f"scene field 'obstacles[{i}]' overlaps the robot base (centre {box.center.tolist()})"
            )
    report = world.check(start)
    if report.in_collision:
        raise ValueError(
            f"scene field 'start': the start pose is in collision ({report.kind}: {report.detail})"
        )
    goal = scene.goal
    if goal is not None:
        res = robot.ik(goal.center[None], restarts=64, tol_pos=1e-3)
        if float(res.pos_error[0]) > goal.radius:
            raise ValueError(
                f"scene field 'goal': unreachable for {robot_name}: no configuration within the joint limits "
                f"puts the tool within {goal.radius} m of {goal.center.tolist()} "
                f"(closest {float(res.pos_error[0]):.3f} m)"
            )
