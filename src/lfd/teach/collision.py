"""Collision checks of one arm configuration in PyBullet (``p.DIRECT``, own client).

The arm is the generated URDF (:meth:`lfd.robots.Robot.to_urdf`, loaded with
``URDF_USE_INERTIA_FROM_FILE``); obstacles are static boxes, the table a large static
slab whose top is at ``table_z``. A configuration is *in collision* when any of

* arm - obstacle: a robot link (the base included) within ``margin`` of a box,
* arm - table: a moving link other than the first (which turns in place on the base)
  within ``margin`` of the table top,
* self: two links that are not neighbours in the chain within ``margin`` of each other;
  pairs already touching at the robot's home pose (shapes that overlap by
  construction, e.g. spheres at coincident DH origins) are left out, as a URDF's
  "disable collisions" list would.

Distances come from ``getClosestPoints`` (negative: penetration).

Example::

    >>> from lfd.robots import load_robot
    >>> from lfd.teach.collision import CollisionChecker
    >>> from lfd.teach.scene import Box
    >>> import numpy as np
    >>> checker = CollisionChecker(load_robot("wam4"), [Box(np.array([0.4, 0, 0.6]), np.array([0.2, 0.2, 0.2]))])
    >>> checker.check(np.array([0.0, 0.0, 0.0, 1.57])).in_collision   # elbow bent towards +x
    True
    >>> checker.check(np.array([0.0, 0.0, 0.0, 0.0])).in_collision    # stretched up
    False
    >>> checker.close()
"""

from __future__ import annotations

import math
import os
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import pybullet as p

from lfd.robots import Robot

from .scene import Box

__all__ = ["CollisionChecker", "CollisionReport"]

_TABLE_HALF = (3.0, 3.0, 0.01)


@dataclass(frozen=True)
class CollisionReport:
    """What one check found: ``in_collision`` and, for messages, the first contact's
    ``kind`` (``"obstacle"``, ``"table"``, ``"self"`` or ``None``) and ``detail``."""

    in_collision: bool
    kind: str | None = None
    detail: str = ""


class CollisionChecker:
    """Arm, boxes and table in one private PyBullet DIRECT client.

    Args:
        robot: the arm.
        obstacles: boxes in the robot's world frame.
        table_z: height of the table top (m), or None for no table.
        margin: clearance (m) below which two shapes count as touching.
    """

    def __init__(
        self, robot: Robot, obstacles: Iterable[Box] = (), table_z: float | None = None, margin: float = 0.0
    ):
        self.robot = robot
        self.margin = float(margin)
        self.client = p.connect(p.DIRECT)
        fd, path = tempfile.mkstemp(suffix=".urdf", prefix=f"lfd_teach_{robot.name}_")
        os.close(fd)
        try:
            robot.to_urdf(path)
            self.body = p.loadURDF(
                path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=self.client
            )
        finally:
            os.unlink(path)
        self.n = robot.n_dof
        self.obstacles: list[tuple[int, Box]] = []
        for box in obstacles:
            self.add_obstacle(box)
        self.table = None
        if table_z is not None:
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=_TABLE_HALF, physicsClientId=self.client)
            self.table = p.createMultiBody(
                0.0, shape, basePosition=(0.0, 0.0, table_z - _TABLE_HALF[2]), physicsClientId=self.client
            )
        self.table_z = table_z
        self._self_pairs = self._pairs_to_check()

    # ------------------------------------------------------------------ setup
    def add_obstacle(self, box: Box) -> None:
        """Add a static box obstacle."""
        half = (box.size / 2.0).tolist()
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        orientation = p.getQuaternionFromEuler((0.0, 0.0, box.yaw))
        body = p.createMultiBody(
            0.0,
            shape,
            basePosition=box.center.tolist(),
            baseOrientation=orientation,
            physicsClientId=self.client,
        )
        self.obstacles.append((body, box))

    def _pairs_to_check(self) -> list[tuple[int, int]]:
        links = list(range(-1, self.n))  # -1: base_link; the tool link has no shape
        candidates = [(a, b) for i, a in enumerate(links) for b in links[i + 2 :]]
        self.set_q(self.robot.home.numpy())
        return [(a, b) for a, b in candidates if self._link_distance(a, b) > self.margin]

    def _link_distance(self, a: int, b: int) -> float:
        pts = p.getClosestPoints(
            self.body, self.body, 0.05, linkIndexA=a, linkIndexB=b, physicsClientId=self.client
        )
        return min((pt[8] for pt in pts), default=math.inf)

    def set_q(self, q: np.ndarray) -> None:
        """Put the arm at ``q`` (n,) rad (kinematically, no physics step)."""
        for i in range(self.n):
            p.resetJointState(self.body, i, float(q[i]), physicsClientId=self.client)

    # ------------------------------------------------------------------ queries
    def base_overlaps(self, box: Box) -> bool:
        """True when ``box`` touches the base or the first link (which never leaves it)."""
        body = (
            next(b for b, bx in self.obstacles if bx is box)
            if any(bx is box for _, bx in self.obstacles)
            else None
        )
        temp = body is None
        if temp:
            self.add_obstacle(box)
            body = self.obstacles[-1][0]
        try:
            for link in (-1, 0):
                pts = p.getClosestPoints(
                    self.body, body, self.margin, linkIndexA=link, physicsClientId=self.client
                )
                if pts:
                    return True
            return False
        finally:
            if temp:
                p.removeBody(body, physicsClientId=self.client)
                self.obstacles.pop()

    def check(self, q: np.ndarray) -> CollisionReport:
        """Check configuration ``q`` (n,) rad; see the module docstring for the rules."""
        self.set_q(q)
        m, c = self.margin, self.client
        for i, (body, _) in enumerate(self.obstacles):
            pts = p.getClosestPoints(self.body, body, m, physicsClientId=c)
            if pts:
                return CollisionReport(True, "obstacle", f"link {pts[0][3]} touches obstacle {i}")
        if self.table is not None:
            for link in range(1, self.n):
                pts = p.getClosestPoints(self.body, self.table, m, linkIndexA=link, physicsClientId=c)
                if pts:
                    return CollisionReport(True, "table", f"link {link} touches the table")
        for a, b in self._self_pairs:
            pts = p.getClosestPoints(self.body, self.body, m, linkIndexA=a, linkIndexB=b, physicsClientId=c)
            if pts:
                return CollisionReport(True, "self", f"links {a} and {b} touch")
        return CollisionReport(False)

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if self.client is not None:
            try:
                p.disconnect(physicsClientId=self.client)
            except p.error:
                pass
            self.client = None

    def __del__(self):  # pragma: no cover - best effort
        try:
            self.close()
        except Exception:
            pass
