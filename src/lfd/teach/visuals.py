"""The 3-D scene the teach page draws: the shapes of the arm's generated URDF, the table, the obstacles,
the goal, the drag gizmo and the tool paths (:class:`SceneView`). Units: m."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lfd.robots.spatial import matrix_to_quaternion
from lfd.robots.spec import rpy_to_matrix

__all__ = ["GREEN", "RED", "SceneView", "project_to_pixel", "urdf_visuals"]

GREEN, RED, _GREY = (40, 180, 60), (220, 40, 40), (150, 150, 165)
_BLUE, _PURPLE = (40, 90, 230), (150, 60, 200)


def project_to_pixel(camera, point) -> np.ndarray:
    """(2,) pixel ``(x right, y down)`` of the world point ``point (3,)`` m in the page of a viser client
    whose ``camera`` (a ``viser.CameraHandle``: ``wxyz``, ``position``, ``fov`` rad vertical, ``image_width``,
    ``image_height``) looks at it (OpenCV camera axes: x right, y down, z forward). Scripts and browser tests
    use it to grab the gizmo with the mouse."""
    from .drag_ik import as_rotation

    rot = as_rotation(camera.wxyz)
    pc = rot.T @ (np.asarray(point, float) - np.asarray(camera.position, float))
    f = camera.image_height / 2.0 / np.tan(camera.fov / 2.0)
    return np.array(
        [camera.image_width / 2.0 + f * pc[0] / pc[2], camera.image_height / 2.0 + f * pc[1] / pc[2]]
    )


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


class SceneView:
    """The 3-D scene of :class:`~lfd.teach.server.TeachServer`: table, obstacles, goal, the arm's
    URDF shapes (one frame per link), the drag gizmo with its marker and the ghost target, the
    recorded (blue) and executed (orange) tool paths.

    Args:
        viser_server: the running viser server.
        session: the session drawn (its ``scene``, ``robot``, ``kin``, ``n_dof``, ``tool_pose()``).
        on_gizmo: called with each gizmo update event.
        rotations: give the gizmo rings that turn the tool (arms with 6 or more joints).

    Attributes:
        visuals, link_nodes: the arm's shapes and one scene frame per link. gizmo, marker, ghost: the drag
        gizmo, the sphere on it (green / red) and the unreachable target. gizmo_scale: m, its arrows' length.
        recorded_line, executed_line, motion_line: the drawn paths (None: none). keyframe_handles: one small
        gizmo per keyframe. timeline_markers: the recording's (blue) and the motion's (purple) tool at the
        timeline's time.
    """

    def __init__(self, viser_server, session, on_gizmo: Callable, rotations: bool = False) -> None:
        self.server, self.session = viser_server, session
        s, sc = session, viser_server.scene
        self.server.initial_camera.position = (1.3, -1.3, 1.0)
        self.server.initial_camera.look_at = (0.35, 0.0, 0.2)
        sc.set_up_direction("+z")
        sc.configure_default_lights(cast_shadow=False)  # shadows cost a lot in software WebGL
        # image-based lighting costs software WebGL more than half of each frame (a drag is seen a frame later);
        # a hemisphere light gives the same soft shading for almost nothing
        sc.configure_environment_map(None)
        sc.add_light_hemisphere("/lights/sky", intensity=2.0)
        if s.scene.table_z is not None:
            sc.add_box(
                "/table",
                color=(200, 180, 150),
                dimensions=(2.0, 2.0, 0.02),
                position=(0.3, 0.0, s.scene.table_z - 0.01),
            )
        for i, box in enumerate(s.scene.obstacles):
            self.add_box(i, box)
        if s.scene.goal is not None:
            g = s.scene.goal
            sc.add_icosphere("/goal", radius=g.radius, color=GREEN, opacity=0.35, position=tuple(g.center))
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
        tool, quat = s.tool_pose()
        self.gizmo_scale = 0.25  # m: length of the gizmo's arrows
        self.gizmo = sc.add_transform_controls(
            "/gizmo",
            scale=self.gizmo_scale,
            position=tuple(tool),
            wxyz=(float(quat[3]), *map(float, quat[:3])) if rotations else (1.0, 0.0, 0.0, 0.0),
            disable_rotations=not rotations,
            depth_test=False,
            line_width=4.0,
        )
        self.marker = sc.add_icosphere("/gizmo/marker", radius=0.025, color=GREEN)
        self.ghost = sc.add_icosphere("/ghost", radius=0.03, color=RED, opacity=0.3, visible=False)
        self.gizmo.on_update(on_gizmo)
        self.recorded_line = None
        self.executed_line = None
        self.motion_line = None
        self._motion_marks: list = []
        self.keyframe_handles: list = []
        self.timeline_markers = (
            sc.add_icosphere("/timeline/recorded", radius=0.02, color=_BLUE, visible=False),
            sc.add_icosphere("/timeline/motion", radius=0.02, color=_PURPLE, visible=False),
        )

    def add_box(self, i: int, box) -> None:
        """Draw obstacle number ``i`` (a :class:`~lfd.teach.scene.Box`)."""
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

    def draw_arm(self, q: np.ndarray) -> None:
        """Move the arm's link frames to the configuration ``q (n,)`` rad."""
        frames = self.session.kin.frames(q)
        for node, frame in zip(self.link_nodes, frames[:-1], strict=True):
            node.position = tuple(frame[:3, 3])
            node.wxyz = tuple(matrix_to_quaternion(frame[:3, :3]))

    def _draw_path(self, name: str, points: np.ndarray, color) -> object | None:
        if len(points) < 2:
            return None
        segs = np.stack([points[:-1], points[1:]], axis=1)
        return self.server.scene.add_line_segments(name, segs, color, thickness=0.006)

    def show_recorded(self, tool: np.ndarray) -> None:
        """Draw the recorded tool path ``tool (N, 3)`` m (blue), replacing the previous one."""
        if self.recorded_line is not None:
            self.recorded_line.remove()
            self.recorded_line = None
        self.recorded_line = self._draw_path("/paths/recorded", tool, _BLUE)

    def show_executed(self, tool: np.ndarray) -> None:
        """Draw the executed tool path ``tool (N, 3)`` m of a Send (orange), replacing the previous one."""
        if self.executed_line is not None:
            self.executed_line.remove()
        self.executed_line = self._draw_path("/paths/executed", tool, (255, 140, 0))

    def clear_paths(self) -> None:
        """Remove the recorded and executed paths, the motion and the timeline markers."""
        for line in (self.recorded_line, self.executed_line):
            if line is not None:
                line.remove()
        self.recorded_line = self.executed_line = None
        self.show_motion(None, [])
        for marker in self.timeline_markers:
            marker.visible = False

    def show_motion(self, tool: np.ndarray | None, gripper_marks) -> None:
        """Draw the planned motion's tool path ``tool (N, 3)`` m (purple; None: remove it) and one small
        sphere per gripper event ``(position (3,) m, closed)`` (red closes, green opens)."""
        for node in [self.motion_line, *self._motion_marks]:
            if node is not None:
                node.remove()
        self.motion_line, self._motion_marks = None, []
        if tool is None:
            return
        self.motion_line = self._draw_path("/paths/motion", tool, _PURPLE)
        for k, (p, closed) in enumerate(gripper_marks):
            self._motion_marks.append(
                self.server.scene.add_icosphere(
                    f"/paths/gripper{k}", radius=0.018, color=RED if closed else GREEN, position=tuple(p)
                )
            )

    def show_keyframes(self, positions, on_move: Callable) -> None:
        """One small translate-only gizmo per keyframe tool position ``(3,)`` m (replacing the previous
        ones); ``on_move(i, event)`` is called with each update of keyframe ``i``'s gizmo."""
        for handle in self.keyframe_handles:
            handle.remove()
        self.keyframe_handles = []
        for i, p in enumerate(positions):
            handle = self.server.scene.add_transform_controls(
                f"/keyframes/{i}",
                scale=0.08,
                position=tuple(float(v) for v in p),
                disable_rotations=True,
                depth_test=False,
                line_width=2.0,
            )
            handle.on_update(lambda event, i=i: on_move(i, event))
            self.server.scene.add_icosphere(f"/keyframes/{i}/dot", radius=0.015, color=_PURPLE)
            self.keyframe_handles.append(handle)

    def show_timeline(self, recorded: np.ndarray | None, motion: np.ndarray) -> None:
        """Put the timeline markers on the recording's tool ``recorded (3,)`` m (None: hidden) and the
        motion's ``motion (3,)`` m."""
        rec, mot = self.timeline_markers
        rec.visible = recorded is not None
        if recorded is not None:
            rec.position = tuple(recorded)
        mot.visible = True
        mot.position = tuple(motion)
