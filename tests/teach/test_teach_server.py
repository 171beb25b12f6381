"""The server's handlers without a browser, for every teachable robot."""

from __future__ import annotations

import time

import numpy as np
import pytest
from teach_helpers import BOXES, FakeClock

from lfd.teach import TeachSession, teach_robots
from lfd.teach.server import TeachServer


@pytest.mark.parametrize("robot", teach_robots())
def test_server_handles_drags_and_buttons(robot, tmp_path):
    session = TeachSession(robot=robot, scene=None)
    server = TeachServer(session, port=0, export_dir=tmp_path)
    try:
        assert server.url.startswith("http://127.0.0.1:")
        # every URDF link with shapes gets a scene frame
        assert len(server.view.link_nodes) == session.n_dof and server.view.visuals
        p0 = session.tool_position
        for k in range(1, 11):
            r = server.handle_drag(p0 + [0.0, 0.0, 0.01 * k])
            assert r.accepted
        assert len(session.recorded) == 11
        np.testing.assert_allclose(
            server.view.link_nodes[-1].position, session.kin.frames(session.q)[-2, :3, 3]
        )
        # a target far out of reach: refused or best effort, marker red, ghost shown
        r = server.handle_drag(p0 + [3.0, 0.0, 0.0])
        assert (
            not r.reachable and tuple(server.view.marker.color) == (220, 40, 40) and server.view.ghost.visible
        )
        server._run(server._stop)
        server._run(server._export)
        assert server.last_export is not None and server.last_export["dmp"].is_file()
        server._run(server._send)
        assert session.last_send is not None and server.view.executed_line is not None
        assert "final error" in server.status.content
    finally:
        server.close()
        session.close()


class _Event:
    """A GUI / gizmo event as the server itself would send it (no client: allowed to act)."""

    client = None
    client_id = None

    def __init__(self, position=None, phase: str = "update", wxyz=(1.0, 0.0, 0.0, 0.0)):
        self.phase = phase
        self.target = type("Target", (), {"position": position, "wxyz": wxyz})()


@pytest.fixture
def served(tmp_path):
    session = TeachSession(robot="wam4", scene=BOXES, clock=FakeClock())
    server = TeachServer(session, port=0, export_dir=tmp_path / "export")
    yield server
    server.close()
    session.close()


def _shows_the_arm(server) -> None:
    s = server.session
    pos, quat = s.tool_pose()
    np.testing.assert_allclose(server.view.gizmo.position, pos, atol=1e-6)
    np.testing.assert_allclose([sl.value for sl in server.sliders], s.q, atol=5e-4 + 1e-9)
    np.testing.assert_allclose(server.xyz.value, np.round(pos, 3), atol=1e-9)
    assert f"{pos[0]:.3f} {pos[1]:.3f} {pos[2]:.3f}" in server.readout.content


def test_gizmo_readout_and_sliders_follow_the_arm_after_every_action(served):
    s = served.session
    p0 = s.tool_position
    for k in range(1, 8):
        served.handle_drag(p0 + [0.0, 0.0, 0.02 * k])
    served._on_gizmo(_Event(tuple(p0 + [0.0, 0.0, 0.2]), phase="end"))
    _shows_the_arm(served)
    served._run(served._clear)  # the arm goes back to the start: so does the gizmo
    assert np.allclose(s.q, s.start)
    _shows_the_arm(served)
    # a drag from where the gizmo is now is accepted (it was a joint jump from the stale gizmo)
    gizmo = np.array(served.view.gizmo.position)
    r = served.handle_drag(gizmo + [0.0, 0.0, 0.01])
    assert r.accepted and r.reason == "ok"
    for k in range(2, 6):
        served.handle_drag(gizmo + [0.0, 0.0, 0.01 * k])
    served._run(served._home)
    _shows_the_arm(served)
    served._run(served._playback)
    _shows_the_arm(served)
    served._run(served._clear)
    served._on_mode(None, "2d")  # 2-D: the gizmo is hidden, the active mode button marked
    assert not served.view.gizmo.visible and served.mode_buttons["2d"].color == "blue"
    assert served.mode_buttons["3d"].color == "gray"
    served.sliders[0].value = float(s.q[0] + 0.1)
    served._slider_moved(0)
    assert s.q[0] == pytest.approx(np.round(s.start[0] + 0.1, 3)) and np.all(s.q[1:] == s.start[1:])
    _shows_the_arm(served)
    served._run(served._clear)
    served._on_mode(None, "3d")
    assert served.view.gizmo.visible and served.mode_buttons["3d"].color == "blue"


def test_readout_follows_a_drag_while_the_gizmo_is_held(served):
    s = served.session
    p0 = s.tool_position
    served._on_gizmo(_Event(tuple(p0 + [0.0, 0.0, 0.02]), phase="start"))
    for k in range(1, 4):
        served.handle_drag(p0 + [0.0, 0.0, 0.02 * k])
        pos = s.tool_position
        assert f"{pos[0]:.3f} {pos[1]:.3f} {pos[2]:.3f}" in served.readout.content
    served._on_gizmo(_Event(tuple(p0 + [0.0, 0.0, 0.06]), phase="end"))
    _shows_the_arm(served)


def test_rotation_handles_turn_the_tool_of_a_seven_dof_arm(tmp_path):
    from lfd.robots.spatial import matrix_to_quaternion
    from lfd.teach.drag_ik import as_rotation, rotation_angle
    from lfd.teach.server import xyzw_to_wxyz

    session = TeachSession(robot="sawyer", scene=None)
    server = TeachServer(session, port=0, export_dir=tmp_path)
    try:
        assert server.rotations and server.view.gizmo.disable_rotations is False
        pos, quat = session.tool_pose()
        np.testing.assert_allclose(server.view.gizmo.wxyz, xyzw_to_wxyz(quat), atol=1e-9)

        def about_z(deg: float) -> np.ndarray:
            c, s_ = np.cos(np.radians(deg)), np.sin(np.radians(deg))
            return np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])

        goal = about_z(20.0) @ as_rotation(quat, order="xyzw")
        for deg in np.linspace(2.0, 20.0, 10):  # the ring turned in 2-degree steps, through the worker
            wxyz = matrix_to_quaternion(about_z(deg) @ as_rotation(quat, order="xyzw"))
            server._on_gizmo(_Event(tuple(pos), wxyz=tuple(wxyz)))
            time.sleep(0.05)
        for _ in range(5):  # a held gizmo keeps sending its pose
            server._on_gizmo(_Event(tuple(pos), wxyz=tuple(wxyz)))
            time.sleep(0.05)
        assert _wait(lambda: server.processed_updates >= 10)
        frame = session.kin.frames(session.q)[-1]
        assert np.degrees(rotation_angle(goal, frame[:3, :3])) < 2.0
        assert np.linalg.norm(frame[:3, 3] - pos) < 0.01
        assert "roll/pitch/yaw" in server.readout.content
    finally:
        server.close()
        session.close()


def _wait(predicate, timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return bool(predicate())


def test_add_box_default_is_accepted_and_a_box_on_the_goal_is_refused(served):
    s = served.session
    n = len(s.scene.obstacles)
    served._run(served._add_box)
    assert len(s.scene.obstacles) == n + 1 and not s.scene.goal.overlaps(s.scene.obstacles[-1])
    served.box_center.value = tuple(s.scene.goal.center)
    served._run(served._add_box)
    assert len(s.scene.obstacles) == n + 1 and "would cover the goal" in served.status.content


def test_each_action_has_one_button_and_a_hint(served):
    labels = [h.label for h in served.server.gui._gui_input_handle_from_uuid.values() if hasattr(h, "label")]
    for label in ("Playback", "Send", "Stop", "Export", "Clear", "Store"):
        assert labels.count(label) == 1, label
    assert "Take control" not in labels  # only viewers get one (their own)
    assert "Drag the arrows" in served.hint.content


def test_keyframes_timeline_speed_gripper_and_reopen(served, tmp_path):
    s = served.session
    p0 = s.tool_position
    served._run(lambda: served._add_keyframe(None))
    for k in range(1, 11):
        served.handle_drag(p0 + [0.0, 0.0, 0.01 * k])
    served._run(lambda: served._add_keyframe(None))
    served._run(served._stop)
    assert len(s.keyframes) == 2 and len(served.view.keyframe_handles) == 2
    assert served.view.motion_line is not None and served.timeline.max == pytest.approx(
        s.motion_duration, abs=0.01
    )
    # drag keyframe 2 in 3-D: the keyframe moves, the motion is redrawn
    before = np.array(served.view.motion_line.points).copy()
    target = s.keyframe_poses()[1][0] + [0.0, 0.02, 0.0]
    served._on_keyframe(1, _Event(tuple(target)))
    assert np.linalg.norm(s.keyframe_poses()[1][0] - target) < 1e-3
    assert not np.allclose(served.view.motion_line.points, before)
    served._on_keyframe(1, _Event(tuple(target), phase="end"))
    np.testing.assert_allclose(served.view.keyframe_handles[1].position, s.keyframe_poses()[1][0], atol=1e-6)
    # insert before 2, reorder, delete
    served.keyframe_pick.value = "2"
    served._run(served._insert_keyframe)
    assert len(s.keyframes) == 3 and served.keyframe_pick.value == "2"
    served._run(lambda: served._shift_keyframe(+1))
    assert served.keyframe_pick.value == "3"
    served._run(served._delete_keyframe)
    assert len(s.keyframes) == 2 and len(served.view.keyframe_handles) == 2
    # timeline, speed, gripper
    served.timeline.value = s.motion_duration / 2
    served._run(served._scrub)
    rec, mot = served.view.timeline_markers
    assert rec.visible and mot.visible
    served._run(lambda: served._gripper(True))
    assert [e.closed for e in s.gripper_events] == [True] and "close at" in served.gripper_list.content
    duration = s.motion_duration
    served.speed.value = 2.0
    served._run(served._set_speed)
    assert s.speed == 2.0 and served.timeline.max == pytest.approx(duration / 2, abs=0.01)
    # export and reopen: the exported skill passes the keyframes as edited in the panel within 1 mm
    served._run(served._export)
    folder = served.last_export["csv"].parent
    from lfd.dmp import DMP

    tool = np.array([s.kin.tool_position(q) for q in DMP.load(served.last_export["dmp"]).rollout()])
    for p, _ in s.keyframe_poses():
        assert np.linalg.norm(tool - p, axis=1).min() < 1e-3
    assert served.reopen_pick.value == folder.name
    old = s
    served._run(served._reopen)
    assert served.session is not old and "reopened" in served.status.content
    r = served.session
    assert len(r.keyframes) == 2 and r.speed == 2.0 and [e.closed for e in r.gripper_events] == [True]
    assert len(served.view.keyframe_handles) == 2 and served.view.motion_line is not None
    with pytest.raises(ValueError, match="only exports in"):
        served.reopen(tmp_path)
