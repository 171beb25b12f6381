"""Obstacle editing in a teach session (the UI's "Add box"), through the collision world's API."""

from __future__ import annotations

import math

import numpy as np

from lfd.sim.collision import CollisionWorld

from .checks import check_vector
from .scene import Box

__all__ = ["add_box"]


def add_box(world: CollisionWorld, q: np.ndarray, center, size, yaw_deg: float = 0.0) -> Box:
    """Add a box (``center`` (3,) m, full edge lengths ``size`` (3,) m, ``yaw_deg`` about z)
    to ``world``, with the arm at ``q (n,)`` rad; returns the :class:`Box`.

    Raises:
        ValueError: malformed vectors, a non-positive size, a box overlapping the robot base
            or the arm at ``q`` (then the world is left unchanged).
    """
    box = Box(check_vector(center, 3, "center"), check_vector(size, 3, "size"), math.radians(float(yaw_deg)))
    if np.any(box.size <= 0):
        raise ValueError(f"size must be positive (m), got {box.size.tolist()}")
    if world.base_overlaps(box):
        raise ValueError(f"obstacle at {box.center.tolist()} overlaps the robot base")
    world.add_obstacle(box)
    if world.check(q).in_collision:
        world.remove_obstacle(box)
        raise ValueError(f"obstacle at {box.center.tolist()} overlaps the arm in its current pose")
    return box
