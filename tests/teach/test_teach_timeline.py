"""The timeline: at(t) scrubs the recording and the motion on the motion's time axis."""

from __future__ import annotations

import numpy as np
import pytest
from teach_helpers import FakeClock, drag_line

from lfd.teach import TeachSession


def test_at_scrubs_the_recording_and_the_motion():
    clock = FakeClock()
    s = TeachSession(robot="wam4", scene=None, clock=clock)
    p0 = s.tool_position
    drag_line(s, p0, p0 + [0.0, 0.1, 0.0], n=20)
    clock.now += 5.0  # idle: not on the timeline
    drag_line(s, s.tool_position, s.tool_position + [0.0, 0.0, 0.1], n=20)
    s.stop()
    rec, m = s.recorded, s.motion(400)
    s.speed = 2.0
    d = s.motion_duration
    assert d == pytest.approx(rec.t[-1] / 2.0)
    start, end = s.at(0.0), s.at(d)
    np.testing.assert_allclose(start["q_recorded"], rec.q[0])
    np.testing.assert_allclose(start["q_motion"], m.q[0])
    np.testing.assert_allclose(end["q_recorded"], rec.q[-1])
    np.testing.assert_allclose(end["q_motion"], m.q[-1], atol=1e-6)
    # half way along the motion is half way along the recording (its time 0.5 * d * speed)
    mid = s.at(0.5 * d)
    want = [np.interp(0.5 * rec.t[-1], rec.t, rec.q[:, j]) for j in range(4)]
    np.testing.assert_allclose(mid["q_recorded"], want)
    k = np.searchsorted(m.t, 0.5 * rec.t[-1])
    assert np.abs(mid["q_motion"] - m.q[k]).max() < 0.02
    np.testing.assert_allclose(s.at(d + 10.0)["q_motion"], end["q_motion"])  # clipped
    with pytest.raises(ValueError, match="t must be a finite number"):
        s.at(float("nan"))
    s.close()


def test_at_without_a_recording_has_only_the_motion():
    s = TeachSession(robot="sawyer", scene=None, clock=FakeClock(), mode="2d")
    s.add_keyframe()
    assert s.move_to(s.tool_position + [0.1, 0.0, 0.0]).accepted
    s.add_keyframe()
    out = s.at(0.5 * s.motion_duration)
    assert out["q_recorded"] is None and out["q_motion"].shape == (7,)
    s.close()
