"""Approach rule: side for round objects at least 6 cm tall, top for the rest, following the placement."""

import math

import numpy as np
import pytest

from lfd.sim.approach import (
    SHOULDER_XY,
    SIDE_MIN_HEIGHT,
    TABLE_Z,
    approach_mode,
    box_grasp_yaw,
    plan_approach,
)
from lfd.sim.objects import ObjectSpec, Placement

RED = (1.0, 0.0, 0.0, 1.0)
CYLINDER = ObjectSpec("cylinder", (0.03, 0.12), RED, 0.2)
BOX = ObjectSpec("box", (0.05, 0.06, 0.08), RED, 0.2)


def _is_rotation(r):
    return np.allclose(r @ r.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(r), 1.0)


@pytest.mark.parametrize("shape", ["cylinder", "capsule", "sphere"])
@pytest.mark.parametrize(("x", "y"), [(0.45, -0.3), (0.6, 0.0), (0.7, 0.3)])
def test_round_objects_from_the_side_along_shoulder_direction(shape, x, y):
    dims = {"cylinder": (0.03, 0.12), "capsule": (0.025, 0.08), "sphere": (0.04,)}[shape]
    spec = ObjectSpec(shape, dims, RED, 0.2)
    plans = [plan_approach(spec, Placement(x, y, yaw)) for yaw in (-1.2, 0.0, 1.0)]
    plan = plans[0]
    assert plan.mode == "side"
    for other in plans[1:]:  # yaw is invisible for a round object: it does not matter
        np.testing.assert_allclose(other.pregrasp_pose, plan.pregrasp_pose)
    expected = np.array([x - SHOULDER_XY[0], y - SHOULDER_XY[1], 0.0])
    np.testing.assert_allclose(plan.approach_dir, expected / np.linalg.norm(expected), atol=1e-12)
    np.testing.assert_allclose(plan.grasp_pose[:3, 2], [0, 0, 1])  # fingers close horizontally
    for pose in (plan.grasp_pose, plan.pregrasp_pose, plan.approach_pose):
        assert _is_rotation(pose[:3, :3])
        np.testing.assert_allclose(pose[:3, :3], plan.grasp_pose[:3, :3])
    np.testing.assert_allclose(plan.grasp_point[:2], [x, y])
    assert TABLE_Z < plan.grasp_point[2] <= TABLE_Z + spec.height
    # pre-grasp and approach lie back along the approach direction, towards the robot
    back = plan.grasp_point - plan.target_point
    assert np.dot(back, plan.approach_dir) > 0 and np.allclose(
        np.cross(back, plan.approach_dir), 0, atol=1e-12
    )
    assert np.linalg.norm(plan.target_point[:2] - np.array([x, y])) > dims[0]  # clear of the object
    assert np.linalg.norm(plan.approach_pose[:3, 3] - plan.grasp_point) > np.linalg.norm(back)


@pytest.mark.parametrize("yaw_deg", [-90, -60, -30, 0, 20, 44, 46, 89])
def test_boxes_from_the_top_following_yaw(yaw_deg):
    yaw = math.radians(yaw_deg)
    plan = plan_approach(BOX, Placement(0.55, 0.1, yaw))
    assert plan.mode == "top"
    np.testing.assert_allclose(plan.approach_dir, [0, 0, -1])
    closing = plan.grasp_pose[:3, 1]
    assert abs(closing[2]) < 1e-12
    # the closing axis is one of the box's horizontal axes (90 degree symmetry)
    box_x = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    assert max(abs(np.dot(closing, box_x)), abs(np.cross(closing, box_x)[2])) == pytest.approx(1.0)
    assert _is_rotation(plan.grasp_pose[:3, :3])
    np.testing.assert_allclose(plan.grasp_point[:2], [0.55, 0.1])
    assert plan.grasp_point[2] < TABLE_Z + BOX.height < plan.target_point[2] < plan.approach_pose[2, 3]


def test_box_grasp_yaw_folds_by_quarter_turns():
    for yaw in np.linspace(-math.pi, math.pi, 37):
        folded = box_grasp_yaw(yaw)
        assert -math.pi / 4 <= folded < math.pi / 4
        assert math.isclose(math.remainder(yaw - folded, math.pi / 2), 0.0, abs_tol=1e-9)


def test_invalid_offsets_raise():
    with pytest.raises(ValueError, match="clearance"):
        plan_approach(CYLINDER, Placement(0.5, 0.0, 0.0), clearance=-0.1)


@pytest.mark.parametrize(
    ("spec", "mode"),
    [
        (ObjectSpec("cylinder", (0.03, SIDE_MIN_HEIGHT - 1e-4), RED, 0.2), "top"),
        (ObjectSpec("cylinder", (0.03, SIDE_MIN_HEIGHT), RED, 0.2), "side"),
        (ObjectSpec("cylinder", (0.045, 0.045), RED, 0.2), "top"),  # a tin
        (ObjectSpec("cylinder", (0.008, 0.26), RED, 0.2), "side"),  # a pen standing up
        (ObjectSpec("sphere", (SIDE_MIN_HEIGHT / 2 - 1e-4,), RED, 0.2), "top"),
        (ObjectSpec("sphere", (SIDE_MIN_HEIGHT / 2,), RED, 0.2), "side"),
        (ObjectSpec("capsule", (0.01, SIDE_MIN_HEIGHT - 0.02), RED, 0.2), "side"),  # caps make it 6 cm
        (ObjectSpec("capsule", (0.01, SIDE_MIN_HEIGHT - 0.0201), RED, 0.2), "top"),
        (ObjectSpec("box", (0.05, 0.05, 0.25), RED, 0.2), "top"),  # tall boxes too
        (ObjectSpec("box", (0.02, 0.02, 0.02), RED, 0.2), "top"),
    ],
)
def test_approach_mode_is_decided_by_footprint_and_height(spec, mode):
    """Round footprint and at least SIDE_MIN_HEIGHT tall: side; anything else: top."""
    assert approach_mode(spec) == mode
    assert plan_approach(spec, Placement(0.55, 0.0, 0.3)).mode == mode


def test_low_round_objects_from_the_top_with_a_fixed_roll():
    """A low round object's yaw is invisible: the plan is the same for every yaw, the tool
    points down and the fingers close along the torso x-axis, ``finger_depth`` below the top."""
    tin = ObjectSpec("cylinder", (0.04, 0.045), RED, 0.2)
    plans = [plan_approach(tin, Placement(0.6, -0.1, yaw)) for yaw in (-1.5, -0.4, 0.0, 0.7, 1.5)]
    for plan in plans:
        assert plan.mode == "top"
        np.testing.assert_allclose(plan.pregrasp_pose, plans[0].pregrasp_pose)
        np.testing.assert_allclose(plan.approach_pose, plans[0].approach_pose)
    plan = plans[0]
    np.testing.assert_allclose(plan.approach_dir, [0, 0, -1])
    np.testing.assert_allclose(plan.grasp_pose[:3, 1], [1, 0, 0], atol=1e-12)
    assert _is_rotation(plan.grasp_pose[:3, :3])
    np.testing.assert_allclose(plan.grasp_point, [0.6, -0.1, TABLE_Z + 0.045 - 0.02])
    np.testing.assert_allclose(plan.target_point, [0.6, -0.1, TABLE_Z + 0.045 + 0.03])
    ball = ObjectSpec("sphere", (0.015,), RED, 0.2)  # finger depth capped at half the height
    np.testing.assert_allclose(plan_approach(ball, Placement(0.6, 0.0, 0.0)).grasp_point[2], TABLE_Z + 0.015)


def test_mode_override():
    tin = ObjectSpec("cylinder", (0.04, 0.045), RED, 0.2)
    assert plan_approach(tin, Placement(0.6, 0.0, 0.0), mode="side").mode == "side"
    assert plan_approach(CYLINDER, Placement(0.6, 0.0, 0.0), mode="top").mode == "top"
    with pytest.raises(ValueError, match="plan_approach: mode must be"):
        plan_approach(CYLINDER, Placement(0.6, 0.0, 0.0), mode="front")
