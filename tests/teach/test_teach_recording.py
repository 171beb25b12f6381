"""lfd.teach.recording: the 2-D waypoint path and the recording state machine."""

from __future__ import annotations

import numpy as np

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
