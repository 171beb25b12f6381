"""The browser interface: a local viser web app in front of a :class:`TeachSession`.

``TeachServer(session).url`` is a page (viser's bundled client, no network needed)
showing the arm (the primitive shapes of its generated URDF), the table, the box
obstacles (red), the goal region (green sphere) and a drag gizmo on the tool, with a short
hint on how to start at the top of the panel:

* **3-D mode**: dragging the gizmo's arrows sends its position to :meth:`TeachSession.drag`;
  on arms with 6 or more joints its rings turn the tool (the gizmo's orientation goes along,
  quaternion ``x, y, z, w``). Updates go through a *latest wins* slot: a worker thread always
  solves the newest target and drops the ones that arrived while it was busy. The sphere at
  the gizmo is green while the arm follows and turns red when an update is refused (collision,
  joint jump, out of reach); an unreachable target is drawn as a translucent ghost sphere.
* **State follows the arm**: after every action (a drag's release, Clear, Go Home, a slider,
  playback, a take-over, a reopen) the gizmo, the tool readout (x/y/z m, roll/pitch/yaw deg),
  the x/y/z entry and the joint sliders show the arm's current tool pose, so the next drag starts
  where the tool is. The readout also follows during a drag. In the 2-D mode the gizmo is hidden.
* **2-D panel**: one slider per joint, an x/y/z entry with "Move (IK)", Store, Go Home.
* **Demonstration** (both modes): Stop, Playback, Export (CSV/JSON/DMP/episode into a new
  ``demo-<date>-<time>`` folder of ``export_dir`` each time, never over an earlier one), Send
  (PyBullet execution of :meth:`TeachSession.motion`; the executed tool path is drawn in orange
  next to the recorded one in blue, with its final error in the status text), Clear.
* **Keyframes**: add the current pose (at the end or before the selected one), delete, move
  earlier / later; each keyframe has a small gizmo in 3-D: dragging it moves the keyframe
  (:meth:`TeachSession.move_keyframe`) and the fitted motion (purple) is redrawn live.
* **Timeline**: a time slider scrubbing the recording (blue marker) and the motion (purple marker),
  the speed factor, gripper close/open events at the slider's time (drawn on the motion).
* **Reopen**: an export folder of ``export_dir`` is loaded back (:meth:`TeachSession.reopen`).
* **Obstacles**: "Add box" (refused where it would cover the goal).

Everything the interface does goes through the session under one lock, so tests can
read ``server.session`` while a browser drives the page. Every handler catches every
exception and shows it as one line in the status text; a malformed drag position (NaN,
inf, wrong shape) is refused there and the drag worker keeps serving later drags.

**Access** (:mod:`lfd.teach.access`): the server binds to loopback by default, refuses
websockets from pages of other origins, needs the per-launch token of :attr:`TeachServer.url`
whenever ``host`` is not loopback (or ``token=True``), never opens a share tunnel (viser's Share
button is hidden and its requests dropped), drops malformed messages and refuses a busy port.
**One controller** (:mod:`lfd.teach.control`): the first tab drives the session; later tabs are
read-only viewers with their own "Take control" button (the previous tab is told it lost control).

**Composition**: the server owns the viser server, a :class:`~lfd.teach.control.ClientControl`
(``clients``: which tab may act) and a :class:`~lfd.teach.visuals.SceneView` (``view``: what the page
draws), built with explicit arguments; it forwards each action to the session's public methods.
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from pathlib import Path

import numpy as np

from lfd.robots.spec import matrix_to_rpy

from .access import AccessGuard, new_token, start_guarded_viser, token_required
from .control import ClientControl, error_line, escape_markdown
from .drag_ik import as_rotation
from .export import export_new_folder
from .session import SPEED_RANGE, TeachSession
from .settings import TeachSettings
from .visuals import GREEN, RED, SceneView

__all__ = ["HINT", "TeachServer", "free_port", "wxyz_to_xyzw", "xyzw_to_wxyz"]

#: The instructions shown on top of the panel.
HINT = (
    "**Drag the arrows** on the tool to move the arm{rings}. The first move starts a recording; "
    "**Stop** ends it, **Send** runs it in simulation, **Export** saves it. Keyframes, the timeline "
    "(speed, gripper) and reopening an export: the folders below."
)

#: Default centre of "Add box" (m): beside the arm's usual workspace, away from the shipped goals.
BOX_CENTER = (0.2, 0.5, 0.05)


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that is free on ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def _shown(value: float, low: float, high: float) -> float:
    """A joint angle as its slider shows it: within the limits, rounded to the slider's step (0.001 rad),
    so the number box shows all of it."""
    return float(np.round(np.clip(value, low, high), 3))


def xyzw_to_wxyz(q) -> tuple[float, float, float, float]:
    """Quaternion ``(x, y, z, w)`` (the session's order) -> ``(w, x, y, z)`` (viser's)."""
    x, y, z, w = (float(v) for v in q)
    return (w, x, y, z)


def wxyz_to_xyzw(q) -> np.ndarray:
    """Quaternion ``(w, x, y, z)`` (viser's order) -> ``(x, y, z, w)`` (the session's), (4,)."""
    w, x, y, z = (float(v) for v in q)
    return np.array([x, y, z, w])


class TeachServer:
    """Serve ``session`` on ``http://host:port`` (see the module docstring).

    Args:
        session: the session to drive.
        host: interface to bind (default ``127.0.0.1``: this machine only).
        port: TCP port; 0 picks a free one. A busy port is refused (``ValueError``), never moved.
        export_dir: where Export creates its ``demo-<date>-<time>`` folders (and Reopen lists them).
        verbose: let viser print its banner.
        token: the launch token (:mod:`lfd.teach.access`): None (default) a fresh secret
            exactly when ``host`` is not loopback; True a fresh secret on any host; a
            string, that secret; False none (refused with ``ValueError`` when ``host`` is not
            loopback). :attr:`url` carries it.

    Attributes:
        rotations: whether the gizmo turns the tool (arms with 6 or more joints).
        last_target: the last drag target handed to the session: ``(position (3,) m, quaternion (4,)
            x, y, z, w or None)``.
    """

    def __init__(
        self,
        session: TeachSession,
        host: str = "127.0.0.1",
        port: int = 8080,
        export_dir: str | Path = "outputs/teach/export",
        verbose: bool = False,
        token: bool | str | None = None,
    ) -> None:
        self.session = session
        self.export_dir = Path(export_dir)
        self.lock = threading.RLock()
        if isinstance(token, str):
            if not token:
                raise ValueError("token must be a non-empty string, True, False or None")
            self.token: str | None = token
        else:
            self.token = new_token() if token_required(host, token) else None
        port = free_port(host) if port == 0 else int(port)
        self.guard = AccessGuard(host, self.token, port)
        self.server = start_guarded_viser(host, port, self.guard, verbose=verbose)
        self.host, self.port = host, self.server.get_port()
        self.server.gui.configure_theme(show_share_button=False, control_width="large")
        self.clients = ClientControl(self.server, self.lock, self._handover, self._refresh_safely)
        self.drag_errors = 0
        self.status_text = ""
        self.last_export: dict | None = None
        self.last_target: tuple[np.ndarray, np.ndarray | None] | None = None
        self.playbacks = 0
        self._pending: tuple[np.ndarray, np.ndarray | None] | None = None
        self._dragging = False
        self._cond = threading.Condition()
        self._closed = False
        self.processed_updates = 0
        self.dropped_updates = 0
        self._install(session)
        self._worker = threading.Thread(target=self._drag_worker, name="teach-drag", daemon=True)
        self._worker.start()
        self.server.on_client_connect(self.clients.on_connect)
        self.server.on_client_disconnect(self.clients.on_disconnect)

    @classmethod
    def from_settings(
        cls, session: TeachSession, settings: TeachSettings, verbose: bool = False
    ) -> TeachServer:
        """Serve ``session`` with the server part of ``settings`` (host, port, export_dir, token)."""
        return cls(
            session,
            host=settings.host,
            port=settings.port,
            export_dir=settings.export_dir,
            verbose=verbose,
            token=settings.token_policy,
        )

    @property
    def url(self) -> str:
        """The page's address, with ``?token=`` when a token is in force."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        base = f"http://{host}:{self.port}"
        return base if self.token is None else f"{base}/?token={self.token}"

    def _install(self, session: TeachSession) -> None:
        """Draw ``session`` (scene and panel built afresh) and make it the one the page drives."""
        with self.lock:
            self.session = session
            self.rotations = session.n_dof >= 6
            self.server.scene.reset()
            self.server.gui.reset()
            self.view = SceneView(self.server, session, self._on_gizmo, rotations=self.rotations)
            self._motion_key = None
            self._gizmo_visible = True
            self._build_gui()
            self._redraw_keyframes()
            self._refresh()

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui, s = self.server.gui, self.session
        self.hint = gui.add_markdown(HINT.format(rings=", the rings to turn it" if self.rotations else ""))
        self.status = gui.add_markdown("")
        self.readout = gui.add_markdown("")
        self.buttons: dict[str, object] = {}  # label -> handle
        self.mode_buttons = {}
        for label, mode in (("3-D drag", "3d"), ("2-D panel", "2d")):
            self.mode_buttons[mode] = gui.add_button(label)
            self.mode_buttons[mode].on_click(lambda e, mode=mode: self._on_mode(e, mode))
        with gui.add_folder("Demonstration"):
            for label, fn in (
                ("Stop", self._stop),
                ("Playback", self._playback),
                ("Export", self._export),
                ("Send", self._send),
                ("Clear", self._clear),
            ):
                self._button(label, fn)
        with gui.add_folder("Keyframes"):
            self.keyframe_list = gui.add_markdown("")
            self.keyframe_pick = gui.add_dropdown("keyframe", ("-",), initial_value="-")
            for label, fn in (
                ("Add keyframe", lambda: self._add_keyframe(None)),
                ("Insert before", self._insert_keyframe),
                ("Delete keyframe", self._delete_keyframe),
                ("Move earlier", lambda: self._shift_keyframe(-1)),
                ("Move later", lambda: self._shift_keyframe(+1)),
            ):
                self._button(label, fn)
        with gui.add_folder("Timeline"):
            self.timeline = gui.add_slider("t (s)", min=0.0, max=1.0, step=0.01, initial_value=0.0)
            self.timeline.on_update(lambda e: self._on_input(e, self._scrub))
            self.speed = gui.add_slider(
                "speed", min=SPEED_RANGE[0], max=SPEED_RANGE[1], step=0.1, initial_value=float(s.speed)
            )
            self.speed.on_update(lambda e: self._on_input(e, self._set_speed))
            self._button("Close gripper at t", lambda: self._gripper(True))
            self._button("Open gripper at t", lambda: self._gripper(False))
            self._button("Remove gripper event", self._remove_gripper)
            self.gripper_list = gui.add_markdown("")
        with gui.add_folder("2-D panel", expand_by_default=s.mode == "2d"):
            self.sliders = []
            spec = s.robot.spec
            for j in range(s.n_dof):
                sl = gui.add_slider(
                    f"q{j} ({spec.joint_names[j]})",
                    min=float(spec.lower[j]),
                    max=float(spec.upper[j]),
                    step=0.001,
                    initial_value=_shown(s.q[j], float(spec.lower[j]), float(spec.upper[j])),
                )
                sl.on_update(self._on_slider)
                self.sliders.append(sl)
            self.xyz = gui.add_vector3(
                "x/y/z (m)", initial_value=tuple(np.round(s.tool_position, 3)), step=0.001
            )
            self.xyz_uuid = self.xyz._impl.uuid  # the id of its first input in the page
            for label, fn in (("Move (IK)", self._move_ik), ("Store", self._store), ("Go Home", self._home)):
                self._button(label, fn)
        with gui.add_folder("Reopen an export", expand_by_default=False):
            self.reopen_pick = gui.add_dropdown("folder", ("-",), initial_value="-")
            self._button("Reopen", self._reopen)
        with gui.add_folder("Obstacles", expand_by_default=False):
            self.box_center = gui.add_vector3("centre (m)", initial_value=BOX_CENTER, step=0.01)
            self.box_size = gui.add_vector3("size (m)", initial_value=(0.1, 0.1, 0.1), step=0.01)
            self._button("Add box", self._add_box)
        self._list_exports()

    def _button(self, label: str, fn) -> None:
        self.buttons[label] = self.server.gui.add_button(label)
        self.buttons[label].on_click(lambda e, fn=fn: self._run(fn, e))

    def _run(self, fn, event=None) -> None:
        """Run one button's action for the client of ``event`` (None: the server itself);
        any exception becomes the status line."""
        if not self.clients.may_act(event):
            return
        with self.lock:
            self.status_text = ""
            try:
                fn()
            except Exception as e:
                self.status_text = error_line(e)
            self._refresh_safely()

    def _on_input(self, event, fn) -> None:
        """A GUI input changed by a client (not by the server): run ``fn`` as an action, or put the
        viewer's input back."""
        if event.client is None:
            return
        if not self.clients.may_act(event):
            self._refresh_safely()
            return
        self._run(fn)

    def _refresh_safely(self, sliders: bool = True) -> None:
        try:
            self._refresh(sliders=sliders)
        except Exception as e:  # shown with the next refresh that works
            self.status_text = error_line(e)

    # ------------------------------------------------------------------ drag path
    def _on_gizmo(self, event) -> None:
        if not self.clients.may_act(event):
            with self.lock:
                self._place_gizmo()
            return
        if event.phase == "end":
            with self._cond:
                self._pending = None
            with self.lock:
                self._dragging = False
                self._place_gizmo()
            return
        pos = np.array(event.target.position, dtype=float)
        quat = wxyz_to_xyzw(event.target.wxyz) if self.rotations else None
        with self._cond:
            self._dragging = True
            if self._pending is not None:
                self.dropped_updates += 1
            self._pending = (pos, quat)
            self._cond.notify()

    def _drag_worker(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                pending, self._pending = self._pending, None
            try:
                target, quat = pending
                self.handle_drag(target, quat)
            except Exception as e:  # a bad target (NaN, inf, wrong shape) or a failed redraw
                with self.lock:
                    self.drag_errors += 1
                    self.status_text = f"refused drag: {error_line(e)}"
                    with contextlib.suppress(Exception):
                        self._place_gizmo()
                    self._refresh_safely()

    def handle_drag(self, target: np.ndarray, orientation=None):
        """One drag update as the worker runs it: IK + collision check (the session),
        then the scene update (arm, gizmo colour, ghost, readout, sliders, status). ``orientation``: the
        tool's quaternion ``(x, y, z, w)`` (None: position only). Returns the
        :class:`~lfd.teach.session.DragResult` (None outside the 3-D mode).

        Raises:
            ValueError: ``target`` is not 3 finite numbers, or a malformed orientation (the session's check).
        """
        with self.lock:
            if self.session.mode != "3d":
                return None
            self.last_target = (np.asarray(target, dtype=float), orientation)
            r = self.session.drag(target, orientation)
            self.processed_updates += 1
            view = self.view
            view.marker.color = GREEN if r.accepted and r.reachable else RED
            view.ghost.visible = not r.reachable or r.reason == "unreachable"
            if view.ghost.visible:
                view.ghost.position = tuple(r.target)
            self.status_text = (
                ""
                if r.accepted and r.reachable
                else f"refused: {r.reason} {r.detail}"
                if not r.accepted
                else "target out of reach (best effort)"
            )
            self._refresh(sliders=True)
            return r

    def _place_gizmo(self) -> None:
        """Put the gizmo on the tool (position, and orientation when it turns the tool)."""
        position, quat = self.session.tool_pose()
        gizmo = self.view.gizmo
        gizmo.position = tuple(position)
        if self.rotations:
            gizmo.wxyz = xyzw_to_wxyz(quat)

    # ------------------------------------------------------------------ panel actions
    def _handover(self) -> None:
        """Control changed hands: end a recording in progress (recordings are never merged)."""
        if self.session.recording_state == "recording":
            self.session.stop()
            self.status_text = "recording stopped: another tab took control"

    def _on_mode(self, event, mode: str) -> None:
        if not self.clients.may_act(event):
            return
        with self.lock:
            try:
                self.session.mode = mode
                self.status_text = ""
            except Exception as e:
                self.status_text = error_line(e)
            self._refresh_safely()

    def _on_slider(self, event) -> None:
        if event.client is None:  # set by the server itself
            return
        if not self.clients.may_act(event):
            with self.lock:
                self._refresh_safely(sliders=True)
            return
        with self.lock:
            try:
                self._slider_moved(next(j for j, sl in enumerate(self.sliders) if sl is event.target))
            except Exception as e:
                self.status_text = error_line(e)
                self._refresh_safely(sliders=True)

    def _slider_moved(self, j: int | None = None) -> None:
        """Slider ``j`` moved (None: any of them): the arm goes to the current configuration with that
        joint (every joint) at its slider's value."""
        if self.session.mode != "2d":
            self.session.mode = "2d" if self.session.recording_state == "idle" else self.session.mode
        if self.session.mode != "2d":
            self.status_text = "**switch to the 2-D panel (Clear first) to use the sliders**"
            self._refresh(sliders=True)
            return
        if j is None:
            q = np.array([sl.value for sl in self.sliders], dtype=float)
        else:
            q = self.session.q.copy()
            q[j] = float(self.sliders[j].value)
        r = self.session.set_joints(q)
        self.status_text = "" if r.accepted else f"refused: {r.reason} {r.detail}"
        self._refresh(sliders=not r.accepted)

    def _move_ik(self) -> None:
        if self.session.mode != "2d":
            self.session.mode = "2d"
        r = self.session.move_to(np.array(self.xyz.value, dtype=float))
        self.status_text = "" if r.accepted else f"refused: {r.reason} {r.detail}"

    def _store(self) -> None:
        if self.session.mode != "2d":
            self.session.mode = "2d"
        ok = self.session.store()
        self.status_text = (
            "stored"
            if ok
            else "refused: the segment from the last waypoint collides"
            if self.session.recording_state != "done"
            else "recording finished"
        )
        self.view.show_recorded(self.session.recorded.tool)

    def _home(self) -> None:
        self.session.go_home()

    def _stop(self) -> None:
        self.session.stop()

    def _clear(self) -> None:
        self.session.clear()
        self.view.clear_paths()
        self._redraw_keyframes()
        self.status_text = "cleared"

    def _playback(self, rate: float = 30.0) -> None:
        frames = self.session.playback(rate)
        if len(frames) == 0:
            raise ValueError("nothing recorded to play back")
        step = max(1, len(frames) // 150)  # at most ~5 s of animation
        for q in frames[::step]:
            self.view.draw_arm(q)
            time.sleep(1.0 / rate)
        self.view.draw_arm(self.session.q)
        self.playbacks += 1
        self.status_text = f"played back {len(frames)} frames"

    def _export(self) -> None:
        self.last_export = export_new_folder(self.session, self.export_dir)
        self.status_text = "exported to " + escape_markdown(str(self.last_export["csv"].parent))
        self._list_exports()

    def _send(self) -> None:
        res = self.session.send()
        self.view.show_executed(res.executed.tool)
        self.status_text = f"sent: max deviation from the motion {res.max_path_deviation * 100:.2f} cm"

    def _add_box(self) -> None:
        from .scene import Box

        center = np.array(self.box_center.value, dtype=float)
        size = np.array(self.box_size.value, dtype=float)
        goal = self.session.scene.goal
        if goal is not None and goal.overlaps(Box(center, size)):
            raise ValueError(
                f"refused: a box at {np.round(center, 3).tolist()} would cover the goal "
                f"(centre {np.round(goal.center, 3).tolist()}, radius {goal.radius} m): move it"
            )
        box = self.session.add_obstacle(center, size)
        self.view.add_box(len(self.session.scene.obstacles) - 1, box)
        self.status_text = "box added"

    # ------------------------------------------------------------------ keyframes
    def _selected_keyframe(self) -> int:
        pick = str(self.keyframe_pick.value)
        if not pick.isdigit():
            raise ValueError("select a keyframe first (Add keyframe makes one from the arm's pose)")
        return int(pick) - 1

    def _add_keyframe(self, index: int | None) -> None:
        i = self.session.add_keyframe(index)
        self._redraw_keyframes(select=i)
        self.status_text = f"keyframe {i + 1} added"

    def _insert_keyframe(self) -> None:
        self._add_keyframe(self._selected_keyframe() if len(self.session.keyframes) else None)

    def _delete_keyframe(self) -> None:
        i = self._selected_keyframe()
        self.session.delete_keyframe(i)
        self._redraw_keyframes(select=min(i, len(self.session.keyframes) - 1))
        self.status_text = f"keyframe {i + 1} deleted"

    def _shift_keyframe(self, by: int) -> None:
        i = self._selected_keyframe()
        k = len(self.session.keyframes)
        j = i + by
        if not 0 <= j < k:
            raise ValueError(f"keyframe {i + 1} is already the {'first' if by < 0 else 'last'}")
        order = list(range(k))
        order[i], order[j] = order[j], order[i]
        self.session.reorder_keyframes(order)
        self._redraw_keyframes(select=j)

    def _redraw_keyframes(self, select: int | None = None) -> None:
        """One small gizmo per keyframe, the list in the panel and the selection dropdown."""
        poses = self.session.keyframe_poses()
        self.view.show_keyframes([p for p, _ in poses], self._on_keyframe)
        names = tuple(str(i + 1) for i in range(len(poses))) or ("-",)
        current = str(self.keyframe_pick.value)
        self.keyframe_pick.options = names
        if select is not None and 0 <= select < len(poses):
            self.keyframe_pick.value = str(select + 1)
        elif current not in names:
            self.keyframe_pick.value = names[-1]
        self.keyframe_list.content = (
            "  \n".join(
                f"**{i + 1}** ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) m" for i, (p, _) in enumerate(poses)
            )
            or "no keyframes: **Add keyframe** stores the arm's pose"
        )

    def _on_keyframe(self, i: int, event) -> None:
        """A keyframe's gizmo moved: move the keyframe (refused like a drag), redraw the motion."""
        if not self.clients.may_act(event):
            with self.lock:
                self._redraw_keyframes()
            return
        with self.lock:
            try:
                if event.phase == "end":
                    self._redraw_keyframes()
                else:
                    r = self.session.move_keyframe(i, np.array(event.target.position, dtype=float))
                    self.status_text = "" if r.accepted else f"refused: {r.reason} {r.detail}"
                    self._redraw_motion()
            except Exception as e:
                self.status_text = error_line(e)
            self._refresh_safely(sliders=False)

    # ------------------------------------------------------------------ timeline, speed, gripper
    def _scrub(self) -> None:
        at = self.session.at(float(self.timeline.value))
        rec = None if at["q_recorded"] is None else self.session.kin.tool_position(at["q_recorded"])
        self.view.show_timeline(rec, self.session.kin.tool_position(at["q_motion"]))

    def _set_speed(self) -> None:
        self.session.speed = float(self.speed.value)

    def _gripper(self, closed: bool) -> None:
        t = min(float(self.timeline.value), self.session.motion_duration)  # the slider's end is rounded up
        self.session.add_gripper_event(t, closed)
        self.status_text = f"gripper {'closes' if closed else 'opens'} at {t:.2f} s"
        self._motion_key = None

    def _remove_gripper(self) -> None:
        events = self.session.gripper_events
        if not events:
            raise ValueError("no gripper events to remove")
        t = float(self.timeline.value)
        i = int(np.argmin([abs(e.t - t) for e in events]))
        self.session.remove_gripper_event(i)
        self.status_text = f"gripper event at {events[i].t:.2f} s removed"
        self._motion_key = None

    def _redraw_motion(self) -> None:
        """Draw :meth:`TeachSession.motion` (purple) with its gripper events and set the timeline's range
        (nothing drawn while there is nothing to plan)."""
        s = self.session
        try:
            motion = s.motion(100)
        except ValueError:
            self.view.show_motion(None, [])
            self.timeline.max = 1.0
            self.gripper_list.content = ""
            return
        events = s.gripper_events
        marks = [(motion.tool[int(np.argmin(np.abs(motion.t - e.t)))], e.closed) for e in events]
        self.view.show_motion(motion.tool, marks)
        self.timeline.max = max(np.ceil(float(motion.t[-1]) * 100) / 100, 0.01)  # whole hundredths
        self.gripper_list.content = "  \n".join(
            f"{'close' if e.closed else 'open'} at {e.t:.2f} s" for e in events
        )

    # ------------------------------------------------------------------ reopen
    def _list_exports(self) -> None:
        folders = (
            sorted(p.name for p in self.export_dir.iterdir() if (p / "demo.json").is_file())
            if self.export_dir.is_dir()
            else []
        )
        self.reopen_pick.options = tuple(folders) or ("-",)
        self.reopen_pick.value = folders[-1] if folders else "-"

    def _reopen(self) -> None:
        name = str(self.reopen_pick.value)
        folder = self.export_dir / name
        if name in ("-", "", ".", "..") or "/" in name or not (folder / "demo.json").is_file():
            raise ValueError(f"no export to reopen in {escape_markdown(str(self.export_dir))} (Export first)")
        new = TeachSession.reopen(folder)
        old = self.session
        self._install(new)
        old.close()
        self.status_text = "reopened " + escape_markdown(name)

    def reopen(self, folder: str | Path) -> None:
        """Reopen the export ``folder`` (a folder of ``export_dir``) as the page's session (what the
        Reopen button does). Raises ``ValueError`` for anything else."""
        folder = Path(folder)
        if folder.parent.resolve() != self.export_dir.resolve():
            raise ValueError(f"{folder}: only exports in {self.export_dir} can be reopened here")
        with self.lock:
            self._list_exports()
            self.reopen_pick.value = folder.name
            self._reopen()

    # ------------------------------------------------------------------ redraw
    def _refresh(self, sliders: bool = True) -> None:
        s = self.session
        with self.server.atomic():
            self.view.draw_arm(s.q)
            position, quat = s.tool_pose()
            if not self._dragging:
                self._place_gizmo()
            visible = s.mode == "3d"
            if visible != self._gizmo_visible:
                self.view.gizmo.visible = self._gizmo_visible = visible
            for mode, button in self.mode_buttons.items():
                color = "blue" if mode == s.mode else "gray"
                if button.color != color:
                    button.color = color
            rpy = np.degrees(matrix_to_rpy(as_rotation(quat, order="xyzw")))
            self.readout.content = (
                f"tool x/y/z **{position[0]:.3f} {position[1]:.3f} {position[2]:.3f}** m  \n"
                f"roll/pitch/yaw **{rpy[0]:.1f} {rpy[1]:.1f} {rpy[2]:.1f}**°"
            )
            if sliders:
                for sl, v in zip(self.sliders, s.q, strict=True):
                    shown = _shown(v, sl.min, sl.max)
                    if sl.value != shown:
                        sl.value = shown
            if self.speed.value != s.speed:  # a viewer's move of the speed slider is put back
                self.speed.value = float(s.speed)
            xyz = tuple(float(v) for v in np.round(position, 3))
            if tuple(self.xyz.value) != xyz:
                self.xyz.value = xyz
            if s.mode == "3d" and s.recording_state == "recording":
                if s.samples % 5 == 0:
                    self.view.show_recorded(s.recorded.tool)
            else:
                key = (s.samples, s.recording_state, s.keyframes.tobytes(), s.speed, len(s.gripper_events))
                if key != self._motion_key:
                    self._motion_key = key
                    if s.mode == "3d" and s.samples:
                        self.view.show_recorded(s.recorded.tool)
                    self._redraw_motion()
            info = s.summary()
            send = s.last_send
            self.status.content = (
                f"**{s.robot_name}**, mode **{s.mode}**, recording **{s.recording_state}**"
                f"{' (' + s.end_reason + ')' if s.end_reason else ''}  \n"
                f"samples {info['samples']} | keyframes {info['keyframes']} | collisions **{s.collisions}**"
                f" | refused {s.counters['refused_collision']}"
                f" | drag IK+check median {info['latency_median_ms']:.1f} ms"
                + (f"  \nSend: final error {send.final_error * 100:.2f} cm" if send is not None else "")
                + (f"  \n{self.status_text}" if self.status_text else "")
            )

    def close(self) -> None:
        """Stop the worker and the web server."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        self._worker.join(timeout=2.0)
        self.server.stop()
