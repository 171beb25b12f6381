"""The browser interface: a local viser web app in front of a :class:`TeachSession`.

``TeachServer(session).url`` is a page (viser's bundled client, no network needed)
showing the arm (the primitive shapes of its generated URDF), the table, the box
obstacles (red), the goal region (green sphere) and a drag gizmo on the tool:

* **3-D mode**: dragging the gizmo sends its position to :meth:`TeachSession.drag`.
  Updates go through a *latest wins* slot: a worker thread always solves the newest
  target and drops the ones that arrived while it was busy. The sphere at the gizmo is
  green while the arm follows and turns red when an update is refused (collision, joint
  jump, out of reach); an unreachable target is drawn as a translucent ghost sphere.
  On release the gizmo snaps back to the tool.
* **2-D panel**: one slider per joint, an x/y/z entry with "Move (IK)", Store, Playback,
  Go Home, Send.
* Both: Stop, Playback, Export (CSV/JSON/DMP/episode into a new ``demo-<date>-<time>``
  folder of ``export_dir`` each time, never over an earlier one), Send (PyBullet
  execution; the executed tool path is drawn in orange next to the recorded one in
  blue, with its final error in the status text), Clear, and "Add box" for obstacles.

Everything the interface does goes through the session under one lock, so tests can
read ``server.session`` while a browser drives the page. Every handler catches every
exception and shows it as one line in the status text; a malformed drag position (NaN,
inf, wrong shape) is refused there and the drag worker keeps serving later drags.

**Access** (:mod:`lfd.teach.access`): the server binds to loopback by default, refuses
websockets from pages of other origins, and needs the per-launch token of :attr:`TeachServer.url`
whenever ``host`` is not loopback (or ``token=True``). **One controller**
(:mod:`lfd.teach.control`): the first tab drives the session; later tabs are read-only
viewers until one presses "Take control" (the previous tab is told it lost control).

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

from .access import AccessGuard, new_token, start_guarded_viser, token_required
from .control import ClientControl, error_line, escape_markdown
from .export import export_new_folder
from .session import TeachSession
from .settings import TeachSettings
from .visuals import GREEN, RED, SceneView

__all__ = ["TeachServer", "free_port"]


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that is free on ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


class TeachServer:
    """Serve ``session`` on ``http://host:port`` (see the module docstring).

    Args:
        session: the session to drive.
        host: interface to bind (default ``127.0.0.1``: this machine only).
        port: TCP port; 0 picks a free one.
        export_dir: where Export creates its ``demo-<date>-<time>`` folders.
        verbose: let viser print its banner.
        token: the launch token (:mod:`lfd.teach.access`): None (default) a fresh secret
            exactly when ``host`` is not loopback; True a fresh secret on any host; a
            string, that secret; False none (refused with ``ValueError`` when ``host`` is not
            loopback). :attr:`url` carries it.
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
        self.clients = ClientControl(self.server, self.lock, self._handover, self._refresh_safely)
        self.drag_errors = 0
        self.status_text = ""
        self.last_export: dict | None = None
        self.playbacks = 0
        self._pending: np.ndarray | None = None
        self._cond = threading.Condition()
        self._closed = False
        self.processed_updates = 0
        self.dropped_updates = 0
        self.view = SceneView(self.server, session, self._on_gizmo)
        self._build_gui()
        self._worker = threading.Thread(target=self._drag_worker, name="teach-drag", daemon=True)
        self._worker.start()
        self.server.on_client_connect(self.clients.on_connect)
        self.server.on_client_disconnect(self.clients.on_disconnect)
        self._refresh()

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

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui, s = self.server.gui, self.session
        self.status = gui.add_markdown("")
        self.buttons = {"Take control": gui.add_button("Take control")}  # label -> handle
        self.buttons["Take control"].on_click(self.clients.on_take)
        self.mode_buttons = gui.add_button_group("Mode", ("3-D drag", "2-D panel"))
        self.mode_buttons.on_click(self._on_mode)
        with gui.add_folder("Demonstration"):
            for label, fn in (
                ("Stop", self._stop),
                ("Playback", self._playback),
                ("Export", self._export),
                ("Send", self._send),
                ("Clear", self._clear),
            ):
                self.buttons[label] = gui.add_button(label)
                self.buttons[label].on_click(lambda e, fn=fn: self._run(fn, e))
        with gui.add_folder("2-D panel"):
            self.sliders = []
            spec = s.robot.spec
            for j in range(s.n_dof):
                sl = gui.add_slider(
                    f"q{j} ({spec.joint_names[j]})",
                    min=float(spec.lower[j]),
                    max=float(spec.upper[j]),
                    step=0.01,
                    initial_value=float(s.q[j]),
                )
                sl.on_update(self._on_slider)
                self.sliders.append(sl)
            self.xyz = gui.add_vector3(
                "x/y/z (m)", initial_value=tuple(np.round(s.tool_position, 3)), step=0.001
            )
            self.xyz_uuid = self.xyz._impl.uuid  # the id of its first input in the page
            gui.add_button("Move (IK)").on_click(lambda e: self._run(self._move_ik, e))
            for label, fn in (
                ("Store", self._store),
                ("Playback ", self._playback),
                ("Go Home", self._home),
                ("Send ", self._send),
            ):
                gui.add_button(label).on_click(lambda e, fn=fn: self._run(fn, e))
        with gui.add_folder("Obstacles", expand_by_default=False):
            self.box_center = gui.add_vector3("centre (m)", initial_value=(0.5, 0.3, 0.1), step=0.01)
            self.box_size = gui.add_vector3("size (m)", initial_value=(0.1, 0.1, 0.1), step=0.01)
            gui.add_button("Add box").on_click(lambda e: self._run(self._add_box, e))

    def _run(self, fn, event=None) -> None:
        """Run one button's action for the client of ``event`` (None: the server itself);
        any exception becomes the status line."""
        if not self.clients.may_act(event):
            return
        with self.lock:
            try:
                fn()
            except Exception as e:
                self.status_text = error_line(e)
            self._refresh_safely()

    def _refresh_safely(self, sliders: bool = True) -> None:
        try:
            self._refresh(sliders=sliders)
        except Exception as e:  # shown with the next refresh that works
            self.status_text = error_line(e)

    # ------------------------------------------------------------------ drag path
    def _on_gizmo(self, event) -> None:
        if not self.clients.may_act(event):
            with self.lock:
                self.view.gizmo.position = tuple(self.session.tool_position)
            return
        pos = np.array(event.target.position, dtype=float)
        if event.phase == "end":
            with self._cond:
                self._pending = None
            with self.lock:
                self.view.gizmo.position = tuple(self.session.tool_position)
            return
        with self._cond:
            if self._pending is not None:
                self.dropped_updates += 1
            self._pending = pos
            self._cond.notify()

    def _drag_worker(self) -> None:
        while True:
            with self._cond:
                while self._pending is None and not self._closed:
                    self._cond.wait()
                if self._closed:
                    return
                target, self._pending = self._pending, None
            try:
                self.handle_drag(target)
            except Exception as e:  # a bad target (NaN, inf, wrong shape) or a failed redraw
                with self.lock:
                    self.drag_errors += 1
                    self.status_text = f"refused drag: {error_line(e)}"
                    with contextlib.suppress(Exception):
                        self.view.gizmo.position = tuple(self.session.tool_position)
                    self._refresh_safely()

    def handle_drag(self, target: np.ndarray):
        """One drag update as the worker runs it: IK + collision check (the session),
        then the scene update (arm, gizmo colour, ghost, sliders, status). Returns the
        :class:`~lfd.teach.session.DragResult` (None outside the 3-D mode).

        Raises:
            ValueError: ``target`` is not 3 finite numbers (the session's check).
        """
        with self.lock:
            if self.session.mode != "3d":
                return None
            r = self.session.drag(target)
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

    # ------------------------------------------------------------------ panel actions
    def _handover(self) -> None:
        """Control changed hands: end a recording in progress (recordings are never merged)."""
        if self.session.recording_state == "recording":
            self.session.stop()
            self.status_text = "recording stopped: another tab took control"

    def _on_mode(self, event) -> None:
        if not self.clients.may_act(event):
            with self.lock:
                self.mode_buttons.value = "3-D drag" if self.session.mode == "3d" else "2-D panel"
            return
        with self.lock:
            try:
                mode = "3d" if str(event.target.value).startswith("3") else "2d"
                self.session.mode = mode
                self.view.gizmo.visible = mode == "3d"
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
                self._slider_moved()
            except Exception as e:
                self.status_text = error_line(e)
                self._refresh_safely(sliders=True)

    def _slider_moved(self) -> None:
        if self.session.mode != "2d":
            self.session.mode = "2d" if self.session.recording_state == "idle" else self.session.mode
        if self.session.mode != "2d":
            self.status_text = "**switch to the 2-D panel (Clear first) to use the sliders**"
            self._refresh(sliders=True)
            return
        q = np.array([sl.value for sl in self.sliders], dtype=float)
        r = self.session.set_joints(q)
        self.status_text = "" if r.accepted else f"refused: {r.reason} {r.detail}"
        self._refresh(sliders=not r.accepted)

    def _move_ik(self) -> None:
        if self.session.mode != "2d":
            self.session.mode = "2d"
        r = self.session.move_to(np.array(self.xyz.value, dtype=float))
        self.status_text = "" if r.accepted else f"refused: {r.reason} {r.detail}"
        self._refresh(sliders=True)

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
        self._refresh(sliders=True)

    def _stop(self) -> None:
        self.session.stop()

    def _clear(self) -> None:
        self.session.clear()
        self.view.clear_paths()
        self.status_text = "cleared"
        self._refresh(sliders=True)

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

    def _send(self) -> None:
        res = self.session.send()
        self.view.show_executed(res.executed.tool)
        self.status_text = (
            f"sent: final error {res.final_error * 100:.2f} cm, "
            f"max deviation {res.max_path_deviation * 100:.2f} cm"
        )

    def _add_box(self) -> None:
        box = self.session.add_obstacle(np.array(self.box_center.value), np.array(self.box_size.value))
        self.view.add_box(len(self.session.scene.obstacles) - 1, box)
        self.status_text = "box added"

    # ------------------------------------------------------------------ redraw
    def _refresh(self, sliders: bool = True) -> None:
        s = self.session
        with self.server.atomic():
            self.view.draw_arm(s.q)
            if sliders:
                for sl, v in zip(self.sliders, s.q, strict=True):
                    sl.value = float(np.clip(v, sl.min, sl.max))
            if s.mode == "3d" and s.recording_state != "idle" and s.samples % 5 == 0:
                self.view.show_recorded(s.recorded.tool)
            info = s.summary()
            send = s.last_send
            self.status.content = (
                f"**{s.robot_name}**, mode **{s.mode}**, recording **{s.recording_state}**"
                f"{' (' + s.end_reason + ')' if s.end_reason else ''}  \n"
                f"samples {info['samples']} | collisions **{s.collisions}** | refused {s.counters['refused_collision']}"
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
