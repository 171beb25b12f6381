"""TeachSession logic without a browser: dragging, recording, collisions, the 2-D panel."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from teach_helpers import BOXES, FakeClock, drag_line

from lfd.robots import load_robot
from lfd.sim.collision import CollisionWorld
from lfd.teach import TeachSession
from lfd.teach.drag_ik import DragIK

ABOVE_WALL = 0.42  # m: tool height that clears the boxes.yaml wall (top 0.30 m)


def over_the_wall(session, goal) -> list:
    p0 = session.tool_position
    up, over = p0 + [0, 0, ABOVE_WALL - p0[2]], np.array([goal[0], goal[1], ABOVE_WALL])
    return drag_line(session, p0, up) + drag_line(session, up, over) + drag_line(session, over, goal)


def test_drag_sequence_records_the_path_and_the_goal_ends_it(boxes_session):
    s = boxes_session
    start = s.q.copy()
    goal = s.scene.goal.center
    results = over_the_wall(s, goal)
    assert all(r.accepted for r in results) and s.collisions == 0
    assert s.recording_state == "done" and s.end_reason == "goal"
    first_in_goal = next(i for i, r in enumerate(results) if r.reached_goal)
    rec = s.recorded
    # first sample is the configuration before the first drag, then one per accepted update up to the goal
    assert len(rec) == first_in_goal + 2
    np.testing.assert_array_equal(rec.q[0], start)
    np.testing.assert_allclose(rec.q[-1], results[first_in_goal].q)
    assert np.all(np.diff(rec.t) > 0) and rec.t[0] == 0.0
    assert s.scene.goal.contains(rec.tool[-1]) and not s.scene.goal.contains(rec.tool[-2])
    # the tool followed the dragged targets (IK to 1 mm)
    assert max(np.linalg.norm(r.tool - r.target) for r in results[: first_in_goal + 1]) < 1.5e-3
    # dragging on after the goal moves the arm but records nothing
    s.drag(s.tool_position + [0, 0, 0.02])
    assert len(s.recorded) == len(rec)


def test_recording_starts_on_first_drag_and_stop_ends_it(boxes_session):
    s = boxes_session
    assert s.recording_state == "idle" and len(s.recorded) == 0
    drag_line(s, s.tool_position, s.tool_position + [0, 0, 0.1], n=5)
    assert s.recording_state == "recording" and len(s.recorded) == 6
    s.stop()
    assert s.recording_state == "done" and s.end_reason == "stop"
    drag_line(s, s.tool_position, s.tool_position + [0, 0, 0.05], n=3)
    assert len(s.recorded) == 6


def test_collision_is_refused_counted_and_never_recorded(boxes_session):
    s = boxes_session
    p0, goal = s.tool_position, s.scene.goal.center
    results = drag_line(s, p0, goal, n=40)  # straight through the wall
    refused = [r for r in results if not r.accepted]
    assert refused and refused[0].in_collision and refused[0].reason == "collision"
    # once stuck at the wall, targets further on are collisions or too far a joint change
    assert all(r.reason in ("collision", "joint_jump") for r in refused)
    # the arm stays at its last collision-free pose
    first = results.index(refused[0])
    np.testing.assert_array_equal(refused[0].q, results[first - 1].q)
    assert s.collisions == 1  # one continuous push into the wall is one collision
    assert s.counters["refused_collision"] == sum(r.in_collision for r in refused)
    assert s.counters["refused_jump"] == sum(r.reason == "joint_jump" for r in refused)
    # no recorded configuration is in collision (checked by a fresh PyBullet client)
    fresh = CollisionWorld(s.robot, s.scene.obstacles, s.scene.table_z)
    assert not any(fresh.check(q).in_collision for q in s.recorded.q)
    fresh.close()
    # backing off and pushing in again is a second collision
    back = drag_line(s, s.tool_position, p0, n=10)
    again = drag_line(s, p0, goal, n=40)
    seq = [results[-1], *back, *again]
    runs = sum(1 for prev, r in zip(seq[:-1], seq[1:]) if r.in_collision and prev.accepted)
    assert runs >= 1 and s.collisions == 1 + runs


def test_table_collision_is_refused(boxes_session):
    s = boxes_session
    results = drag_line(s, s.tool_position, s.tool_position + [0, 0, -0.4], n=20)
    refused = [r for r in results if not r.accepted]
    assert refused and refused[0].detail == "table" and s.collisions == 1
    assert min(t[2] for t in s.recorded.tool) > s.scene.table_z


def test_self_collision_is_refused_by_the_sliders():
    s = TeachSession(robot="sawyer", scene=None)
    robot, checker = s.robot, s.checker
    # a configuration in self-collision: PyBullet's closest points between non-neighbour links
    qs = robot.sample_q(400, torch.Generator().manual_seed(0)).numpy()
    hit = next(q for q in qs if checker.check(q).kind == "self")
    before = s.q.copy()
    r = s.set_joints(hit)
    assert not r.accepted and r.in_collision and r.detail == "self" and s.collisions == 1
    np.testing.assert_array_equal(s.q, before)
    s.close()


@pytest.mark.parametrize(
    ("name", "wam_q3"), [("wam4", "fixed"), ("wam4", "free"), ("pr2_right_arm", "fixed")]
)
def test_ik_is_continuous_when_dragging_past_the_workspace_boundary(name, wam_q3):
    s = TeachSession(robot=name, scene=None, clock=FakeClock(), max_joint_step=0.15, wam_q3=wam_q3)
    p0 = s.tool_position
    shoulder = s.kin.frames(s.q)[1, :3, 3]
    direction = (p0 - shoulder) / np.linalg.norm(p0 - shoulder)
    results = drag_line(s, p0, shoulder + 1.6 * direction, n=80)  # well past the reach
    rec = s.recorded
    jumps = np.abs(np.diff(rec.q, axis=0)).max(axis=1)
    assert jumps.max() <= 0.15 + 1e-9  # no recorded step above the limit
    beyond = [r for r in results if not r.reachable]
    assert beyond, "the target left the workspace"
    assert all(not r.accepted or r.reason == "best_effort" for r in beyond)
    # the arm stays at the boundary: stretched towards the target, without flipping back
    final_reach = np.linalg.norm(s.tool_position - shoulder)
    max_reach = max(np.linalg.norm(t - shoulder) for t in rec.tool)
    assert final_reach > 0.97 * max_reach
    s.close()


def test_branch_jump_is_refused():
    s = TeachSession(robot="wam4", scene=None, clock=FakeClock(), max_joint_step=0.5)
    p = s.tool_position
    r = s.drag([-p[0], -p[1], p[2]])  # straight behind: joint 1 would turn by pi
    assert not r.accepted and r.reason == "joint_jump"
    np.testing.assert_array_equal(r.q, s.start)
    s.close()


def test_drag_ik_respects_its_time_budget():
    robot = load_robot("sawyer")
    ik = DragIK(robot, time_budget=1e-4, max_iters=10_000)
    step = ik.solve(robot.home.numpy(), [0.3, -0.6, 0.2])
    assert step.timed_out and step.iterations < 10_000


def test_drag_rejects_bad_input(boxes_session):
    with pytest.raises(ValueError, match="position"):
        boxes_session.drag([0.1, 0.2])
    with pytest.raises(ValueError, match="NaN"):
        boxes_session.drag([0.1, np.nan, 0.2])
    with pytest.raises(ValueError, match="orientation"):
        boxes_session.drag([0.4, 0.0, 0.5], orientation=np.eye(3))
    with pytest.raises(ValueError, match="outside"):
        boxes_session.set_joints([0.0, 0.0, 0.0, 5.0])


def test_seven_dof_drag_follows_an_orientation():
    s = TeachSession(robot="sawyer", scene=None, clock=FakeClock())
    pose = s.kin.frames(s.q)[-1]
    r = s.drag(pose[:3, 3] + [0.0, 0.03, 0.0], orientation=pose[:3, :3])
    assert r.accepted and r.reachable
    np.testing.assert_allclose(s.kin.frames(s.q)[-1][:3, :3], pose[:3, :3], atol=2e-2)
    s.close()


def test_two_d_panel_waypoints_collisions_and_goal():
    s = TeachSession(robot="wam4", scene=BOXES, mode="2d", clock=FakeClock())
    with pytest.raises(ValueError, match="3-D"):
        s.drag(s.tool_position)
    goal = s.scene.goal.center
    p0 = s.tool_position
    above_start, over_goal = p0 + [0, 0, ABOVE_WALL - p0[2]], np.array([goal[0], goal[1], ABOVE_WALL])
    assert s.move_to(above_start).accepted and s.store()
    # straight to the goal in joint space from here sweeps through the wall: the move is refused
    r = s.move_to(goal)
    assert not r.accepted and r.in_collision and s.collisions == 1
    assert s.move_to(over_goal).accepted and s.store()
    # Go Home jumps; storing it would make the arm sweep back through the wall: refused
    s.go_home()
    assert not s.store() and s.collisions == 2 and s.counters["refused_stores"] == 1
    for p in (above_start, over_goal, goal):
        assert s.move_to(p).accepted
    assert s.store()
    assert s.recording_state == "done" and s.end_reason == "goal"
    wp = s.waypoints
    assert wp.shape == (4, 4)
    rec = s.recorded
    np.testing.assert_allclose(rec.q[0], s.start)
    np.testing.assert_allclose(rec.q[-1], wp[-1])
    fresh = CollisionWorld(s.robot, s.scene.obstacles, s.scene.table_z)
    assert not any(fresh.check(q).in_collision for q in rec.q)
    fresh.close()
    # the sliders obey the same rule; Go Home returns to the start
    r = s.set_joints(s.start + [0.0, 0.9, 0.0, 0.0])
    assert not r.accepted and r.in_collision
    s.go_home()
    np.testing.assert_array_equal(s.q, s.start)
    frames = s.playback(rate=30.0)
    assert frames.shape[1] == 4 and len(frames) == int(rec.t[-1] * 30) + 1
    s.close()


def test_unreachable_xyz_entry_is_refused():
    s = TeachSession(robot="wam4", scene=BOXES, mode="2d")
    r = s.move_to([2.0, 0.0, 0.5])
    assert not r.accepted and r.reason == "unreachable"
    s.close()


def test_added_obstacle_is_checked(boxes_session):
    s = boxes_session
    with pytest.raises(ValueError, match="base"):
        s.add_obstacle([0.0, 0.0, 0.0], [0.1, 0.1, 0.1])
    with pytest.raises(ValueError, match="current pose"):
        s.add_obstacle(s.tool_position, [0.05, 0.05, 0.05])
    s.add_obstacle(s.tool_position + [0, 0.15, 0], [0.1, 0.05, 0.1])
    results = drag_line(s, s.tool_position, s.tool_position + [0, 0.2, 0], n=10)
    assert any(r.in_collision for r in results) and len(s.scene.obstacles) == 3


def test_one_fast_update_cannot_jump_through_the_wall(boxes_session):
    s = boxes_session
    near = np.array([0.48, -0.10, 0.2])
    assert all(r.accepted for r in drag_line(s, s.tool_position, near, n=20))
    far = np.array([0.48, 0.10, 0.2])  # the wall (4 cm either side of y = 0) lies between
    step = s.ik.solve(s.q, far)
    assert step.reached and step.jump < s.max_joint_step
    assert not s.checker.check(step.q).in_collision  # the end pose alone is free...
    r = s.drag(far)
    assert not r.accepted and r.in_collision and s.collisions == 1  # ...the motion to it is not


def test_scripted_users_complete_a_seeded_task():
    from lfd.teach.scripted_users import klm_seconds, make_task, run_drag_user, run_slider_user, run_xyz_user

    task = make_task(3)
    assert task == make_task(3)  # seeded
    runs = [f(task) for f in (run_drag_user, run_xyz_user, run_slider_user)]
    assert all(r.success for r in runs)
    drag, xyz, slider = runs
    assert drag.actions["drag_segments"] >= 3 and drag.actions["keystrokes"] == 0
    assert xyz.actions["clicks"] >= 6 and xyz.actions["keystrokes"] > 0
    assert slider.actions["slider_moves"] >= 3
    assert all(r.path_length > 0.5 for r in runs)  # over the wall and down, at least ~0.7 m
    assert klm_seconds(drag) < klm_seconds(xyz)  # fewer, cheaper gestures (a model, not a measurement)


def _quat_angle(a, b) -> float:
    """Angle (rad) between two unit quaternions (either order, the same for both)."""
    return 2.0 * np.arccos(min(1.0, abs(float(np.dot(a, b)))))


def _rotate_xyzw(quat, axis, angle):
    """``quat`` (x, y, z, w) turned by ``angle`` rad about the base-frame ``axis``."""
    from lfd.robots.spatial import matrix_to_quaternion
    from lfd.teach.drag_ik import as_rotation

    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    r = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    return matrix_to_quaternion(r @ as_rotation(quat, order="xyzw"), order="xyzw")


def test_sawyer_orientation_drag_reaches_the_commanded_orientation():
    s = TeachSession(robot="sawyer", scene=None, clock=FakeClock())
    p0, q0 = s.tool_pose()
    assert p0.shape == (3,) and q0.shape == (4,) and q0[3] >= 0
    np.testing.assert_allclose(p0, s.tool_position)
    goal_p, goal_q = p0 + [0.0, 0.05, 0.03], _rotate_xyzw(q0, [1.0, 0.5, 0.0], np.radians(40))
    # the rotation handle dragged over 20 updates, with a small translation
    for a in np.linspace(0, 1, 21)[1:]:
        r = s.drag(p0 + a * (goal_p - p0), _rotate_xyzw(q0, [1.0, 0.5, 0.0], a * np.radians(40)))
        assert r.accepted, r.reason
    p, q = s.tool_pose()
    assert np.degrees(_quat_angle(q, goal_q)) < 2.0
    assert np.linalg.norm(p - goal_p) < 2e-3
    s.close()


def test_orientation_weight_zero_is_position_only():
    s = TeachSession(robot="sawyer", scene=None, clock=FakeClock(), orientation_weight=0.0)
    p0, q0 = s.tool_pose()
    target = _rotate_xyzw(q0, [0.0, 0.0, 1.0], np.radians(20))
    for a in np.linspace(0, 1, 11)[1:]:
        assert s.drag(p0 + [0.0, 0.0, 0.03 * a], target).accepted
    assert np.degrees(_quat_angle(s.tool_pose()[1], target)) > 5.0  # the orientation was not followed
    s.close()


def test_orientation_must_be_a_quaternion_or_rotation():
    s = TeachSession(robot="sawyer", scene=None, clock=FakeClock())
    with pytest.raises(ValueError, match="quaternion"):
        s.drag(s.tool_position, [0.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="quaternion"):
        s.drag(s.tool_position, [0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="rotation matrix"):
        s.drag(s.tool_position, -np.eye(3))
    for bad in ({"x": 1}, "up", [[1.0], [0.0, 1.0]]):  # not numbers at all (found by the fuzz harness)
        with pytest.raises(ValueError, match="got a (dict|str|list)"):
            s.drag(s.tool_position, bad)
    s.close()
