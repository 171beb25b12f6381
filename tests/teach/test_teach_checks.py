"""lfd.teach.checks: argument vectors, joint limits, the swept collision check, scene validation."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.robots import load_robot
from lfd.sim.collision import CollisionWorld
from lfd.teach.checks import check_joint_limits, check_vector, sweep, validate_scene
from lfd.teach.scene import Box, load_scene


def test_check_vector():
    np.testing.assert_array_equal(check_vector([1, 2, 3], 3, "p"), [1.0, 2.0, 3.0])
    for bad, match in (("abc", "must be 3 numbers"), ([1, 2], r"shape \(3,\)"), ([1, np.nan, 2], "NaN")):
        with pytest.raises(ValueError, match=match):
            check_vector(bad, 3, "p")


def test_joint_limits_name_the_joint():
    robot = load_robot("wam4")
    q = robot.home.numpy().copy()
    check_joint_limits(robot, q)
    q[2] = robot.upper.numpy()[2] + 0.1
    with pytest.raises(ValueError, match=r"joint 2 \("):
        check_joint_limits(robot, q)


def test_sweep_finds_a_thin_wall_between_two_free_ends():
    robot = load_robot("wam4")
    world = CollisionWorld(robot, [Box(np.array([0.4, 0.0, 0.6]), np.array([0.02, 0.3, 0.6]))])
    a, b = np.array([-1.5, 0.0, 0.0, 1.57]), np.array([1.5, 0.0, 0.0, 1.57])  # forearm swings across the wall
    assert not world.check(a).in_collision and not world.check(b).in_collision
    assert sweep(world, a, b, 0.01).kind == "obstacle"
    assert sweep(world, a, b, 5.0).kind is None  # one check, at the end only
    world.close()


def test_validate_scene_names_the_field():
    robot = load_robot("wam4")
    scene = load_scene({"obstacles": [{"center": [0.0, 0.0, 0.05], "size": [0.2, 0.2, 0.1]}]})
    world = CollisionWorld(robot, scene.obstacles)
    with pytest.raises(ValueError, match=r"obstacles\[0\]' overlaps the robot base"):
        validate_scene(robot, "wam4", scene, robot.home.numpy(), world)
    world.close()
    far = load_scene({"goal": {"center": [3.0, 0.0, 0.5], "radius": 0.05}})
    world = CollisionWorld(robot)
    with pytest.raises(ValueError, match="scene field 'goal': unreachable"):
        validate_scene(robot, "wam4", far, robot.home.numpy(), world)
    world.close()
