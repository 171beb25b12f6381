"""The recording of a teach session: the state machine ``idle -> recording -> done`` and its samples.

In 3-D mode the recording is the accepted drag samples (time, configuration, tool
position); in 2-D mode it is the path through the stored waypoints, minimum-jerk segments
timed by ``panel_speed`` (each at least 0.5 s, sampled at 50 Hz). :class:`Recorder` holds the
state; the session (:class:`~lfd.teach.session.TeachSession`) calls :meth:`Recorder.begin`,
:meth:`Recorder.append`, :meth:`Recorder.add_waypoint` and :meth:`Recorder.finish` and reads
:attr:`Recorder.recorded`. Units: s, rad, m.

**Idle time.** A user who stops to look, or holds the gizmo still, adds time but no motion; the drag
samples then have long gaps or repeat one configuration. :func:`trim_idle` removes that time:
:attr:`Recorder.recorded` is the trimmed recording (3-D mode, unless ``trim_idle=False``) and
:attr:`Recorder.recorded_raw` the samples as the clock stamped them.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from lfd.robots import ChainKinematics

from .results import Recording

__all__ = ["Recorder", "trim_idle", "waypoint_path", "waypoint_times"]


def _min_jerk(s: np.ndarray) -> np.ndarray:
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def waypoint_times(waypoints, speed: float) -> np.ndarray:
    """``(W,)`` s: when the minimum-jerk path of :func:`waypoint_path` passes each of ``waypoints``
    ``(W, n)`` rad (0 for the first; each segment lasts ``max(largest joint change / speed, 0.5)`` s)."""
    w = np.asarray(waypoints, dtype=float)
    if len(w) < 2:
        return np.zeros(len(w))
    durations = np.maximum(np.max(np.abs(np.diff(w, axis=0)), axis=1) / speed, 0.5)
    return np.concatenate([[0.0], np.cumsum(durations)])


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
    knots = waypoint_times(waypoints, speed)
    for a, b, duration in zip(waypoints[:-1], waypoints[1:], np.diff(knots), strict=True):
        duration = float(duration)
        k = max(int(math.ceil(duration * rate)), 2)
        s = np.linspace(0.0, 1.0, k + 1)[1:]
        seg = a + _min_jerk(s)[:, None] * (b - a)
        ts.extend((t0 + s * duration).tolist())
        qs.extend(seg)
        t0 += duration
    return np.array(ts), np.array(qs)


def trim_idle(rec: Recording, idle_speed: float) -> tuple[Recording, np.ndarray]:
    """``rec`` without its idle time, and the trimmed time of each of its samples.

    Between two consecutive samples the arm's speed is the largest joint change (rad, continuous joints the
    short way round) over the time between them. Where it is below ``idle_speed`` (rad/s, > 0) the stretch
    is idle and is shortened to ``change / idle_speed`` s: a pause (no updates for seconds) or a gizmo held
    still (updates that repeat one configuration) takes no time, a slow crawl is sped up to ``idle_speed``.
    A sample that does not move the arm at all ends up at its predecessor's time and is left out, so the
    times stay strictly increasing and no two rows repeat a time. Moving stretches keep their timing.

    Args:
        rec: a recording (``t`` (N,) s strictly increasing, ``q`` (N, n) rad, ``tool`` (N, 3) m).
        idle_speed: rad/s, > 0.

    Returns:
        ``(trimmed, times)``: the trimmed :class:`~lfd.teach.results.Recording` (from 0, strictly
        increasing, first and last samples kept) and ``times`` (N,) s, the trimmed time of every sample of
        ``rec`` (a left-out sample gets its predecessor's time).

    Raises:
        ValueError: ``idle_speed`` not a finite number > 0.
    """
    if not (math.isfinite(idle_speed) and idle_speed > 0):
        raise ValueError(f"idle_speed must be a finite number > 0 (rad/s), got {idle_speed!r}")
    if len(rec) < 2:
        return rec, rec.t - (rec.t[0] if len(rec) else 0.0)
    d = np.diff(rec.q, axis=0)
    change = np.max(np.abs(np.arctan2(np.sin(d), np.cos(d))), axis=1)
    dt = np.minimum(np.diff(rec.t), change / idle_speed)
    times = np.concatenate([[0.0], np.cumsum(dt)])
    keep = np.concatenate([[True], dt > 1e-9])
    last_kept = int(np.flatnonzero(keep)[-1])
    if 0 < last_kept < len(keep) - 1:  # the last samples repeat that one: keep the very last instead
        keep[last_kept], keep[-1] = False, True
    return Recording(times[keep], rec.q[keep], rec.tool[keep]), times


class Recorder:
    """Recording state and its transitions (see the module docstring).

    Args:
        kin: the arm's kinematics (tool positions of the samples).
        n_dof: joints of the arm.
        panel_speed: rad/s timing the 2-D waypoint segments (> 0).
        clock: function returning seconds (sample times).
        trim_idle: :attr:`recorded` leaves out idle time (3-D mode; :func:`trim_idle`).
        idle_speed: rad/s, the speed below which the arm counts as idle.

    Attributes:
        state: ``"idle"``, ``"recording"`` or ``"done"``. end_reason: ``"goal"``, ``"stop"`` or None.
        mode: the mode the recording was begun in (``"3d"`` or ``"2d"``), None while idle.
    """

    def __init__(
        self,
        kin: ChainKinematics,
        n_dof: int,
        panel_speed: float,
        clock: Callable[[], float],
        trim_idle: bool = True,
        idle_speed: float = 0.02,
    ) -> None:
        self.kin, self.n_dof, self.panel_speed, self.clock = kin, int(n_dof), float(panel_speed), clock
        self.trim_idle, self.idle_speed = bool(trim_idle), float(idle_speed)
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

    def restore(self, mode: str, t, q, waypoints, end_reason: str | None) -> None:
        """Put back a finished recording (reopening an export): ``mode`` ``"3d"`` with the raw drag samples
        ``t`` (N,) s and ``q`` (N, n) rad, or ``"2d"`` with ``waypoints`` (W, n) rad; state ``"done"``.

        Raises:
            ValueError: shapes that do not fit ``n_dof``, times not strictly increasing from 0, NaN.
        """
        self.reset()
        t = np.asarray(t, dtype=float).reshape(-1)
        q = np.asarray(q, dtype=float).reshape(-1, self.n_dof) if np.size(q) else np.zeros((0, self.n_dof))
        w = np.asarray(waypoints, dtype=float)
        w = w.reshape(-1, self.n_dof) if w.size else np.zeros((0, self.n_dof))
        if len(t) != len(q) or not (
            np.all(np.isfinite(q)) and np.all(np.isfinite(t)) and np.all(np.isfinite(w))
        ):
            raise ValueError(
                f"recording: t ({len(t)},) and q ({len(q)}, {self.n_dof}) must be finite and match"
            )
        if len(t) and (t[0] != 0.0 or np.any(np.diff(t) <= 0)):
            raise ValueError("recording: t must start at 0 and increase strictly")
        if mode == "idle" or (mode == "3d" and len(t) == 0) or (mode == "2d" and len(w) == 0):
            return
        self.mode, self.state, self.end_reason = mode, "done", end_reason
        if mode == "3d":
            self._t, self._q = [float(x) for x in t], [x.copy() for x in q]
            self._tool = [self.kin.tool_position(x) for x in q]
        else:
            self._waypoints = [x.copy() for x in w]

    @property
    def recorded_raw(self) -> Recording:
        """The demonstration so far as recorded: every drag sample at its clock time (3-D), or the waypoint
        path (2-D, the same as :attr:`recorded`)."""
        if self.mode == "2d":
            t, q = waypoint_path(self._waypoints, self.n_dof, self.panel_speed)
            tool = np.array([self.kin.tool_position(x) for x in q]).reshape(-1, 3)
        else:
            t, q = np.array(self._t, dtype=float), np.array(self._q, dtype=float).reshape(-1, self.n_dof)
            tool = np.array(self._tool, dtype=float).reshape(-1, 3)
        return Recording(t, q, tool)

    @property
    def recorded(self) -> Recording:
        """The demonstration so far: drag samples (3-D) without idle time (:func:`trim_idle`, unless
        ``trim_idle`` is off) or the waypoint path (2-D)."""
        raw = self.recorded_raw
        if self.mode == "2d" or not self.trim_idle:
            return raw
        return trim_idle(raw, self.idle_speed)[0]

    def raw_times(self) -> np.ndarray:
        """(N,) s: the time of each raw sample in :attr:`recorded` (trimmed when trimming is on)."""
        raw = self.recorded_raw
        if self.mode == "2d" or not self.trim_idle:
            return raw.t.copy()
        return trim_idle(raw, self.idle_speed)[1]

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
