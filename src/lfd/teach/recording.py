"""The recording state machine of a teach session (``idle -> recording -> done``).

In 3-D mode the recording is the accepted drag samples (time, configuration, tool
position); in 2-D mode it is the path through the stored waypoints, minimum-jerk segments
timed by the session's ``panel_speed`` (each at least 0.5 s, sampled at 50 Hz).
:class:`RecordingMixin` holds the state; :class:`~lfd.teach.session.TeachSession` provides
``clock``, ``kin``, ``q``, ``n_dof``, ``tool_position``, ``panel_speed`` and ``_mode``.
"""

from __future__ import annotations

import math

import numpy as np

from .results import Recording

__all__ = ["RecordingMixin", "waypoint_path"]


def _min_jerk(s: np.ndarray) -> np.ndarray:
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def waypoint_path(
    waypoints: list[np.ndarray], n_dof: int, speed: float, rate: float = 50.0
) -> tuple[np.ndarray, np.ndarray]:
    """Times ``(N,)`` s and configurations ``(N, n_dof)`` rad of the minimum-jerk path through
    ``waypoints``: each segment lasts ``max(largest joint change / speed, 0.5)`` s, sampled
    at ``rate`` Hz. Fewer than two waypoints: themselves at times ``0, 1, ...``."""
    if len(waypoints) < 2:
        q = np.array(waypoints, dtype=float).reshape(-1, n_dof)
        return np.arange(len(q), dtype=float), q
    ts, qs, t0 = [0.0], [waypoints[0]], 0.0
    for a, b in zip(waypoints[:-1], waypoints[1:], strict=True):
        duration = max(float(np.max(np.abs(b - a))) / speed, 0.5)
        k = max(int(math.ceil(duration * rate)), 2)
        s = np.linspace(0.0, 1.0, k + 1)[1:]
        seg = a + _min_jerk(s)[:, None] * (b - a)
        ts.extend((t0 + s * duration).tolist())
        qs.extend(seg)
        t0 += duration
    return np.array(ts), np.array(qs)


class RecordingMixin:
    """Recording state and its transitions (see the module docstring)."""

    def _reset_recording(self) -> None:
        self.recording_state = "idle"  # idle -> recording -> done
        self._t: list[float] = []
        self._q: list[np.ndarray] = []
        self._tool: list[np.ndarray] = []
        self._waypoints: list[np.ndarray] = []
        self._t0 = 0.0
        self.end_reason: str | None = None

    def _append(self, q: np.ndarray) -> None:
        t = self.clock() - self._t0
        if self._t and t <= self._t[-1]:
            t = self._t[-1] + 1e-3
        self._t.append(float(t))
        self._q.append(q.copy())
        self._tool.append(self.kin.tool_position(q))

    def _begin(self) -> None:
        self.recording_state = "recording"
        self._t0 = self.clock()
        if self._mode == "3d":
            self._t, self._q, self._tool = [0.0], [self.q.copy()], [self.tool_position]
        else:
            self._waypoints = [self.q.copy()]

    def _finish(self, reason: str) -> None:
        self.recording_state = "done"
        self.end_reason = reason

    def stop(self) -> None:
        """End the recording (the Stop button)."""
        if self.recording_state == "recording":
            self._finish("stop")

    @property
    def recorded(self) -> Recording:
        """The demonstration so far: drag samples (3-D) or the waypoint path (2-D)."""
        if self._mode == "2d":
            t, q = self._waypoint_path(self._waypoints)
            tool = np.array([self.kin.tool_position(x) for x in q]).reshape(-1, 3)
        else:
            t, q = np.array(self._t, dtype=float), np.array(self._q, dtype=float).reshape(-1, self.n_dof)
            tool = np.array(self._tool, dtype=float).reshape(-1, 3)
        return Recording(t, q, tool)

    @property
    def waypoints(self) -> np.ndarray:
        """(W, n) stored waypoints of the 2-D panel, rad."""
        return np.array(self._waypoints, dtype=float).reshape(-1, self.n_dof)

    def _waypoint_path(
        self, waypoints: list[np.ndarray], rate: float = 50.0
    ) -> tuple[np.ndarray, np.ndarray]:
        return waypoint_path(waypoints, self.n_dof, self.panel_speed, rate)

    def playback(self, rate: float = 30.0) -> np.ndarray:
        """(F, n) configurations replaying the recording in real time at ``rate`` frames/s."""
        rec = self.recorded
        if len(rec) == 0:
            return np.zeros((0, self.n_dof))
        if len(rec) == 1:
            return rec.q.copy()
        times = np.arange(0.0, rec.t[-1] + 1e-9, 1.0 / rate)
        return np.stack([np.interp(times, rec.t, rec.q[:, j]) for j in range(self.n_dof)], axis=1)
