"""The recording of a teach session: the state machine ``idle -> recording -> done`` and its samples.

In 3-D mode the recording is the accepted drag samples (time, configuration, tool
position); in 2-D mode it is the path through the stored waypoints, minimum-jerk segments
timed by ``panel_speed`` (each at least 0.5 s, sampled at 50 Hz). :class:`Recorder` holds the
state; the session (:class:`~lfd.teach.session.TeachSession`) calls :meth:`Recorder.begin`,
:meth:`Recorder.append`, :meth:`Recorder.add_waypoint` and :meth:`Recorder.finish` and reads
:attr:`Recorder.recorded`. Units: s, rad, m.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from lfd.robots import ChainKinematics

from .results import Recording

__all__ = ["Recorder", "waypoint_path"]


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


class Recorder:
    """Recording state and its transitions (see the module docstring).

    Args:
        kin: the arm's kinematics (tool positions of the samples).
        n_dof: joints of the arm.
        panel_speed: rad/s timing the 2-D waypoint segments (> 0).
        clock: function returning seconds (sample times).

    Attributes:
        state: ``"idle"``, ``"recording"`` or ``"done"``. end_reason: ``"goal"``, ``"stop"`` or None.
        mode: the mode the recording was begun in (``"3d"`` or ``"2d"``), None while idle.
    """

    def __init__(
        self, kin: ChainKinematics, n_dof: int, panel_speed: float, clock: Callable[[], float]
    ) -> None:
        self.kin, self.n_dof, self.panel_speed, self.clock = kin, int(n_dof), float(panel_speed), clock
        self.reset()

    def reset(self) -> None:
        """Forget everything: back to ``idle``."""
        self.state = "idle"
        self.mode: str | None = None
        self._t: list[float] = []
        self._q: list[np.ndarray] = []
        self._tool: list[np.ndarray] = []
        self._waypoints: list[np.ndarray] = []
        self._t0 = 0.0
        self.end_reason: str | None = None

    def begin(self, q: np.ndarray, mode: str) -> None:
        """Start recording from the configuration ``q (n,)`` rad: the first drag sample (``"3d"``) or
        waypoint 0 (``"2d"``)."""
        self.state, self.mode = "recording", mode
        self._t0 = self.clock()
        if mode == "3d":
            self._t, self._q, self._tool = [0.0], [q.copy()], [self.kin.tool_position(q)]
        else:
            self._waypoints = [q.copy()]

    def append(self, q: np.ndarray) -> None:
        """One accepted drag sample at the clock's time (kept strictly increasing)."""
        t = self.clock() - self._t0
        if self._t and t <= self._t[-1]:
            t = self._t[-1] + 1e-3
        self._t.append(float(t))
        self._q.append(q.copy())
        self._tool.append(self.kin.tool_position(q))

    def add_waypoint(self, q: np.ndarray) -> None:
        """Store ``q (n,)`` rad as the next 2-D waypoint."""
        self._waypoints.append(q.copy())

    @property
    def last_waypoint(self) -> np.ndarray | None:
        """The last stored waypoint (n,) rad, None before any."""
        return self._waypoints[-1].copy() if self._waypoints else None

    def finish(self, reason: str) -> None:
        """End the recording (``reason``: ``"goal"`` or ``"stop"``)."""
        self.state = "done"
        self.end_reason = reason

    def stop(self) -> None:
        """End the recording if one is in progress (the Stop button)."""
        if self.state == "recording":
            self.finish("stop")

    @property
    def samples(self) -> int:
        """Drag samples (3-D) or stored waypoints (2-D) so far."""
        return len(self._waypoints) if self.mode == "2d" else len(self._t)

    @property
    def recorded(self) -> Recording:
        """The demonstration so far: drag samples (3-D) or the waypoint path (2-D)."""
        if self.mode == "2d":
            t, q = waypoint_path(self._waypoints, self.n_dof, self.panel_speed)
            tool = np.array([self.kin.tool_position(x) for x in q]).reshape(-1, 3)
        else:
            t, q = np.array(self._t, dtype=float), np.array(self._q, dtype=float).reshape(-1, self.n_dof)
            tool = np.array(self._tool, dtype=float).reshape(-1, 3)
        return Recording(t, q, tool)

    @property
    def waypoints(self) -> np.ndarray:
        """(W, n) stored waypoints of the 2-D panel, rad."""
        return np.array(self._waypoints, dtype=float).reshape(-1, self.n_dof)

    def playback(self, rate: float = 30.0) -> np.ndarray:
        """(F, n) configurations replaying the recording in real time at ``rate`` frames/s."""
        rec = self.recorded
        if len(rec) == 0:
            return np.zeros((0, self.n_dof))
        if len(rec) == 1:
            return rec.q.copy()
        times = np.arange(0.0, rec.t[-1] + 1e-9, 1.0 / rate)
        return np.stack([np.interp(times, rec.t, rec.q[:, j]) for j in range(self.n_dof)], axis=1)
