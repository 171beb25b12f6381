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
* Both: Stop, Playback, Export (CSV/JSON/DMP/episode into ``export_dir``), Send (PyBullet
  execution; the executed tool path is drawn in orange next to the recorded one in
  blue, with its final error in the status text), Clear, and "Add box" for obstacles.

Everything the interface does goes through the session under one lock, so tests can
read ``server.session`` while a browser drives the page.
"""

from __future__ import annotations

import math
import socket
import threading
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import viser

from lfd.robots.spatial import matrix_to_quaternion
from lfd.robots.spec import rpy_to_matrix

from .session import TeachSession

__all__ = ["TeachServer", "free_port"]

_GREEN, _RED, _GREY = (40, 180, 60), (220, 40, 40), (150, 150, 165)


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port that is free on ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


@dataclass(frozen=True)
class _Visual:
    link: int  # -1 base_link, i: link i
    origin: np.ndarray  # (4, 4) in the link frame
    kind: str  # "sphere" | "cylinder"
    radius: float
    length: float


def urdf_visuals(urdf: str, link_names: tuple[str, ...]) -> list[_Visual]:
    """The sphere and cylinder visuals of a URDF written by :mod:`lfd.robots.urdf`."""
    index = {"base_link": -1, **{name: i for i, name in enumerate(link_names)}}
    out = []
    for link in ET.fromstring(urdf).findall("link"):
        name = link.get("name")
        if name not in index:
            continue
        for vis in link.findall("visual"):
            o = vis.find("origin")
            xyz = [float(v) for v in o.get("xyz").split()] if o is not None else [0.0, 0.0, 0.0]
            rpy = [float(v) for v in o.get("rpy").split()] if o is not None else [0.0, 0.0, 0.0]
            frame = np.eye(4)
            frame[:3, :3] = rpy_to_matrix(rpy)
            frame[:3, 3] = xyz
            geom = vis.find("geometry")
            sphere, cyl = geom.find("sphere"), geom.find("cylinder")
            if sphere is not None:
                out.append(_Visual(index[name], frame, "sphere", float(sphere.get("radius")), 0.0))
            elif cyl is not None:
                out.append(
                    _Visual(
                        index[name], frame, "cylinder", float(cyl.get("radius")), float(cyl.get("length"))
                    )
                )
    return out


class TeachServer:
    """Serve ``session`` on ``http://host:port`` (see the module docstring).

    Args:
        session: the session to drive.
        host: interface to bind (default ``127.0.0.1``: this machine only).
        port: TCP port; 0 picks a free one.
        export_dir: where Export writes its files.
        verbose: let viser print its banner.
    """

    def __init__(
        self,
        session: TeachSession,
        host: str = "127.0.0.1",
        port: int = 8080,
        export_dir: str | Path = "outputs/teach/export",
        verbose: bool = False,
    ) -> None:
        self.session = session
        self.export_dir = Path(export_dir)
        self.lock = threading.RLock()
        port = free_port(host) if port == 0 else int(port)
        self.server = viser.ViserServer(host=host, port=port, verbose=verbose)
        self.host, self.port = host, self.server.get_port()
        self.status_text = ""
        self.last_export: dict | None = None
        self.playbacks = 0
        self._pending: np.ndarray | None = None
        self._cond = threading.Condition()
        self._closed = False
        self.processed_updates = 0
        self.dropped_updates = 0
        self._build_scene()
        self._build_gui()
        self._worker = threading.Thread(target=self._drag_worker, name="teach-drag", daemon=True)
        self._worker.start()
        self._refresh()

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    # ------------------------------------------------------------------ scene
    def _build_scene(self) -> None:
        s, sc = self.session, self.server.scene
        self.server.initial_camera.position = (1.3, -1.3, 1.0)
        self.server.initial_camera.look_at = (0.35, 0.0, 0.2)
        sc.set_up_direction("+z")
        sc.configure_default_lights(cast_shadow=False)  # shadows cost a lot in software WebGL
        if s.scene.table_z is not None:
            sc.add_box(
                "/table",
                color=(200, 180, 150),
                dimensions=(2.0, 2.0, 0.02),
                position=(0.3, 0.0, s.scene.table_z - 0.01),
            )
        for i, box in enumerate(s.scene.obstacles):
            self._add_box_node(i, box)
        if s.scene.goal is not None:
            g = s.scene.goal
            sc.add_icosphere("/goal", radius=g.radius, color=_GREEN, opacity=0.35, position=tuple(g.center))
        # one scene frame per link (moved on every update), its URDF shapes as fixed children
        self.visuals = urdf_visuals(s.robot.to_urdf(), s.robot.spec.link_names)
        self.link_nodes = [sc.add_frame(f"/robot/link{i}", show_axes=False) for i in range(s.n_dof)]
        for k, v in enumerate(self.visuals):
            parent = "/robot/base" if v.link < 0 else f"/robot/link{v.link}"
            pose = {
                "position": tuple(v.origin[:3, 3]),
                "wxyz": tuple(matrix_to_quaternion(v.origin[:3, :3])),
                "cast_shadow": False,
                "receive_shadow": False,
            }
            if v.kind == "sphere":
                sc.add_icosphere(f"{parent}/v{k}", radius=v.radius, color=_GREY, subdivisions=2, **pose)
            else:
                sc.add_cylinder(
                    f"{parent}/v{k}",
                    radius=v.radius,
                    height=v.length,
                    color=_GREY,
                    radial_segments=16,
                    **pose,
                )
        tool = s.tool_position
        self.gizmo_scale = 0.25  # m: length of the gizmo's arrows
        self.gizmo = sc.add_transform_controls(
            "/gizmo",
            scale=self.gizmo_scale,
            position=tuple(tool),
            disable_rotations=True,
            depth_test=False,
            line_width=4.0,
        )
        self.marker = sc.add_icosphere("/gizmo/marker", radius=0.025, color=_GREEN)
        self.ghost = sc.add_icosphere("/ghost", radius=0.03, color=_RED, opacity=0.3, visible=False)
        self.gizmo.on_update(self._on_gizmo)
        self.recorded_line = None
        self.executed_line = None

    def _add_box_node(self, i: int, box) -> None:
        rot = np.array(
            [[math.cos(box.yaw), -math.sin(box.yaw), 0], [math.sin(box.yaw), math.cos(box.yaw), 0], [0, 0, 1]]
        )
        self.server.scene.add_box(
            f"/obstacles/{i}",
            color=(200, 60, 60),
            dimensions=tuple(box.size),
            position=tuple(box.center),
            wxyz=tuple(matrix_to_quaternion(rot)),
            opacity=0.8,
        )

    def _draw_arm(self, q: np.ndarray) -> None:
        frames = self.session.kin.frames(q)
        for node, frame in zip(self.link_nodes, frames[:-1], strict=True):
            node.position = tuple(frame[:3, 3])
            node.wxyz = tuple(matrix_to_quaternion(frame[:3, :3]))

    def _draw_path(self, name: str, points: np.ndarray, color) -> object | None:
        if len(points) < 2:
            return None
        segs = np.stack([points[:-1], points[1:]], axis=1)
        return self.server.scene.add_line_segments(name, segs, color, thickness=0.006)

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui, s = self.server.gui, self.session
        self.status = gui.add_markdown("")
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
                gui.add_button(label).on_click(lambda _e, fn=fn: self._run(fn))
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
            gui.add_button("Move (IK)").on_click(lambda _e: self._run(self._move_ik))
            for label, fn in (
                ("Store", self._store),
                ("Playback ", self._playback),
                ("Go Home", self._home),
                ("Send ", self._send),
            ):
                gui.add_button(label).on_click(lambda _e, fn=fn: self._run(fn))
        with gui.add_folder("Obstacles", expand_by_default=False):
            self.box_center = gui.add_vector3("centre (m)", initial_value=(0.5, 0.3, 0.1), step=0.01)
            self.box_size = gui.add_vector3("size (m)", initial_value=(0.1, 0.1, 0.1), step=0.01)
            gui.add_button("Add box").on_click(lambda _e: self._run(self._add_box))

    def _run(self, fn) -> None:
        with self.lock:
            try:
                fn()
            except ValueError as e:
                self.status_text = f"**{e}**"
            self._refresh()

    # ------------------------------------------------------------------ drag path
    def _on_gizmo(self, event) -> None:
        pos = np.array(event.target.position, dtype=float)
        if event.phase == "end":
            with self._cond:
                self._pending = None
            with self.lock:
                self.gizmo.position = tuple(self.session.tool_position)
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
            self.handle_drag(target)

    def handle_drag(self, target: np.ndarray):
        """One drag update as the worker runs it: IK + collision check (the session),
        then the scene update (arm, gizmo colour, ghost, sliders, status). Returns the
        :class:`~lfd.teach.session.DragResult` (None outside the 3-D mode)."""
        with self.lock:
            if self.session.mode != "3d":
                return None
            r = self.session.drag(target)
            self.processed_updates += 1
            self.marker.color = _GREEN if r.accepted and r.reachable else _RED
            self.ghost.visible = not r.reachable or r.reason == "unreachable"
            if self.ghost.visible:
                self.ghost.position = tuple(r.target)
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
    def _on_mode(self, event) -> None:
        mode = "3d" if event.target.value.startswith("3") else "2d"
        with self.lock:
            try:
                self.session.mode = mode
                self.gizmo.visible = mode == "3d"
                self.status_text = ""
            except ValueError as e:
                self.status_text = f"**{e}**"
            self._refresh()

    def _on_slider(self, event) -> None:
        if event.client is None:  # set by the server itself
            return
        with self.lock:
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
        self._draw_recorded()

    def _home(self) -> None:
        self.session.go_home()
        self._refresh(sliders=True)

    def _stop(self) -> None:
        self.session.stop()

    def _clear(self) -> None:
        self.session.clear()
        for line in (self.recorded_line, self.executed_line):
            if line is not None:
                line.remove()
        self.recorded_line = self.executed_line = None
        self.status_text = "cleared"
        self._refresh(sliders=True)

    def _playback(self, rate: float = 30.0) -> None:
        frames = self.session.playback(rate)
        if len(frames) == 0:
            raise ValueError("nothing recorded to play back")
        step = max(1, len(frames) // 150)  # at most ~5 s of animation
        for q in frames[::step]:
            self._draw_arm(q)
            time.sleep(1.0 / rate)
        self._draw_arm(self.session.q)
        self.playbacks += 1
        self.status_text = f"played back {len(frames)} frames"

    def _export(self) -> None:
        self.last_export = self.session.export(self.export_dir)
        self.status_text = f"exported to {self.export_dir}"

    def _send(self) -> None:
        res = self.session.send()
        if self.executed_line is not None:
            self.executed_line.remove()
        self.executed_line = self._draw_path("/paths/executed", res.executed.tool, (255, 140, 0))
        self.status_text = (
            f"sent: final error {res.final_error * 100:.2f} cm, "
            f"max deviation {res.max_path_deviation * 100:.2f} cm"
        )

    def _add_box(self) -> None:
        box = self.session.add_obstacle(np.array(self.box_center.value), np.array(self.box_size.value))
        self._add_box_node(len(self.session.scene.obstacles) - 1, box)
        self.status_text = "box added"

    # ------------------------------------------------------------------ redraw
    def _draw_recorded(self) -> None:
        rec = self.session.recorded
        if self.recorded_line is not None:
            self.recorded_line.remove()
            self.recorded_line = None
        self.recorded_line = self._draw_path("/paths/recorded", rec.tool, (40, 90, 230))

    def _refresh(self, sliders: bool = True) -> None:
        s = self.session
        with self.server.atomic():
            self._draw_arm(s.q)
            if sliders:
                for sl, v in zip(self.sliders, s.q, strict=True):
                    sl.value = float(np.clip(v, sl.min, sl.max))
            if s.mode == "3d" and s.recording_state != "idle" and len(s._t) % 5 == 0:
                self._draw_recorded()
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
