"""Scripted expert: IK targets, trajectory, executed demonstrations in PyBullet."""

import numpy as np
import pytest
import torch

from lfd.robots import load_robot
from lfd.sim.approach import plan_approach
from lfd.sim.expert import SHOULDER_LIFT, DemoDiscarded, ScriptedExpert, run_demonstration
from lfd.sim.objects import SHAPES, ObjectSpec, Placement, PlacementRanges, sample_object
from lfd.sim.scene import ReachScene


@pytest.fixture(scope="module")
def robot():
    return load_robot("pr2_right_arm")


@pytest.fixture(scope="module")
def expert(robot):
    return ScriptedExpert(robot)


@pytest.fixture(scope="module")
def scene(robot):
    with ReachScene(robot, image_size=32) as s:
        yield s


@pytest.mark.parametrize(
    ("shape", "placement"),
    [
        ("cylinder", Placement(0.47, -0.25, 0.3)),
        ("capsule", Placement(0.68, 0.28, -1.2)),
        ("sphere", Placement(0.55, 0.05, 0.0)),
        ("box", Placement(0.65, -0.2, 1.4)),
    ],
)
def test_demonstrations_end_within_1cm_of_target(scene, expert, robot, shape, placement):
    obj = sample_object(np.random.default_rng(7), shape)
    demo = expert.run(scene, obj, placement)
    assert demo.final_error < 0.01
    assert demo.frames.shape == (100, 32, 32, 3) and demo.frames.dtype == np.uint8
    assert demo.joints.shape == demo.velocities.shape == (100, 7)
    np.testing.assert_allclose(demo.joints[0], robot.home.numpy(), atol=1e-9)
    np.testing.assert_allclose(demo.ee_poses[-1, :3, 3], demo.plan.target_point, atol=0.01)
    np.testing.assert_allclose(demo.joints[-1], demo.q_pregrasp, atol=0.01)
    assert np.abs(demo.velocities[-1]).max() < 0.05  # at rest at the end
    # the object was not disturbed
    np.testing.assert_allclose(demo.object_poses[-1], demo.object_poses[0], atol=2e-3)
    # the tool ends pointing along the approach direction
    assert demo.ee_poses[-1, :3, 0] @ demo.plan.approach_dir > np.cos(np.radians(2))


def test_ik_targets_reach_the_poses_and_are_consistent(expert, robot):
    rng = np.random.default_rng(3)
    ranges = PlacementRanges()
    for shape in ("cylinder", "box"):
        solved = []
        for _ in range(12):
            plan = plan_approach(sample_object(rng, shape), ranges.sample(rng))
            try:
                q_app, q_pre = expert.joint_targets(plan)
            except DemoDiscarded:
                continue
            for q, pose in ((q_app, plan.approach_pose), (q_pre, plan.pregrasp_pose)):
                np.testing.assert_allclose(robot.fk(torch.as_tensor(q)[None])[0].numpy(), pose, atol=1e-3)
            solved.append(q_pre)
        assert len(solved) >= 9
        # one IK branch: the targets of different placements stay close together
        assert np.ptp(np.array(solved), axis=0).max() < np.pi


@pytest.mark.parametrize("mode_shape", ["cylinder", "box"])
def test_ik_success_rate_over_the_placement_ranges(expert, mode_shape):
    rng = np.random.default_rng(11)
    ranges = PlacementRanges()
    ok = 0
    n = 30
    for _ in range(n):
        try:
            expert.joint_targets(plan_approach(sample_object(rng, mode_shape), ranges.sample(rng)))
            ok += 1
        except DemoDiscarded:
            pass
    assert ok / n >= 0.9


def test_trajectory_shape(expert):
    q_app = expert.home + 0.5
    q_pre = expert.home + 0.6
    q, qd = expert.trajectory(q_app, q_pre)
    np.testing.assert_allclose(q[0], expert.home)
    np.testing.assert_allclose(q[-1], q_pre)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)
    i_app = int(round(expert.approach_fraction * (expert.n_steps - 1)))
    np.testing.assert_allclose(q[i_app], q_app, atol=1e-2)
    mid = q[int(round(expert.via_fraction * (expert.n_steps - 1)))]
    assert mid[SHOULDER_LIFT] < (expert.home[SHOULDER_LIFT] + q_app[SHOULDER_LIFT]) / 2 - 0.2  # raised


def test_unreachable_placement_is_discarded(scene):
    obj = ObjectSpec("cylinder", (0.03, 0.15), (0.2, 0.8, 0.2, 1.0), 0.2)
    with pytest.raises(DemoDiscarded) as info:
        run_demonstration(scene, obj, Placement(1.25, 0.0, 0.0))
    assert info.value.reason == "ik_failed"


def test_expert_validation(robot, scene, expert):
    with pytest.raises(ValueError, match="via_fraction"):
        ScriptedExpert(robot, via_fraction=0.8, approach_fraction=0.7)
    short = ScriptedExpert(robot, n_steps=50)
    with pytest.raises(ValueError, match="control_dt"):
        short.run(scene, sample_object(np.random.default_rng(0), SHAPES[0]), Placement(0.6, 0.0, 0.0))
    with pytest.raises(ValueError, match="reason"):
        DemoDiscarded("bad", "x")


@pytest.mark.parametrize(
    ("low", "tall"),
    [
        (
            ObjectSpec("cylinder", (0.03, 0.055), (0.2, 0.2, 0.8, 1.0), 0.2),
            ObjectSpec("cylinder", (0.03, 0.06), (0.2, 0.2, 0.8, 1.0), 0.2),
        ),
        (
            ObjectSpec("sphere", (0.0275,), (0.2, 0.2, 0.8, 1.0), 0.2),
            ObjectSpec("sphere", (0.03,), (0.2, 0.2, 0.8, 1.0), 0.2),
        ),
    ],
)
def test_the_side_top_boundary_is_where_the_side_approach_stops_working(
    scene, expert, monkeypatch, low, tall
):
    """The approach rule's 6 cm boundary, in PyBullet: below it the side approach's forearm
    touches the table, the rule's top approach reaches; at it the side approach reaches."""
    import functools

    import lfd.sim.expert as expert_module

    placements = [Placement(0.5, -0.2, 0.0), Placement(0.6, 0.0, 0.5), Placement(0.65, 0.2, -0.8)]
    for p in placements:
        assert expert.run(scene, low, p).plan.mode == "top"
        assert expert.run(scene, tall, p).plan.mode == "side"
    monkeypatch.setattr(expert_module, "plan_approach", functools.partial(plan_approach, mode="side"))
    reasons = []
    for p in placements:
        with pytest.raises(DemoDiscarded) as info:
            expert.run(scene, low, p)
        reasons.append(info.value.reason)
    assert reasons == ["table_collision"] * len(placements)
