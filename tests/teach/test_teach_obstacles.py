"""lfd.teach.obstacles (adding a box through the collision world) and lfd.teach.latency."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim.collision import CollisionWorld
from lfd.teach.latency import latency_summary
from lfd.teach.obstacles import add_box


def test_add_box_refuses_overlaps_and_leaves_the_world_unchanged():
    robot = load_robot("wam4")
    world = CollisionWorld(robot)
    bent = np.array([0.0, 0.0, 0.0, 1.57])
    with pytest.raises(ValueError, match="overlaps the arm"):
        add_box(world, bent, [0.4, 0.0, 0.6], [0.2, 0.2, 0.2])
    assert not world.obstacles
    with pytest.raises(ValueError, match="overlaps the robot base"):
        add_box(world, bent, [0.0, 0.0, 0.05], [0.2, 0.2, 0.1])
    with pytest.raises(ValueError, match="size must be positive"):
        add_box(world, bent, [1.0, 0.0, 0.6], [0.2, 0.0, 0.2])
    box = add_box(world, bent, [1.0, 0.0, 0.6], [0.2, 0.2, 0.2], yaw_deg=90.0)
    assert box.yaw == pytest.approx(np.pi / 2) and world.obstacles[0][1] is box
    world.close()


def test_latency_summary():
    assert latency_summary([]) == {"latency_median_ms": 0.0, "latency_p95_ms": 0.0}
    stats = latency_summary([0.001, 0.002, 0.003])
    assert stats["latency_median_ms"] == pytest.approx(2.0)
    assert 2.0 < stats["latency_p95_ms"] <= 3.0
