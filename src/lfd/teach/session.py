"""The teach session: everything the browser interface does, without a browser.

A :class:`TeachSession` holds the arm's configuration, the scene, the recording and
the counters. The viser server (:mod:`lfd.teach.server`) only forwards the user's
actions to it and draws its state; scripts and tests call it directly.

**3-D mode** (the gizmo): :meth:`TeachSession.drag` moves the tool towards a target by
bounded-time IK (:class:`~lfd.teach.drag_ik.DragIK`). An update is *refused* (the arm
stays at its last accepted configuration) when the IK step would change a joint by more
than ``max_joint_step`` rad, when the target is out of reach and the best-effort pose
is no closer to it, or when the new configuration is in collision (arm - obstacle, arm -
table, self; :mod:`lfd.sim.collision`) anywhere on its joint-space segment from the last
accepted configuration (checked every ``sweep_resolution`` rad, :func:`lfd.teach.checks.sweep`,
so a fast drag cannot pass through a thin wall). Recording starts on the first accepted
drag (its first sample is the configuration before it) and ends when the tool enters the
goal region or on :meth:`stop`.

**2-D panel** (the baseline): :meth:`set_joints` (the sliders) and :meth:`move_to` (the
x/y/z entry, IK) move the arm, with the same collision rule; :meth:`store` appends the
current configuration as a waypoint, refused when the joint-space segment from the
previous waypoint passes through a collision; the recording is the waypoint path
(minimum-jerk segments timed by ``panel_speed``). Recording starts on the first arm
motion of the panel and ends when a stored waypoint puts the tool in the goal, or on
:meth:`stop`.

**Composition**: the session owns one object per job, each built with explicit arguments and
talked to through small public methods: :class:`~lfd.teach.drag_ik.DragIK` (``ik``, the
3-D mode's IK), :class:`~lfd.teach.panel.Panel` (``panel``, the 2-D inputs' checks and IK),
:class:`~lfd.teach.guard.MoveGuard` (``guard``, the swept collision check and the counters),
:class:`~lfd.teach.recording.Recorder` (``recorder``, the state machine and the samples); obstacle
editing is :func:`lfd.teach.obstacles.add_box`. The session applies the one rule that joins them:
a move is accepted (arm moved, recorded) or refused (arm kept, counted). Its settings are a
:class:`~lfd.teach.settings.TeachSettings` (``settings``), checked when built; the robots offered
are the catalogue's entries marked ``teach``.

**Recording, keyframes, motion**: :attr:`recorded` is the recording without the time the arm stood
still (:func:`lfd.teach.recording.trim_idle`; :attr:`recorded_raw` keeps the clock's times). Keyframes
(:meth:`add_keyframe`, :meth:`delete_keyframe`, :meth:`move_keyframe`, :meth:`reorder_keyframes`) are
configurations the motion must pass, timed by the recorded sample nearest them. :meth:`motion` is what
Export and Send run: the DMP fitted to the recording and conditioned through the keyframes
(:mod:`lfd.teach.motion`; the keyframes alone when nothing was recorded), its duration divided by
:attr:`speed`, with the gripper events (:meth:`add_gripper_event`) along it; :meth:`at` reads the
recording and the motion at one time of the timeline. :meth:`reopen` continues an export.

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

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from lfd.checks import check_float
from lfd.robots import ChainKinematics, load_robot
from lfd.robots.spatial import matrix_to_quaternion
from lfd.sim.collision import CollisionWorld

from .checks import check_vector, validate_scene
from .drag_ik import DragIK, IKStep, as_rotation, rotation_angle
from .gripper import GripperEvent, gripper_state
from .guard import MoveGuard
from .keyframes import Keyframe, check_index, keyframe_times, nearest_sample, reordered
from .latency import latency_summary
from .motion import Motion, Skill, plan_skill
from .obstacles import add_box
from .panel import Panel
from .recording import Recorder
from .results import DragResult, Recording
from .scene import Box, TeachScene, load_scene
from .settings import MODES, IKSettings, TeachSettings, teach_robots

__all__ = ["DragResult", "GripperEvent", "Motion", "Recording", "TeachSession", "teach_robots"]

#: The speeds a session may run its motion at (a factor on the taught timing).
SPEED_RANGE = (0.1, 4.0)


class TeachSession:
    """Session logic of the teach interface (see the module docstring).

    Args:
        robot: catalogue name, one of :func:`~lfd.teach.settings.teach_robots`.
        scene: YAML path, dict (see :mod:`lfd.teach.scene`), a ``TeachScene`` or None.
        mode: ``"3d"`` (drag) or ``"2d"`` (panel); switchable while nothing is recorded.
        ik_time_budget: seconds per drag IK (default 0.02).
        max_joint_step: largest joint change one drag update may make, rad (default 0.5).
        wam_q3: ``"fixed"`` (the closed form with its held joint kept, for robots that have one) or
            ``"free"`` (LM).
        margin: collision clearance, m.
        panel_speed: joint speed (rad/s) that times the 2-D waypoint segments.
        clock: function returning seconds (default ``time.monotonic``); scripted users
            pass a simulated clock.
        validate: check the scene against the robot (see :meth:`TeachScene` checks).
        sweep_resolution: every move is collision-checked along its joint-space
            segment at this spacing (rad of the largest joint change), not only at its end.
        orientation_weight: m per rad weighting a drag's orientation against its position (0: position
            only); see :class:`~lfd.teach.settings.IKSettings`.
        trim_idle: :attr:`recorded` leaves out the time the arm stood still (:attr:`recorded_raw` keeps it).
        idle_speed: rad/s below which the arm counts as standing still (:func:`lfd.teach.recording.trim_idle`).

    The arguments are checked as a :class:`~lfd.teach.settings.TeachSettings`
    (:meth:`from_settings` takes one directly).

    Raises:
        ValueError: a bad setting (field named), unknown robot, bad scene (field named), start pose
            outside the limits or in collision, an obstacle overlapping the robot base, a goal out of
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
        orientation_weight: float = 0.1,
        trim_idle: bool = True,
        idle_speed: float = 0.02,
    ) -> None:
        settings = TeachSettings(
            robot=robot,
            mode=mode,
            ik=IKSettings(
                time_budget=ik_time_budget,
                max_joint_step=max_joint_step,
                wam_q3=wam_q3,
                orientation_weight=orientation_weight,
            ),
            margin=margin,
            panel_speed=panel_speed,
            sweep_resolution=sweep_resolution,
            trim_idle=trim_idle,
            idle_speed=idle_speed,
        )
        self.settings = settings
        self.robot_name = settings.robot
        self.robot = load_robot(settings.robot)
        self.scene: TeachScene = load_scene(scene)
        self.kin = ChainKinematics(self.robot.spec)
        self.ik = DragIK(
            self.robot,
            time_budget=settings.ik.time_budget,
            wam_q3=settings.ik.wam_q3,
            orientation_weight=settings.ik.orientation_weight,
        )
        self.panel = Panel(self.robot, self.ik)
        self.max_joint_step = settings.ik.max_joint_step
        self.panel_speed = settings.panel_speed
        self.sweep_resolution = settings.sweep_resolution
        self.clock = clock or time.monotonic
        self._mode = settings.mode
        n = self.robot.n_dof
        try:
            self.start = self._checked_start(settings, validate)
        except ValueError as e:  # a scene read from a file: the line names it
            if self.scene.source != "<dict>":
                raise ValueError(f"{self.scene.source}: {e}") from None
            raise
        self.guard = MoveGuard(self.checker, settings.sweep_resolution)
        self.recorder = Recorder(
            self.kin, n, settings.panel_speed, self.clock, settings.trim_idle, settings.idle_speed
        )
        self.q = self.start.copy()
        self.last_send = None
        self._keyframes: list[Keyframe] = []
        self._gripper: list[GripperEvent] = []  # times at speed 1
        self._speed = 1.0
        self._edits = 0  # bumped by every edit of the keyframes, the speed or the recording
        self._skill: tuple[tuple, Skill] | None = None

    def _checked_start(self, settings: TeachSettings, validate: bool) -> np.ndarray:
        """The scene's start for this robot (its home when none), checked against the robot and the
        scene (limits, collisions, base, goal reach) when ``validate``; builds ``self.checker`` (closed
        again when a check fails)."""
        n, robot = self.robot.n_dof, settings.robot
        start = self.scene.start_for(robot)
        start = self.robot.home.numpy() if start is None else np.asarray(start, dtype=float)
        if start.shape != (n,):
            raise ValueError(
                f"scene field 'start' must have {n} joint angles for {robot}, got {start.shape[0]} "
                f"(a scene for several arms gives one start per robot: start: {{{robot}: [...], ...}})"
            )
        self.checker = CollisionWorld(self.robot, self.scene.obstacles, self.scene.table_z, settings.margin)
        if validate:
            try:
                validate_scene(self.robot, robot, self.scene, start, self.checker)
            except ValueError:
                self.checker.close()
                raise
        return start

    @classmethod
    def from_settings(
        cls,
        settings: TeachSettings,
        scene=None,
        *,
        clock: Callable[[], float] | None = None,
        validate: bool = True,
    ) -> TeachSession:
        """A session of ``settings`` (robot, ``scene`` path unless ``scene`` is given, mode, ``ik``,
        margin, panel speed, sweep resolution)."""
        return cls(
            settings.robot,
            settings.scene if scene is None else scene,
            mode=settings.mode,
            ik_time_budget=settings.ik.time_budget,
            max_joint_step=settings.ik.max_joint_step,
            wam_q3=settings.ik.wam_q3,
            margin=settings.margin,
            panel_speed=settings.panel_speed,
            clock=clock,
            validate=validate,
            sweep_resolution=settings.sweep_resolution,
            orientation_weight=settings.ik.orientation_weight,
            trim_idle=settings.trim_idle,
            idle_speed=settings.idle_speed,
        )

    @classmethod
    def reopen(cls, export_dir, **settings_overrides) -> TeachSession:
        """A session continuing an export folder lfd wrote (``demo.json``, :func:`lfd.teach.export.read_export`):
        the robot, scene (start included), mode, recording (its raw samples, finished), keyframes (with their
        anchors), gripper events and speed come back; ``settings_overrides`` are this constructor's keyword
        arguments (e.g. ``clock``, ``margin``). Counters start at zero.

        Raises:
            FileNotFoundError: no ``demo.json`` in ``export_dir``.
            ValueError: not a teach export lfd wrote, or a field that does not fit (one line naming
                ``demo.json`` and the field).
        """
        from .export import reopen_session

        return reopen_session(cls, export_dir, **settings_overrides)

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

    def tool_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The tool's pose at the current configuration: ``(position (3,) m, quaternion (4,) x, y, z, w)``,
        base frame, ``w >= 0`` (the order :meth:`drag` takes)."""
        frame = self.kin.frames(self.q)[-1]
        return frame[:3, 3].copy(), matrix_to_quaternion(frame[:3, :3], order="xyzw")

    @property
    def in_goal(self) -> bool:
        return self.scene.goal is not None and self.scene.goal.contains(self.tool_position)

    @property
    def collisions(self) -> int:
        """Collision events so far (:class:`~lfd.teach.guard.MoveGuard`)."""
        return self.guard.collisions

    @property
    def counters(self) -> dict[str, int]:
        """Updates by outcome (:data:`lfd.teach.guard.COUNTERS`)."""
        return self.guard.counters

    @property
    def latencies(self) -> list[float]:
        """IK + collision check time of each checked drag update, s."""
        return self.guard.latencies

    @property
    def recording_state(self) -> str:
        """``"idle"``, ``"recording"`` or ``"done"``."""
        return self.recorder.state

    @property
    def end_reason(self) -> str | None:
        """Why the recording ended: ``"goal"``, ``"stop"`` or None."""
        return self.recorder.end_reason

    @property
    def recorded(self) -> Recording:
        """The demonstration so far: drag samples (3-D) without the time the arm stood still (unless
        ``settings.trim_idle`` is off; :func:`lfd.teach.recording.trim_idle`), or the waypoint path (2-D).
        This is what Export, Send and :meth:`motion` use."""
        return self.recorder.recorded

    @property
    def recorded_raw(self) -> Recording:
        """The drag samples at the times the clock stamped them, idle time included (2-D: :attr:`recorded`)."""
        return self.recorder.recorded_raw

    @property
    def waypoints(self) -> np.ndarray:
        """(W, n) stored waypoints of the 2-D panel, rad."""
        return self.recorder.waypoints

    @property
    def samples(self) -> int:
        """Drag samples (3-D) or stored waypoints (2-D) recorded so far."""
        return self.recorder.samples

    def playback(self, rate: float = 30.0) -> np.ndarray:
        """(F, n) configurations replaying the recording in real time at ``rate`` frames/s."""
        return self.recorder.playback(rate)

    def stop(self) -> None:
        """End the recording (the Stop button)."""
        self.recorder.stop()

    def clear(self) -> None:
        """Forget the recording, the keyframes, the gripper events (and the last Send) and put the arm back
        at the start: afterwards :attr:`q` is the start pose and :meth:`tool_pose` its tool pose (counters and
        speed kept: they belong to the whole session)."""
        self.recorder.reset()
        self.last_send = None
        self.q = self.start.copy()
        self.guard.settle()
        self._keyframes, self._gripper = [], []
        self._edits += 1

    # ------------------------------------------------------------------ the rule of every move
    def _refuse(
        self, reason: str, target, step: IKStep | None, latency: float, detail: str = "", q=None
    ) -> DragResult:
        self.guard.refused(reason)
        q = self.q if q is None else q
        tool = self.kin.tool_position(q)
        return DragResult(
            False,
            q.copy(),
            reason == "collision",
            self.scene.goal is not None and self.scene.goal.contains(tool),
            reachable=bool(step.reached) if step is not None else True,
            reason=reason,
            tool=tool,
            target=np.asarray(target, dtype=float),
            latency=latency,
            detail=detail,
        )

    def _accept(self, q: np.ndarray, target, reachable: bool, latency: float) -> DragResult:
        self.guard.accepted(reachable)
        recorder = self.recorder
        if recorder.state == "idle":
            recorder.begin(self.q, self._mode)
        self.q = q.copy()
        if self._mode == "3d" and recorder.state == "recording":
            recorder.append(self.q)
        goal = self.in_goal
        if goal and self._mode == "3d" and recorder.state == "recording":
            recorder.finish("goal")
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

    # ------------------------------------------------------------------ 3-D mode
    def drag(self, position, orientation=None) -> DragResult:
        """One gizmo update: move the tool towards ``position`` (3,) m (base frame).

        ``orientation``: None (position only), a (3, 3) rotation or a quaternion ``(x, y, z, w)`` (the order
        :meth:`tool_pose` returns; viser's gizmo gives ``(w, x, y, z)``: reorder it) of the tool in the base
        frame, followed by arms with 6 or more joints, weighted by ``settings.ik.orientation_weight``
        (0: ignored). See the module docstring for when an update is refused; "unreachable" compares the
        weighted pose error (position m, orientation rad times the weight) before and after the step.

        Raises:
            ValueError: 2-D mode; a malformed position; a malformed orientation or one given to a
                4-DoF arm.
        """
        if self._mode != "3d":
            raise ValueError(
                "drag() is the 3-D mode's action; this session is in mode '2d' (use set_joints/move_to)"
            )
        target = check_vector(position, 3, "position")
        rot = None if orientation is None else as_rotation(orientation, order="xyzw")
        tic = time.perf_counter()
        self.guard.count("drag_updates")
        step, current_error = self._ik_step(self.q, target, rot)
        if step.jump > self.max_joint_step:
            return self._refuse(
                "joint_jump", target, step, time.perf_counter() - tic, f"joint change {step.jump:.2f} rad"
            )
        if not step.reached and step.error >= current_error - 1e-6:
            return self._refuse("unreachable", target, step, time.perf_counter() - tic, "target out of reach")
        report = self.guard.sweep(self.q, step.q)
        latency = time.perf_counter() - tic
        self.guard.latencies.append(latency)
        if report.in_collision:
            return self._refuse("collision", target, step, latency, report.kind or "")
        return self._accept(step.q, target, step.reached, latency)

    # ------------------------------------------------------------------ keyframes
    @property
    def keyframes(self) -> np.ndarray:
        """(K, n) rad: the keyframes in the order the motion visits them."""
        return np.array([kf.q for kf in self._keyframes], dtype=float).reshape(-1, self.n_dof)

    def keyframe_poses(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The tool pose of each keyframe: ``[(position (3,) m, quaternion (4,) x, y, z, w), ...]``."""
        out = []
        for kf in self._keyframes:
            frame = self.kin.frames(kf.q)[-1]
            out.append((frame[:3, 3].copy(), matrix_to_quaternion(frame[:3, :3], order="xyzw")))
        return out

    def _raw_q(self) -> np.ndarray | None:
        """(N, n) rad of the raw 3-D recording the keyframes are anchored in, None without one."""
        if self.recorder.mode != "3d" or self.recorder.samples == 0:
            return None
        return self.recorder.recorded_raw.q

    def _anchor(self, q: np.ndarray) -> int | None:
        raw = self._raw_q()
        return None if raw is None else nearest_sample(q, raw)

    def add_keyframe(self, index: int | None = None) -> int:
        """Add the current configuration as a keyframe, inserted before ``index`` (``0..K``; None: at the
        end). With a 3-D recording the keyframe is timed by the recorded sample nearest it (in joint
        space); the motion (:meth:`motion`) passes through it. Returns its index.

        Raises:
            ValueError: ``index`` not an integer in ``0..K``.
        """
        k = len(self._keyframes)
        i = k if index is None else check_index(index, k, insert=True)
        self._keyframes.insert(i, Keyframe(self.q.copy(), self._anchor(self.q)))
        self._edits += 1
        return i

    def delete_keyframe(self, i: int) -> None:
        """Remove keyframe ``i``. Raises ``ValueError`` for an index outside ``0..K-1``."""
        del self._keyframes[check_index(i, len(self._keyframes))]
        self._edits += 1

    def reorder_keyframes(self, order) -> None:
        """Visit the keyframes in ``order`` (a permutation of ``0..K-1``: new position ``j`` holds old
        keyframe ``order[j]``). With a recording the times stay where they were and the keyframes are
        handed out to them in the new order. Raises ``ValueError`` if ``order`` is not a permutation."""
        self._keyframes = reordered(self._keyframes, order, self._raw_q())
        self._edits += 1

    def move_keyframe(self, i: int, position, orientation=None) -> DragResult:
        """Drag keyframe ``i``'s tool to ``position`` (3,) m (and ``orientation`` as in :meth:`drag`): IK from
        that keyframe's configuration, refused like a drag (``"joint_jump"``, ``"unreachable"``,
        ``"collision"`` along the joint-space segment from the keyframe's old configuration; counted like
        one). The arm itself does not move; the keyframe keeps its time. ``DragResult.q`` is the keyframe's
        configuration afterwards.

        Raises:
            ValueError: an index outside ``0..K-1``; a malformed position or orientation.
        """
        i = check_index(i, len(self._keyframes))
        target = check_vector(position, 3, "position")
        rot = None if orientation is None else as_rotation(orientation, order="xyzw")
        kf = self._keyframes[i]
        tic = time.perf_counter()
        step, current_error = self._ik_step(kf.q, target, rot)
        if step.jump > self.max_joint_step:
            return self._refuse(
                "joint_jump",
                target,
                step,
                time.perf_counter() - tic,
                f"joint change {step.jump:.2f} rad",
                kf.q,
            )
        if not step.reached and step.error >= current_error - 1e-6:
            return self._refuse(
                "unreachable", target, step, time.perf_counter() - tic, "target out of reach", kf.q
            )
        report = self.guard.sweep(kf.q, step.q)
        latency = time.perf_counter() - tic
        if report.in_collision:
            return self._refuse("collision", target, step, latency, report.kind or "", kf.q)
        self.guard.settle()
        anchor = kf.anchor if kf.anchor is not None else self._anchor(kf.q)
        self._keyframes[i] = Keyframe(step.q.copy(), anchor)
        self._edits += 1
        tool = self.kin.tool_position(step.q)
        return DragResult(
            True,
            step.q.copy(),
            False,
            self.scene.goal is not None and self.scene.goal.contains(tool),
            reachable=step.reached,
            reason="ok" if step.reached else "best_effort",
            tool=tool,
            target=target,
            latency=latency,
        )

    # ------------------------------------------------------------------ the motion, speed, gripper, timeline
    @property
    def speed(self) -> float:
        """Speed factor of the motion (0.1..4, default 1): the taught timing divided by it."""
        return self._speed

    @speed.setter
    def speed(self, value: float) -> None:
        self._speed = check_float(value, "speed", low=SPEED_RANGE[0], high=SPEED_RANGE[1])
        self._edits += 1

    def skill(self) -> Skill:
        """The planned motion (:func:`lfd.teach.motion.plan_skill`): the DMP fitted to :attr:`recorded`
        (or, with fewer than 3 recorded samples, to the keyframe path), conditioned to pass every keyframe,
        at :attr:`speed`. Cached until the next edit.

        Raises:
            ValueError: nothing to plan (fewer than 3 recorded samples and fewer than 2 keyframes).
        """
        key = (self._edits, self.recorder.samples, self.recorder.mode)
        if self._skill is not None and self._skill[0] == key:
            return self._skill[1]
        rec = self.recorded
        kq = self.keyframes
        times = None
        raw = self._raw_q()
        if raw is not None and len(rec) >= 3:
            times = keyframe_times(self._keyframes, raw, self.recorder.raw_times())
        elif len(rec) >= 3 and len(kq):  # 2-D: the waypoint path's nearest samples
            times = keyframe_times([Keyframe(q) for q in kq], rec.q, rec.t)
        skill = plan_skill(rec, kq, times, self._speed, self.panel_speed)
        self._skill = (key, skill)
        return skill

    def motion(self, n: int = 200) -> Motion:
        """The motion Export and Send run, sampled at ``n`` (>= 2) uniform times: ``Motion(t (n,) s, q (n, n_dof)
        rad, tool (n, 3) m, gripper (n,) 0 open / 1 closed)``. It is :meth:`skill`'s DMP rolled out: fitted to
        the idle-trimmed recording, through every keyframe (within rounding at its time), over the
        recording's duration divided by :attr:`speed`; without a recording, through the keyframes alone.

        Raises:
            ValueError: ``n`` < 2; nothing to plan (fewer than 3 recorded samples and fewer than 2 keyframes).
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"n must be an integer >= 2, got {n!r}")
        dmp = self.skill().dmp
        t = np.linspace(0.0, float(dmp.tau_), int(n))
        q = np.asarray(dmp.rollout(t=t), dtype=float)
        tool = np.array([self.kin.tool_position(x) for x in q])
        return Motion(t, q, tool, gripper_state(self.gripper_events, t))

    @property
    def motion_duration(self) -> float:
        """Duration of :meth:`motion`, s (at :attr:`speed`); 0.0 while there is nothing to plan."""
        try:
            return float(self.skill().dmp.tau_)
        except ValueError:
            return 0.0

    def at(self, t: float) -> dict:
        """The timeline at ``t`` s of the motion (clipped to ``0..motion_duration``): ``{"q_recorded": (n,) rad
        or None, "q_motion": (n,) rad}``: the recording at the same point (its time ``t * speed``, linear
        between samples; None with fewer than 2 recorded samples) and the motion.

        Raises:
            ValueError: ``t`` not a finite number; nothing to plan.
        """
        t = check_float(t, "t")
        dmp = self.skill().dmp
        t = min(max(t, 0.0), float(dmp.tau_))
        grid = np.array([0.0, t]) if t > 0 else np.array([0.0])
        q_motion = np.asarray(dmp.rollout(t=grid), dtype=float)[-1]
        rec = self.recorded
        q_rec = None
        if len(rec) >= 2:
            tr = t * self._speed
            q_rec = np.array([np.interp(tr, rec.t, rec.q[:, j]) for j in range(self.n_dof)])
        return {"q_recorded": q_rec, "q_motion": q_motion}

    @property
    def gripper_events(self) -> list[GripperEvent]:
        """The gripper events, sorted by time, ``t`` in s of the motion at the current :attr:`speed` (a change
        of speed moves them with the motion)."""
        return [GripperEvent(e.t / self._speed, e.closed) for e in self._gripper]

    def add_gripper_event(self, t: float, closed: bool) -> int:
        """Close (``closed=True``) or open the gripper from ``t`` s of the motion on (at the current speed).
        Returns the event's index in :attr:`gripper_events` (sorted by time).

        Raises:
            ValueError: ``t`` not a finite number in ``0..motion_duration`` (any ``t >= 0`` while nothing is
                planned); ``closed`` not a bool.
        """
        duration = self.motion_duration
        t = check_float(t, "gripper event t", low=0.0, high=duration if duration > 0 else None)
        if not isinstance(closed, (bool, np.bool_)):
            raise ValueError(f"gripper event closed must be true or false, got {closed!r}")
        event = GripperEvent(t * self._speed, bool(closed))
        i = sum(1 for e in self._gripper if e.t <= event.t)
        self._gripper.insert(i, event)
        return i

    def remove_gripper_event(self, i: int) -> None:
        """Remove gripper event ``i`` (of :attr:`gripper_events`). Raises ``ValueError`` for a bad index."""
        del self._gripper[check_index(i, len(self._gripper), "gripper event")]

    def _ik_step(self, q_from: np.ndarray, target: np.ndarray, rot) -> tuple[IKStep, float]:
        """The drag IK from ``q_from`` and the pose error before it; with an orientation both errors are the
        weighted pose error ``hypot(position m, orientation_weight * angle rad)``."""
        step = self.ik.solve(q_from, target, rot)
        frame = self.kin.frames(q_from)[-1]
        current_error = float(np.linalg.norm(frame[:3, 3] - target))
        if rot is not None and self.ik.orientation_weight > 0:
            w = self.ik.orientation_weight
            current_error = float(np.hypot(current_error, w * rotation_angle(rot, frame[:3, :3])))
            step = dataclasses.replace(step, error=float(np.hypot(step.error, w * step.rot_error)))
        return step, current_error

    # ------------------------------------------------------------------ 2-D panel
    def set_joints(self, q) -> DragResult:
        """The sliders: put the arm at ``q`` (n,) rad if it is collision-free (else refused).

        Raises:
            ValueError: wrong length, NaN, a joint outside its limits (named).
        """
        q = self.panel.joints(q)
        tic = time.perf_counter()
        self.guard.count("panel_moves")
        report = self.guard.sweep(self.q, q)
        latency = time.perf_counter() - tic
        target = self.kin.tool_position(q)
        if report.in_collision:
            return self._refuse("collision", target, None, latency, report.kind or "")
        return self._accept(q, target, True, latency)

    def move_to(self, position, orientation=None) -> DragResult:
        """The x/y/z entry: IK (from the current configuration, with restarts if that
        fails) to ``position`` (3,) m (and ``orientation``, as in :meth:`drag`: (3, 3) or quaternion
        ``(x, y, z, w)``), then the same rule as :meth:`set_joints`; refused (``"unreachable"``) when no
        configuration reaches it within 1 mm."""
        target = check_vector(position, 3, "position")
        orientation = None if orientation is None else as_rotation(orientation, order="xyzw")
        tic = time.perf_counter()
        step = self.panel.solve(self.q, target, orientation)
        if not step.reached:
            self.guard.count("panel_moves")
            return self._refuse("unreachable", target, step, time.perf_counter() - tic, "no IK solution")
        return self.set_joints(step.q)

    def store(self) -> bool:
        """Store the current configuration as a waypoint (2-D). Returns False (and counts a
        collision) when the joint-space segment from the previous waypoint collides."""
        if self._mode != "2d":
            raise ValueError("store() is the 2-D panel's action; this session is in mode '3d'")
        recorder = self.recorder
        if recorder.state == "done":
            return False
        if recorder.state == "idle":
            recorder.begin(self.q, self._mode)
        self.guard.count("stores")
        if self.guard.sweep(recorder.last_waypoint, self.q).in_collision:
            self.guard.count("refused_stores")
            self._refuse("collision", self.tool_position, None, 0.0, "segment")
            return False
        self.guard.settle()
        recorder.add_waypoint(self.q)
        if self.in_goal:
            recorder.finish("goal")
        return True

    def go_home(self) -> None:
        """Put the arm back at the scene's start pose (not recorded)."""
        self.q = self.start.copy()

    # ------------------------------------------------------------------ scene edits
    def add_obstacle(self, center, size, yaw_deg: float = 0.0) -> Box:
        """Add a box obstacle (the UI's "Add box"); refused with ``ValueError`` when it
        overlaps the robot base or the arm where it stands now (:func:`lfd.teach.obstacles.add_box`)."""
        box = add_box(self.checker, self.q, center, size, yaw_deg)
        self.scene = self.scene.with_obstacle(box)
        return box

    # ------------------------------------------------------------------ playback, export, send
    def fit_dmp(self, n_samples: int = 200, n_basis: int = 30):
        """A DMP fitted to the recording alone, resampled on a uniform grid (:mod:`lfd.teach.export`;
        no keyframes, speed 1). Export and Send run :meth:`skill`'s DMP instead."""
        from .export import fit_recording_dmp

        return fit_recording_dmp(self.recorded, n_samples=n_samples, n_basis=n_basis)

    def export(self, out_dir) -> dict:
        """Write ``demo.csv``, ``demo.json``, ``demo.dmp.json`` (the :meth:`skill`) and ``episode.npz`` to
        ``out_dir`` (:func:`lfd.teach.export.export_session`); returns ``{"csv", "json", "dmp", "episode"}`` paths.

        Raises:
            ValueError: nothing to export (fewer than 3 recorded samples and fewer than 2 keyframes).
            FileExistsError: one of the four files already exists there (nothing is overwritten).
        """
        from .export import export_session

        return export_session(self, out_dir)

    def send(self):
        """Run :meth:`motion` (the :meth:`skill`'s DMP) on the simulated arm in PyBullet; returns a
        :class:`~lfd.teach.export.SendResult` (also kept as ``last_send``)."""
        from .export import send_session

        self.last_send = send_session(self)
        return self.last_send

    def summary(self) -> dict:
        """Counters for the UI and the JSON export."""
        return {
            "robot": self.robot_name,
            "mode": self._mode,
            "recording": self.recording_state,
            "end_reason": self.end_reason,
            "samples": self.samples,
            "keyframes": len(self._keyframes),
            "speed": self._speed,
            "collisions": self.collisions,
            "counters": dict(self.counters),
            **latency_summary(self.latencies),
        }

    def close(self) -> None:
        """Release the PyBullet client."""
        self.checker.close()

    def __enter__(self) -> TeachSession:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
