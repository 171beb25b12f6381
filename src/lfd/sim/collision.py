"""Collision world of one arm configuration, and the one self-collision rule.

**Self-collision rule** (:func:`overlapping_link_pairs`). The generated URDF's simplified
collision shapes overlap by construction for some non-adjacent link pairs (e.g. spheres at
coincident DH origins, the base with the shoulder links). A pair is left out of
self-collision when its links are in contact in at least ``share`` (25 %) of ``n_samples``
(200) configurations drawn uniformly within the joint limits (seeded, so always the same
pairs), as a URDF's "disable collisions" list would; every other non-adjacent pair
collides. The pairs are found once per URDF and cached. The reaching scenes
(:class:`lfd.sim.scene.ReachScene`) and the teach collision checks (:class:`CollisionWorld`)
both use it.

**Collision world** (:class:`CollisionWorld`). The arm (the generated URDF, loaded with
``URDF_USE_INERTIA_FROM_FILE``) in its own ``p.DIRECT`` client, with static box obstacles
and optionally a table (a large static slab whose top is at ``table_z``). A configuration is
*in collision* when any of

* arm - obstacle: a robot link (the base included) within ``margin`` of a box,
* arm - table: a moving link other than the first (which turns in place on the base)
  within ``margin`` of the table top,
* self: two links that are not neighbours in the chain, and not a pair left out by the rule
  above, within ``margin`` of each other.

Distances come from ``getClosestPoints`` (negative: penetration). A box is any object with
``center`` (3,) m, ``size`` (3,) m (full edge lengths) and ``yaw`` (rad about z), such as
:class:`lfd.teach.scene.Box`.

Example::

    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> from lfd.robots import load_robot
    >>> from lfd.sim.collision import CollisionWorld
    >>> box = SimpleNamespace(center=np.array([0.4, 0, 0.6]), size=np.array([0.2, 0.2, 0.2]), yaw=0.0)
    >>> world = CollisionWorld(load_robot("wam4"), [box])
    >>> world.check(np.array([0.0, 0.0, 0.0, 1.57])).in_collision   # elbow bent towards +x
    True
    >>> world.check(np.array([0.0, 0.0, 0.0, 0.0])).in_collision    # stretched up
    False
    >>> world.close()
"""

from __future__ import annotations

import contextlib
import math
import os
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from lfd.sim._pybullet import pybullet as p

__all__ = ["CollisionReport", "CollisionWorld", "overlapping_link_pairs"]

_TABLE_HALF = (3.0, 3.0, 0.01)

#: Per URDF text: the link pairs left out of self-collision (:func:`overlapping_link_pairs`).
_OVERLAPPING_PAIRS: dict[str, list[tuple[int, int]]] = {}


def overlapping_link_pairs(
    robot: Any, client: int, body: int, urdf: str, n_samples: int = 200, share: float = 0.25
) -> list[tuple[int, int]]:
    """Non-adjacent link pairs ``(a, b)`` (``a < b - 1``; -1 is the base, ``n`` the tool) in
    contact in at least ``share`` of ``n_samples`` seeded uniform configurations of
    ``robot`` (see the module docstring). ``body`` in ``client`` is the robot loaded from the
    URDF text ``urdf`` (the cache key); its joints are left at the last sample."""
    if urdf not in _OVERLAPPING_PAIRS:
        import torch

        n = robot.n_dof
        q = robot.sample_q(n_samples, torch.Generator().manual_seed(0)).numpy()
        links = range(-1, n + 1)
        pairs = [(a, b) for a in links for b in links if b > a + 1]
        counts = dict.fromkeys(pairs, 0)
        for sample in q:
            for j in range(n):
                p.resetJointState(body, j, float(sample[j]), 0.0, physicsClientId=client)
            for a, b in pairs:
                counts[(a, b)] += bool(
                    p.getClosestPoints(body, body, 0.0, linkIndexA=a, linkIndexB=b, physicsClientId=client)
                )
        _OVERLAPPING_PAIRS[urdf] = [pair for pair, k in counts.items() if k >= share * n_samples]
    return list(_OVERLAPPING_PAIRS[urdf])


@dataclass(frozen=True)
class CollisionReport:
    """What one check found: ``in_collision`` and, for messages, the first contact's
    ``kind`` (``"obstacle"``, ``"table"``, ``"self"`` or ``None``) and ``detail``."""

    in_collision: bool
    kind: str | None = None
    detail: str = ""


class CollisionWorld:
    """Arm, boxes and table in one private PyBullet DIRECT client (see the module docstring).

    Args:
        robot: the arm (:class:`lfd.robots.Robot`).
        obstacles: boxes in the robot's world frame.
        table_z: height of the table top (m), or None for no table.
        margin: clearance (m) below which two shapes count as touching.
    """

    def __init__(
        self, robot: Any, obstacles: Iterable[Any] = (), table_z: float | None = None, margin: float = 0.0
    ) -> None:
        self.robot = robot
        self.margin = float(margin)
        self.client = p.connect(p.DIRECT)
        urdf = robot.to_urdf()
        fd, path = tempfile.mkstemp(suffix=".urdf", prefix=f"lfd_collision_{robot.name}_")
        os.close(fd)
        try:
            with open(path, "w") as f:
                f.write(urdf)
            self.body = p.loadURDF(
                path, useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=self.client
            )
        finally:
            os.unlink(path)
        self.n = robot.n_dof
        self.obstacles: list[tuple[int, Any]] = []
        for box in obstacles:
            self.add_obstacle(box)
        self.table = None
        if table_z is not None:
            shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=_TABLE_HALF, physicsClientId=self.client)
            self.table = p.createMultiBody(
                0.0, shape, basePosition=(0.0, 0.0, table_z - _TABLE_HALF[2]), physicsClientId=self.client
            )
        self.table_z = table_z
        excluded = set(overlapping_link_pairs(robot, self.client, self.body, urdf))
        links = list(range(-1, self.n))  # -1: base_link; the tool link has no shape
        candidates = [(a, b) for i, a in enumerate(links) for b in links[i + 2 :]]
        self.self_pairs = [pair for pair in candidates if pair not in excluded]
        self.set_q(robot.home.numpy())

    # ------------------------------------------------------------------ obstacles
    def add_obstacle(self, box: Any) -> None:
        """Add a static box obstacle."""
        half = (np.asarray(box.size) / 2.0).tolist()
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=self.client)
        orientation = p.getQuaternionFromEuler((0.0, 0.0, box.yaw))
        body = p.createMultiBody(
            0.0,
            shape,
            basePosition=np.asarray(box.center).tolist(),
            baseOrientation=orientation,
            physicsClientId=self.client,
        )
        self.obstacles.append((body, box))

    def remove_obstacle(self, box: Any) -> None:
        """Remove the obstacle ``box`` (the object given to :meth:`add_obstacle`).

        Raises:
            ValueError: ``box`` is not an obstacle of this world.
        """
        for i, (body, known) in enumerate(self.obstacles):
            if known is box:
                p.removeBody(body, physicsClientId=self.client)
                del self.obstacles[i]
                return
        raise ValueError("CollisionWorld.remove_obstacle: not an obstacle of this world")

    def set_q(self, q: np.ndarray) -> None:
        """Put the arm at ``q`` (n,) rad (kinematically, no physics step)."""
        for i in range(self.n):
            p.resetJointState(self.body, i, float(q[i]), physicsClientId=self.client)

    # ------------------------------------------------------------------ queries
    def base_overlaps(self, box: Any) -> bool:
        """True when ``box`` touches the base or the first link (which never leaves it)."""
        known = any(bx is box for _, bx in self.obstacles)
        if not known:
            self.add_obstacle(box)
        body = next(b for b, bx in self.obstacles if bx is box)
        try:
            for link in (-1, 0):
                pts = p.getClosestPoints(
                    self.body, body, self.margin, linkIndexA=link, physicsClientId=self.client
                )
                if pts:
                    return True
            return False
        finally:
            if not known:
                self.remove_obstacle(box)

    def link_distance(self, a: int, b: int, reach: float = 0.05) -> float:
        """Closest distance (m) between links ``a`` and ``b`` of the arm as it stands, or inf
        beyond ``reach`` m."""
        pts = p.getClosestPoints(
            self.body, self.body, reach, linkIndexA=a, linkIndexB=b, physicsClientId=self.client
        )
        return min((pt[8] for pt in pts), default=math.inf)

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
        for a, b in self.self_pairs:
            pts = p.getClosestPoints(self.body, self.body, m, linkIndexA=a, linkIndexB=b, physicsClientId=c)
            if pts:
                return CollisionReport(True, "self", f"links {a} and {b} touch")
        return CollisionReport(False)

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if self.client is not None:
            with contextlib.suppress(p.error):
                p.disconnect(physicsClientId=self.client)
            self.client = None

    def __del__(self):  # pragma: no cover - best effort
        with contextlib.suppress(Exception):
            self.close()
