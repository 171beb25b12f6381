"""lfd.teach.recording: the 2-D waypoint path and the recording state machine."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.teach.recording import waypoint_path


def test_waypoint_path_is_minimum_jerk_and_timed_by_the_speed():
    a, b = np.zeros(2), np.array([0.6, -0.3])
    t, q = waypoint_path([a, b], 2, speed=0.6)
    assert t[0] == 0.0 and t[-1] == np.float64(1.0)  # 0.6 rad at 0.6 rad/s
    np.testing.assert_allclose(q[[0, -1]], [a, b])
    assert np.all(np.diff(t) > 0) and len(t) == 51
    np.testing.assert_allclose(q[25], (a + b) / 2, atol=1e-12)  # symmetric profile
    t, q = waypoint_path([a, a + 0.01], 2, speed=0.6)
    assert t[-1] == 0.5  # at least 0.5 s per segment
    t, q = waypoint_path([a], 2, speed=0.6)
    assert t.shape == (1,) and q.shape == (1, 2)


def test_recording_states():
    from lfd.teach import TeachSession

    s = TeachSession(robot="wam4", scene=None, clock=iter(np.arange(0, 100, 0.05)).__next__)
    assert s.recording_state == "idle" and len(s.recorded) == 0
    s.drag(s.tool_position + [0.0, 0.0, -0.02])
    assert s.recording_state == "recording" and len(s.recorded) == 2
    s.stop()
    assert s.recording_state == "done" and s.end_reason == "stop"
    assert s.playback(rate=10).shape[1] == 4
    s.clear()
    assert s.recording_state == "idle" and len(s.recorded) == 0
    s.close()


def _drag_with_idle(s, clock, seconds=5.0, idle=10.0):
    """~``seconds`` of dragging at the clock's rate, with ``idle`` s in the middle: half of it a pause (no
    updates), half the gizmo held still (updates that repeat one target)."""
    p0 = s.tool_position
    n = int(round(seconds / clock.dt))
    half = n // 2
    path = [p0 + [0.0, 0.12 * k / n, -0.1 * k / n] for k in range(1, n + 1)]
    results = [s.drag(p) for p in path[:half]]
    clock.now += idle / 2  # the user lets go and looks
    held = path[half - 1]
    results += [s.drag(held) for _ in range(int(round(idle / 2 / clock.dt)))]
    results += [s.drag(p) for p in path[half:]]
    assert all(r.accepted for r in results)
    return n


def test_idle_time_is_trimmed_and_the_raw_recording_kept(tmp_path):
    import json

    from teach_helpers import FakeClock

    from lfd.dmp import DMP
    from lfd.teach import TeachSession

    clock = FakeClock(0.04)
    s = TeachSession(robot="wam4", scene=None, clock=clock)
    n = _drag_with_idle(s, clock)
    s.stop()
    motion_time = n * clock.dt  # the time the arm moved
    raw, rec = s.recorded_raw, s.recorded
    assert raw.t[-1] > motion_time + 9.0  # the clock's view: the pause and the hold are in it
    assert abs(rec.t[-1] - motion_time) < 0.1 * motion_time
    assert np.all(np.diff(rec.t) > 0) and rec.t[0] == 0.0
    moved = np.max(np.abs(np.diff(rec.q, axis=0)), axis=1)
    assert moved.min() > 0  # no row repeats the one before (no flat runs)
    np.testing.assert_array_equal(rec.q[[0, -1]], raw.q[[0, -1]])
    paths = s.export(tmp_path)
    dmp = DMP.load(paths["dmp"])
    assert abs(dmp.tau_ - motion_time) < 0.1 * motion_time
    info = json.loads(paths["json"].read_text())
    assert len(info["recording_raw"]["t"]) == len(raw) and info["recording_raw"]["t"][-1] == raw.t[-1]
    assert info["timings"]["duration_s"] == rec.t[-1]
    s.close()


def test_trimming_can_be_switched_off():
    from teach_helpers import FakeClock

    from lfd.teach import TeachSession

    clock = FakeClock(0.04)
    s = TeachSession(robot="wam4", scene=None, clock=clock, trim_idle=False)
    _drag_with_idle(s, clock)
    np.testing.assert_array_equal(s.recorded.t, s.recorded_raw.t)
    assert s.recorded.t[-1] > 14.0
    s.close()


def test_trim_idle_keeps_moving_stretches_and_drops_repeats():
    from lfd.teach.recording import trim_idle
    from lfd.teach.results import Recording

    t = np.array([0.0, 0.0001, 0.04, 0.08, 10.08, 10.12])
    q = np.array([[0.0], [0.0], [0.01], [0.02], [0.021], [0.03]])
    trimmed, times = trim_idle(Recording(t, q, np.zeros((6, 3))), idle_speed=0.02)
    # the repeated start row is dropped; 10 s for 0.001 rad becomes 0.05 s; moving stretches keep 0.04 s
    np.testing.assert_allclose(trimmed.t, [0.0, 0.0399, 0.0799, 0.1299, 0.1699])
    np.testing.assert_array_equal(trimmed.q[:, 0], [0.0, 0.01, 0.02, 0.021, 0.03])
    assert times.shape == (6,) and times[1] == times[0]
    with pytest.raises(ValueError, match="idle_speed"):
        trim_idle(Recording(t, q, np.zeros((6, 3))), idle_speed=0.0)
