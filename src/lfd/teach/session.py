"""The teach session: everything the browser interface does, without a browser.

A :class:`TeachSession` holds the arm's configuration, the scene, the recording and
the counters. The viser server (:mod:`lfd.teach.server`) only forwards the user's
actions to it and draws its state; scripts and tests call it directly.

**3-D mode** (the gizmo): :meth:`TeachSession.drag` moves the tool towards a target by
bounded-time IK (:class:`~lfd.teach.drag_ik.DragIK`). An update is *refused* (the arm
stays at its last accepted configuration) when the IK step would change a joint by more
than ``max_joint_step`` rad, when the target is out of reach and the best-effort pose
is no closer to it, or when the new configuration is in collision (arm - obstacle, arm -
table, self) anywhere on its joint-space segment from the last accepted configuration
(checked every ``sweep_resolution`` rad, so a fast drag cannot pass through a thin wall). Recording starts on the first accepted drag (its first sample is the
configuration before it) and ends when the tool enters the goal region or on
:meth:`stop`.

**2-D panel** (the baseline): :meth:`set_joints` (the sliders) and :meth:`move_to` (the
x/y/z entry, IK) move the arm, with the same collision rule; :meth:`store` appends the
current configuration as a waypoint, refused when the joint-space segment from the
previous waypoint passes through a collision; the recording is the waypoint path
(minimum-jerk segments timed by ``panel_speed``). Recording starts on the first arm
motion of the panel and ends when a stored waypoint puts the tool in the goal, or on
:meth:`stop`.

**Collisions** counts collision *events*: runs of consecutive refused updates count as
one (the user pushing into an obstacle for 20 updates made one collision);
``counters["refused_collision"]`` counts every refused update.

Example::

    >>> import numpy as np
    >>> from lfd.teach import TeachSession
    >>> scene = {"goal": {"center": [0.35, 0.25, 0.55], "radius": 0.05}}
    >>> s = TeachSession(robot="wam4", scene=scene, clock=iter(np.arange(0, 100, 0.05)).__next__)
    >>> start = s.tool_position
    >>> for a in np.linspace(0, 1, 30)[1:]:
    ...     r = s.drag(start + a * (np.array([0.35, 0.25, 0.55]) - start))
    >>> r.accepted, r.reached_goal, s.recording_state, s.collisions
    (True, True, 'done', 0)
    >>> s.recorded.q.shape           # the start + one sample per update until the goal
    (25, 4)
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from lfd.robots import ChainKinematics, available_robots, load_robot
from lfd.sim.collision import CollisionWorld

from .drag_ik import DragIK, IKStep
from .scene import Box, TeachScene, load_scene

__all__ = ["TEACH_ROBOTS", "DragResult", "Recording", "TeachSession"]

#: Catalogue robots the teach interface supports.
TEACH_ROBOTS = ("wam4", "pr2_right_arm", "sawyer")
MODES = ("3d", "2d")


@dataclass(frozen=True)
class DragResult:
    """Outcome of one drag update (or panel move).

    Attributes:
        accepted: the arm moved to the new configuration.
        q: (n,) configuration after the update (the old one when refused), rad.
        in_collision: the candidate configuration was in collision (so it was refused).
        reached_goal: the tool is inside the goal region after the update.
        reachable: IK put the tool on the target (False: workspace boundary, best effort).
        reason: ``"ok"``, ``"best_effort"`` (accepted, target out of reach),
            ``"collision"``, ``"joint_jump"``, ``"unreachable"``.
        tool: (3,) tool position after the update, m.
        target: (3,) requested tool position, m.
        latency: seconds spent in IK + collision check.
        detail: collision kind or IK note, for the UI.
    """

    accepted: bool
    q: np.ndarray
    in_collision: bool
    reached_goal: bool
    reachable: bool = True
    reason: str = "ok"
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    latency: float = 0.0
    detail: str = ""


@dataclass(frozen=True)
class Recording:
    """A recorded demonstration: ``t`` (N,) s from 0, strictly increasing; ``q`` (N, n) rad;
    ``tool`` (N, 3) m (tool positions, base frame)."""

    t: np.ndarray
    q: np.ndarray
    tool: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def path_length(self) -> float:
        """Length of the tool path, m."""
        return float(np.linalg.norm(np.diff(self.tool, axis=0), axis=1).sum()) if len(self) > 1 else 0.0


def _min_jerk(s: np.ndarray) -> np.ndarray:
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


class TeachSession:
    """Session logic of the teach interface (see the module docstring).

    Args:
        robot: catalogue name, one of :data:`TEACH_ROBOTS`.
        scene: YAML path, dict (see :mod:`lfd.teach.scene`), a ``TeachScene`` or None.
        mode: ``"3d"`` (drag) or ``"2d"`` (panel); switchable while nothing is recorded.
        ik_time_budget: seconds per drag IK (default 0.02).
        max_joint_step: largest joint change one drag update may make, rad (default 0.5).
        wam_q3: WAM joint 3 ``"fixed"`` (closed form) or ``"free"`` (LM).
        margin: collision clearance, m.
        panel_speed: joint speed (rad/s) that times the 2-D waypoint segments.
        clock: function returning seconds (default ``time.monotonic``); scripted users
            pass a simulated clock.
        validate: check the scene against the robot (see :meth:`TeachScene` checks).
        sweep_resolution: every move is collision-checked along its joint-space
            segment at this spacing (rad of the largest joint change), not only at its end.

    Raises:
        ValueError: unknown robot, bad scene (field named), start pose outside the
            limits or in collision, an obstacle overlapping the robot base, a goal out of
            reach.
    """

    def __init__(
        self,
        robot: str = "wam4",
        scene=None,
        *,
        mode: str = "3d",
        ik_time_budget: float = 0.02,
        max_joint_step: float = 0.5,
        wam_q3: str = "fixed",
        margin: float = 0.0,
        panel_speed: float = 0.6,
        clock: Callable[[], float] | None = None,
        validate: bool = True,
        sweep_resolution: float = 0.01,
    ) -> None:
        if robot not in TEACH_ROBOTS:
            known = ", ".join(TEACH_ROBOTS)
            extra = (
                "" if robot not in available_robots() else " (it is in the catalogue but not a teachable arm)"
            )
            raise ValueError(f"unknown robot {robot!r}{extra}; choose one of: {known}")
        if mode not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
        if not max_joint_step > 0 or not panel_speed > 0:
            raise ValueError("max_joint_step and panel_speed must be positive")
        self.robot_name = robot
        self.robot = load_robot(robot)
        self.scene: TeachScene = load_scene(scene)
        self.kin = ChainKinematics(self.robot.spec)
        self.ik = DragIK(self.robot, time_budget=ik_time_budget, wam_q3=wam_q3)
        self.max_joint_step = float(max_joint_step)
        self.panel_speed = float(panel_speed)
        if not sweep_resolution > 0:
            raise ValueError("sweep_resolution must be positive (rad)")
        self.sweep_resolution = float(sweep_resolution)
        self.clock = clock or time.monotonic
        self._mode = mode
        n = self.robot.n_dof
        start = self.robot.home.numpy() if self.scene.start is None else self.scene.start
        if start.shape != (n,):
            raise ValueError(
                f"scene field 'start' must have {n} joint angles for {robot}, got {start.shape[0]}"
            )
        self.start = np.asarray(start, dtype=float)
        self.checker = CollisionWorld(self.robot, self.scene.obstacles, self.scene.table_z, margin)
        if validate:
            self._validate()
        self.q = self.start.copy()
        self.collisions = 0
        self.counters: dict[str, int] = {
            "drag_updates": 0,
            "accepted": 0,
            "refused_collision": 0,
            "refused_jump": 0,
            "refused_unreachable": 0,
            "best_effort": 0,
            "panel_moves": 0,
            "stores": 0,
            "refused_stores": 0,
        }
        self.latencies: list[float] = []
        self._refusing = False
        self._reset_recording()
        self.last_send = None

    # ------------------------------------------------------------------ validation
    def _validate(self) -> None:
        spec = self.robot.spec
        bad = np.where(
            ~spec.continuous & ((self.start < spec.lower - 1e-9) | (self.start > spec.upper + 1e-9))
        )[0]
        if bad.size:
            j = int(bad[0])
            raise ValueError(
                f"scene field 'start': joint {j} = {self.start[j]:.3f} rad is outside [{spec.lower[j]:.3f}, {spec.upper[j]:.3f}]"
            )
        for i, box in enumerate(self.scene.obstacles):
            if self.checker.base_overlaps(box):
                raise ValueError(
                    f"scene field 'obstacles[{i}]' overlaps the robot base (centre {box.center.tolist()})"
                )
        report = self.checker.check(self.start)
        if report.in_collision:
            raise ValueError(
                f"scene field 'start': the start pose is in collision ({report.kind}: {report.detail})"
            )
        goal = self.scene.goal
        if goal is not None:
            res = self.robot.ik(goal.center[None], restarts=64, tol_pos=1e-3)
            if float(res.pos_error[0]) > goal.radius:
                raise ValueError(
                    f"scene field 'goal': unreachable for {self.robot_name}: no configuration within the joint limits "
                    f"puts the tool within {goal.radius} m of {goal.center.tolist()} (closest {float(res.pos_error[0]):.3f} m)"
                )

    # ------------------------------------------------------------------ state
    @property
    def mode(self) -> str:
        """``"3d"`` or ``"2d"``; can be changed only while nothing is recorded."""
        return self._mode

    @mode.setter
    def mode(self, value: str) -> None:
        if value not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {value!r}")
        if value != self._mode and self.recording_state != "idle":
            raise ValueError("clear() the recording before switching mode")
        self._mode = value

    @property
    def n_dof(self) -> int:
        return self.robot.n_dof

    @property
    def tool_position(self) -> np.ndarray:
        """(3,) current tool position, m."""
        return self.kin.tool_position(self.q)

    @property
    def in_goal(self) -> bool:
        return self.scene.goal is not None and self.scene.goal.contains(self.tool_position)

    def _reset_recording(self) -> None:
        self.recording_state = "idle"  # idle -> recording -> done
        self._t: list[float] = []
        self._q: list[np.ndarray] = []
        self._tool: list[np.ndarray] = []
        self._waypoints: list[np.ndarray] = []
        self._t0 = 0.0
        self.end_reason: str | None = None

    def clear(self) -> None:
        """Forget the recording (and the last Send) and put the arm back at the start
        (counters kept: they count the whole session)."""
        self._reset_recording()
        self.last_send = None
        self.q = self.start.copy()
        self._refusing = False

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
        if len(waypoints) < 2:
            q = np.array(waypoints, dtype=float).reshape(-1, self.n_dof)
            return np.arange(len(q), dtype=float), q
        ts, qs, t0 = [0.0], [waypoints[0]], 0.0
        for a, b in zip(waypoints[:-1], waypoints[1:], strict=True):
            duration = max(float(np.max(np.abs(b - a))) / self.panel_speed, 0.5)
            k = max(int(math.ceil(duration * rate)), 2)
            s = np.linspace(0.0, 1.0, k + 1)[1:]
            seg = a + _min_jerk(s)[:, None] * (b - a)
            ts.extend((t0 + s * duration).tolist())
            qs.extend(seg)
            t0 += duration
        return np.array(ts), np.array(qs)

    # ------------------------------------------------------------------ shared rule
    def _refuse(
        self, reason: str, target, step: IKStep | None, latency: float, detail: str = ""
    ) -> DragResult:
        if reason == "collision":
            self.counters["refused_collision"] += 1
            if not self._refusing:
                self.collisions += 1
            self._refusing = True
        else:
            self.counters[f"refused_{'jump' if reason == 'joint_jump' else 'unreachable'}"] += 1
        return DragResult(
            False,
            self.q.copy(),
            reason == "collision",
            self.in_goal,
            reachable=bool(step.reached) if step is not None else True,
            reason=reason,
            tool=self.tool_position,
            target=np.asarray(target, dtype=float),
            latency=latency,
            detail=detail,
        )

    def _check_vector(self, x, length: int, name: str) -> np.ndarray:
        try:
            arr = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be {length} numbers, got {x!r}") from None
        if arr.shape != (length,):
            raise ValueError(f"{name} must have shape ({length},), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} contains NaN or inf: {arr.tolist()}")
        return arr

    def _sweep(self, q_from: np.ndarray, q_to: np.ndarray):
        """Collision report of the straight joint-space motion ``q_from -> q_to``, checked
        every ``sweep_resolution`` rad of the largest joint change (end included), so
        one update cannot jump through a thin obstacle."""
        steps = max(1, int(math.ceil(float(np.max(np.abs(q_to - q_from))) / self.sweep_resolution)))
        for s in np.linspace(0.0, 1.0, steps + 1)[1:][::-1]:  # the end first: most refusals are there
            report = self.checker.check(q_from + s * (q_to - q_from))
            if report.in_collision:
                return report
        return report

    # ------------------------------------------------------------------ 3-D mode
    def drag(self, position, orientation=None) -> DragResult:
        """One gizmo update: move the tool towards ``position`` (3,) m (base frame).

        ``orientation`` ((3, 3) rotation or quaternion wxyz) is followed by 6+ DoF arms.
        See the module docstring for when an update is refused. Raises ``ValueError``
        in 2-D mode or for a malformed position.
        """
        if self._mode != "3d":
            raise ValueError(
                "drag() is the 3-D mode's action; this session is in mode '2d' (use set_joints/move_to)"
            )
        target = self._check_vector(position, 3, "position")
        tic = time.perf_counter()
        self.counters["drag_updates"] += 1
        step = self.ik.solve(self.q, target, orientation)
        current_error = float(np.linalg.norm(self.tool_position - target))
        if step.jump > self.max_joint_step:
            return self._refuse(
                "joint_jump", target, step, time.perf_counter() - tic, f"joint change {step.jump:.2f} rad"
            )
        if not step.reached and step.error >= current_error - 1e-6:
            return self._refuse("unreachable", target, step, time.perf_counter() - tic, "target out of reach")
        report = self._sweep(self.q, step.q)
        latency = time.perf_counter() - tic
        self.latencies.append(latency)
        if report.in_collision:
            return self._refuse("collision", target, step, latency, report.kind or "")
        return self._accept(step.q, target, step.reached, latency)

    def _accept(self, q: np.ndarray, target, reachable: bool, latency: float) -> DragResult:
        self._refusing = False
        self.counters["accepted"] += 1
        if not reachable:
            self.counters["best_effort"] += 1
        if self.recording_state == "idle":
            self._begin()
        self.q = q.copy()
        if self._mode == "3d" and self.recording_state == "recording":
            self._append(self.q)
        goal = self.in_goal
        if goal and self._mode == "3d" and self.recording_state == "recording":
            self._finish("goal")
        return DragResult(
            True,
            self.q.copy(),
            False,
            goal,
            reachable=reachable,
            reason="ok" if reachable else "best_effort",
            tool=self.tool_position,
            target=np.asarray(target, dtype=float),
            latency=latency,
        )

    # ------------------------------------------------------------------ 2-D panel
    def set_joints(self, q) -> DragResult:
        """The sliders: put the arm at ``q`` (n,) rad if it is collision-free (else refused).

        Raises:
            ValueError: wrong length, NaN, a joint outside its limits (named).
        """
        q = self._check_vector(q, self.n_dof, "q")
        spec = self.robot.spec
        for j in range(self.n_dof):
            if not spec.continuous[j] and not spec.lower[j] - 1e-9 <= q[j] <= spec.upper[j] + 1e-9:
                raise ValueError(
                    f"joint {j} ({spec.joint_names[j]}) = {q[j]:.4f} rad is outside [{spec.lower[j]:.4f}, {spec.upper[j]:.4f}]"
                )
        q = self.ik._clamp(q)
        tic = time.perf_counter()
        self.counters["panel_moves"] += 1
        report = self._sweep(self.q, q)
        latency = time.perf_counter() - tic
        target = self.kin.tool_position(q)
        if report.in_collision:
            return self._refuse("collision", target, None, latency, report.kind or "")
        return self._accept(q, target, True, latency)

    def move_to(self, position, orientation=None) -> DragResult:
        """The x/y/z entry: IK (from the current configuration, with restarts if that
        fails) to ``position`` (3,) m, then the same rule as :meth:`set_joints`;
        refused (``"unreachable"``) when no configuration reaches it within 1 mm."""
        target = self._check_vector(position, 3, "position")
        tic = time.perf_counter()
        rot = None if orientation is None else orientation
        step = DragIK(self.robot, time_budget=0.2, wam_q3=self.ik.wam_q3).solve(self.q, target, rot)
        if not step.reached:
            res = self.robot.ik(target[None], self.q[None], restarts=32, tol_pos=1e-4)
            if bool(res.success[0]):
                step = IKStep(res.q[0].numpy(), True, float(res.pos_error[0]), 0.0, 0, False, "lm")
        if not step.reached:
            self.counters["panel_moves"] += 1
            return self._refuse("unreachable", target, step, time.perf_counter() - tic, "no IK solution")
        result = self.set_joints(step.q)
        return result

    def store(self) -> bool:
        """Store the current configuration as a waypoint (2-D). Returns False (and counts a
        collision) when the joint-space segment from the previous waypoint collides."""
        if self._mode != "2d":
            raise ValueError("store() is the 2-D panel's action; this session is in mode '3d'")
        if self.recording_state == "done":
            return False
        if self.recording_state == "idle":
            self._begin()
        self.counters["stores"] += 1
        if self._sweep(self._waypoints[-1], self.q).in_collision:
            self.counters["refused_stores"] += 1
            self._refuse("collision", self.tool_position, None, 0.0, "segment")
            return False
        self._refusing = False
        self._waypoints.append(self.q.copy())
        if self.in_goal:
            self._finish("goal")
        return True

    def go_home(self) -> None:
        """Put the arm back at the scene's start pose (not recorded)."""
        self.q = self.start.copy()

    # ------------------------------------------------------------------ scene edits
    def add_obstacle(self, center, size, yaw_deg: float = 0.0) -> Box:
        """Add a box obstacle (the UI's "Add box"); refused with ``ValueError`` when it
        overlaps the robot base or the arm where it stands now."""
        box = Box(
            self._check_vector(center, 3, "center"),
            self._check_vector(size, 3, "size"),
            math.radians(float(yaw_deg)),
        )
        if np.any(box.size <= 0):
            raise ValueError(f"size must be positive (m), got {box.size.tolist()}")
        if self.checker.base_overlaps(box):
            raise ValueError(f"obstacle at {box.center.tolist()} overlaps the robot base")
        self.checker.add_obstacle(box)
        if self.checker.check(self.q).in_collision:
            self.checker.remove_obstacle(box)
            raise ValueError(f"obstacle at {box.center.tolist()} overlaps the arm in its current pose")
        self.scene = self.scene.with_obstacle(box)
        return box

    # ------------------------------------------------------------------ playback, export, send
    def playback(self, rate: float = 30.0) -> np.ndarray:
        """(F, n) configurations replaying the recording in real time at ``rate`` frames/s."""
        rec = self.recorded
        if len(rec) == 0:
            return np.zeros((0, self.n_dof))
        if len(rec) == 1:
            return rec.q.copy()
        times = np.arange(0.0, rec.t[-1] + 1e-9, 1.0 / rate)
        return np.stack([np.interp(times, rec.t, rec.q[:, j]) for j in range(self.n_dof)], axis=1)

    def fit_dmp(self, n_samples: int = 200, n_basis: int = 30):
        """Fit a DMP to the recording resampled on a uniform grid (see :mod:`lfd.teach.export`)."""
        from .export import fit_recording_dmp

        return fit_recording_dmp(self.recorded, n_samples=n_samples, n_basis=n_basis)

    def export(self, out_dir) -> dict:
        """Write ``demo.csv``, ``demo.json``, ``demo.dmp.json`` and ``episode.npz`` to
        ``out_dir``; returns ``{"csv", "json", "dmp", "episode"}`` paths."""
        from .export import export_session

        return export_session(self, out_dir)

    def send(self):
        """Fit the DMP, run it on the simulated arm in PyBullet; returns a
        :class:`~lfd.teach.export.SendResult` (also kept as ``last_send``)."""
        from .export import send_session

        self.last_send = send_session(self)
        return self.last_send

    def summary(self) -> dict:
        """Counters for the UI and the JSON export."""
        lat = np.array(self.latencies) if self.latencies else np.zeros(1)
        return {
            "robot": self.robot_name,
            "mode": self._mode,
            "recording": self.recording_state,
            "end_reason": self.end_reason,
            "samples": len(self._t) if self._mode == "3d" else len(self._waypoints),
            "collisions": self.collisions,
            "counters": dict(self.counters),
            "latency_median_ms": float(np.median(lat) * 1e3),
            "latency_p95_ms": float(np.percentile(lat, 95) * 1e3),
        }

    def close(self) -> None:
        """Release the PyBullet client."""
        self.checker.close()

    def __enter__(self) -> TeachSession:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
