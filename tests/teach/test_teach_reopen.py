"""Gripper events, speed and reopening an export: export -> reopen gives back the same session to edit."""

from __future__ import annotations

import json

import numpy as np
import pytest
from teach_helpers import BOXES, FakeClock, drag_line

from lfd.dmp import DMP
from lfd.teach import TeachSession
from lfd.teach.gripper import GripperEvent
from lfd.visuomotor.data.episodes import EpisodeRecord

LIFT = 0.42  # m, clears the wall of boxes.yaml


def _pick(s: TeachSession, clock: FakeClock) -> None:
    """Over the wall into the goal with a pause on top, keyframes at the corners, one moved, the gripper
    closing on top and opening in the goal, at twice the speed."""
    p0, goal = s.tool_position, s.scene.goal.center
    up, over = np.array([p0[0], p0[1], LIFT]), np.array([goal[0], goal[1], LIFT])
    assert all(r.accepted for r in drag_line(s, p0, up, n=20))
    s.add_keyframe()
    clock.now += 4.0  # a pause: trimmed
    for a, b in ((up, over), (over, goal)):
        assert all(r.accepted for r in drag_line(s, a, b, n=20))
        s.add_keyframe()
    assert s.move_keyframe(1, s.keyframe_poses()[1][0] + [0.0, 0.0, 0.04]).accepted
    s.speed = 2.0
    d = s.motion_duration
    assert s.add_gripper_event(0.6 * d, False) == 0
    assert s.add_gripper_event(0.3 * d, True) == 0  # sorted by time
    assert [e.closed for e in s.gripper_events] == [True, False]


def test_gripper_events_speed_and_keyframes_round_trip_through_export_and_reopen(tmp_path):
    clock = FakeClock()
    s = TeachSession(robot="wam4", scene=BOXES, clock=clock)
    _pick(s, clock)
    paths = s.export(tmp_path / "a")
    info = json.loads(paths["json"].read_text())
    assert info["speed"] == 2.0
    assert info["gripper_events"] == [{"t": e.t, "closed": e.closed} for e in s.gripper_events]
    ep = EpisodeRecord.load(paths["episode"])
    np.testing.assert_allclose(ep.arrays["gripper_event_t"], [e.t for e in s.gripper_events])
    np.testing.assert_array_equal(ep.arrays["gripper_event_closed"], [True, False])
    g, t = ep.arrays["gripper"], ep.arrays["t"]
    (t_close, _), (t_open, _) = ((e.t, e.closed) for e in s.gripper_events)
    assert (
        np.all(g[t < t_close] == 0)
        and np.all(g[(t >= t_close) & (t < t_open)] == 1)
        and np.all(g[t >= t_open] == 0)
    )
    assert float(ep.arrays["speed"]) == 2.0

    r = TeachSession.reopen(paths["json"].parent, clock=FakeClock())
    assert r.robot_name == "wam4" and r.scene.to_dict() == s.scene.to_dict() and r.mode == "3d"
    assert r.recording_state == "done" and r.end_reason == "goal"
    assert r.gripper_events == s.gripper_events
    assert r.speed == s.speed
    np.testing.assert_array_equal(r.keyframes, s.keyframes)
    assert [k.anchor for k in r._keyframes] == [k.anchor for k in s._keyframes]
    for a, b in ((r.recorded_raw, s.recorded_raw), (r.recorded, s.recorded)):
        np.testing.assert_array_equal(a.t, b.t)
        np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_allclose(r.motion().q, s.motion().q, atol=1e-12)
    # and editing goes on: a keyframe moved back, exported again
    assert r.move_keyframe(1, r.keyframe_poses()[1][0] - [0.0, 0.0, 0.02]).accepted
    again = r.export(tmp_path / "b")
    dmp = DMP.load(again["dmp"])
    assert dmp.tau_ == pytest.approx(r.recorded.t[-1] / 2.0)
    r.close()
    s.close()


def test_speed_scales_the_motion_and_is_checked():
    clock = FakeClock()
    s = TeachSession(robot="wam4", scene=BOXES, clock=clock)
    p0 = s.tool_position
    drag_line(s, p0, p0 + [0.0, 0.1, 0.1], n=30)
    slow = s.motion(50)
    s.speed = 4.0
    fast = s.motion(50)
    assert fast.t[-1] == pytest.approx(slow.t[-1] / 4.0) and s.motion_duration == pytest.approx(fast.t[-1])
    np.testing.assert_allclose(fast.q, slow.q, atol=1e-9)  # the same path, faster
    for bad in (0.05, 5.0, float("nan"), True):
        with pytest.raises(ValueError, match=r"speed must be a finite number in \[0.1, 4"):
            s.speed = bad
    with pytest.raises(ValueError, match="gripper event t must be a finite number"):
        s.add_gripper_event(fast.t[-1] + 1.0, True)
    with pytest.raises(ValueError, match="closed must be true or false"):
        s.add_gripper_event(0.1, "yes")
    with pytest.raises(ValueError, match="gripper event index"):
        s.remove_gripper_event(0)
    s.add_gripper_event(0.1, True)
    s.remove_gripper_event(0)
    assert s.gripper_events == []
    s.close()


def test_gripper_events_move_with_the_speed():
    s = TeachSession(robot="wam4", scene=None, clock=FakeClock())
    drag_line(s, s.tool_position, s.tool_position + [0.0, 0.1, 0.0], n=25)
    d = s.motion_duration
    s.add_gripper_event(0.5 * d, True)
    s.speed = 2.0
    assert s.gripper_events == [GripperEvent(pytest.approx(0.25 * d), True)]
    m = s.motion(101)
    assert m.gripper[49] == 0 and m.gripper[51] == 1
    s.close()


def test_reopen_refuses_folders_lfd_did_not_write(tmp_path, monkeypatch):
    with pytest.raises(FileNotFoundError, match="no demo.json"):
        TeachSession.reopen(tmp_path)
    (tmp_path / "demo.json").write_text(json.dumps({"format": "notes"}))
    with pytest.raises(ValueError, match="not a teach demonstration lfd wrote") as e:
        TeachSession.reopen(tmp_path)
    assert "\n" not in str(e.value)
    (tmp_path / "demo.json").write_bytes(b"\xff\xfe{")
    with pytest.raises(ValueError, match="not valid UTF-8 JSON"):
        TeachSession.reopen(tmp_path)
    (tmp_path / "demo.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="nested too deep|not a teach demonstration"):
        TeachSession.reopen(tmp_path)
    import lfd.teach.export as export

    monkeypatch.setattr(export, "MAX_DEMO_JSON_BYTES", 1000)
    (tmp_path / "demo.json").write_text(json.dumps({"format": "lfd-teach-demonstration", "pad": "x" * 2000}))
    with pytest.raises(ValueError, match="more than the"):
        TeachSession.reopen(tmp_path)


def test_reopen_names_the_field_that_does_not_fit(tmp_path):
    clock = FakeClock()
    s = TeachSession(robot="wam4", scene=BOXES, clock=clock)
    drag_line(s, s.tool_position, s.tool_position + [0.0, 0.0, 0.08], n=10)
    s.add_keyframe()
    paths = s.export(tmp_path)
    s.close()
    info = json.loads(paths["json"].read_text())
    for key, value, message in (
        ("keyframes", {"q": [[0.0, 0.0]], "anchor": [None]}, "keyframes.q"),
        ("keyframes", {"q": info["keyframes"]["q"], "anchor": [999]}, "keyframes.anchor"),
        ("gripper_events", [{"t": -1.0, "closed": True}], "gripper_events.t"),
        ("speed", 9.0, "speed must be"),
        ("end_reason", "rm -rf", "'end_reason' must be"),
        ("recording_raw", {"t": [0.0, float("nan")], "q": [[0.0] * 4] * 2}, "recording: t"),
        ("robot", "ur5", "unknown robot"),
    ):
        bad = dict(info, **{key: value})
        paths["json"].write_text(json.dumps(bad))
        with pytest.raises(ValueError, match=message) as e:
            TeachSession.reopen(paths["json"].parent)
        assert "\n" not in str(e.value) and str(e.value).startswith(f"{paths['json'].parent}/demo.json: ")
