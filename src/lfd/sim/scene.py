"""PyBullet reaching scene: robot arm, table, one object, fixed RGB camera.

Frames: the PyBullet world has its floor at ``z = 0``; the robot base (the PR2
``torso_lift_link``) is fixed at ``(0, 0, torso_height)`` with no rotation. **Every pose
going in or out of** :class:`ReachScene` **is in the robot base (torso) frame**, like the
robot model's ``fk``/``ik``; the table top lies ``table_z`` (default -0.33 m) below it.

Each scene owns its own PyBullet clients (``p.DIRECT``), so scenes in different processes
(or several in one process) never interfere. :meth:`ReachScene.reset` rebuilds the world
from scratch (``resetSimulation``), so an episode's outcome does not depend on the
episodes simulated before it in the same client.

Rendering: the TinyRenderer's cost grows with the screen area each shape covers, and the
floor and table cover most of the image. They never move and (without shadows) look the
same whatever else is in the scene, so in the physics client they are transparent (the
renderer skips them), a second "backdrop" client holds visible copies, and a frame is the
robot and object rendered over the backdrop image (composited where the depth buffer is
empty).
The fixed camera's backdrop is rendered once per scene.
"""

from __future__ import annotations

import hashlib
import math
import shutil
import tempfile
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from lfd.sim._pybullet import pybullet as p
from lfd.sim.approach import TABLE_Z
from lfd.sim.camera import Camera, Lighting
from lfd.sim.clutter import FlatItem
from lfd.sim.collision import overlapping_link_pairs
from lfd.sim.joints import ArmJoints
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.textures import TableTexture

#: Table extent (m) in the torso frame: x from ``TABLE_X[0]`` to ``TABLE_X[1]``, y symmetric.
TABLE_X = (0.35, 0.95)
TABLE_HALF_Y = 0.45
TABLE_RGBA = (0.62, 0.60, 0.56, 1.0)
FLOOR_RGBA = (0.35, 0.35, 0.38, 1.0)
#: Rolling and spinning friction of the objects (PyBullet's contact model: a resisting
#: torque of this many metres times the normal force). Real objects touch the table over a
#: small patch, a rigid capsule on its hemispherical cap over a point: without it an upright
#: capsule is in unstable equilibrium and falls over by itself (see docs/decisions). Pushing
#: still moves objects (tests/sim/test_sim_scene.py).
OBJECT_ROLLING_FRICTION = 1e-3


def pose_matrix(position, quaternion) -> np.ndarray:
    """``(4, 4)`` pose from a position ``(3,)`` and a PyBullet quaternion ``(x, y, z, w)``."""
    pose = np.eye(4)
    pose[:3, :3] = np.asarray(p.getMatrixFromQuaternion(quaternion)).reshape(3, 3)
    pose[:3, 3] = position
    return pose


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class ReachScene(ArmJoints):
    """One PyBullet world with the arm, a table and (after :meth:`reset`) one object.

    Args:
        robot: robot model from :func:`lfd.robots.load_robot` (provides ``to_urdf()``,
            ``home``, ``joint_names``); its URDF is written to a private temp folder.
        image_size: side (px) of the square images of the fixed camera (and wrist camera).
        camera: fixed camera (torso frame); default :class:`~lfd.sim.camera.Camera` at
            ``image_size``.
        wrist_camera: also render a camera riding on the wrist, looking along the gripper.
        control_dt: seconds per control step (:meth:`step`).
        substeps: physics steps per control step (timestep ``control_dt / substeps``).
        max_force: joint motor torque limit (N m) of every joint; None (default) = the
            URDF effort limits (``robot.effort_limits``), what the real arm's motors have.
        limit_velocity: cap every joint's commanded velocity at its URDF velocity limit
            (``robot.velocity_limits``).
        self_collision: collide the arm's links with each other (parent-child pairs and the
            pairs of :func:`lfd.sim.collision.overlapping_link_pairs` excluded).
        position_gain, velocity_gain: PyBullet position-control gains.
        torso_height: height (m) of the torso frame above the floor.
        table_z: height of the table top in the torso frame.
    """

    _arm_body = "robot_id"  # (ArmJoints) reloaded by every reset

    def __init__(
        self,
        robot: Any,
        *,
        image_size: int = 128,
        camera: Camera | None = None,
        wrist_camera: bool = False,
        control_dt: float = 4.0 / 99,
        substeps: int = 10,
        max_force: float | None = None,
        limit_velocity: bool = True,
        self_collision: bool = True,
        position_gain: float = 0.3,
        velocity_gain: float = 1.0,
        torso_height: float = 1.06,
        table_z: float = TABLE_Z,
    ) -> None:
        if not (isinstance(image_size, int) and image_size > 0):
            raise ValueError(f"ReachScene.image_size: expected a positive int, got {image_size!r}")
        if not (control_dt > 0 and isinstance(substeps, int) and substeps > 0):
            raise ValueError(
                f"ReachScene: need control_dt > 0 and substeps >= 1, got {control_dt}, {substeps}"
            )
        if not table_z < 0 < torso_height + table_z:
            raise ValueError(
                f"ReachScene: table top must lie below the torso and above the floor, got table_z={table_z}"
            )
        self.robot = robot
        self.camera = camera if camera is not None else Camera(width=image_size, height=image_size)
        self.wrist_camera = wrist_camera
        self.image_size = image_size
        self.control_dt = float(control_dt)
        self.substeps = substeps
        self.n_joints = len(robot.joint_names)
        efforts = np.asarray(getattr(robot, "effort_limits", np.full(self.n_joints, 300.0)), dtype=np.float64)
        self.forces = np.full(self.n_joints, float(max_force)) if max_force is not None else efforts
        speeds = np.asarray(
            getattr(robot, "velocity_limits", np.full(self.n_joints, np.inf)), dtype=np.float64
        )
        self.max_velocities = speeds if limit_velocity else np.full(self.n_joints, np.inf)
        self.self_collision = bool(self_collision)
        self.position_gain = float(position_gain)
        self.velocity_gain = float(velocity_gain)
        self.table_z = float(table_z)
        self.base_to_world = np.eye(4)
        self.base_to_world[2, 3] = torso_height
        self._tmpdir = Path(tempfile.mkdtemp(prefix="lfd-scene-"))
        self._urdf = self._tmpdir / "robot.urdf"
        self._urdf.write_text(robot.to_urdf())
        self.client = p.connect(p.DIRECT)
        self._backdrop_client = p.connect(p.DIRECT)
        self.lighting: Lighting | None = None
        self.table_texture: TableTexture | None = None
        self.clutter: tuple[FlatItem, ...] = ()
        self._build_backdrop()
        self.robot_id = self.table_id = self.object_id = -1
        self.object_spec: ObjectSpec | None = None
        self.placement: Placement | None = None
        self.reset()

    # ------------------------------------------------------------------ world building
    def reset(
        self,
        object_spec: ObjectSpec | None = None,
        placement: Placement | None = None,
        q: np.ndarray | None = None,
    ) -> None:
        """Rebuild the world: floor, table, the arm at ``q`` (default ``robot.home``) at
        rest, holding that pose, and ``object_spec`` standing on the table at
        ``placement`` (no object if ``object_spec`` is None)."""
        if (object_spec is None) != (placement is None):
            raise ValueError("ReachScene.reset: give both object_spec and placement, or neither")
        c = self.client
        p.resetSimulation(physicsClientId=c)
        p.setGravity(0, 0, -9.81, physicsClientId=c)
        p.setPhysicsEngineParameter(fixedTimeStep=self.control_dt / self.substeps, physicsClientId=c)
        self.table_id = self._add_static_bodies(c, visible=False)
        self.robot_id = p.loadURDF(
            str(self._urdf),
            basePosition=self.base_to_world[:3, 3].tolist(),
            useFixedBase=True,
            flags=p.URDF_USE_INERTIA_FROM_FILE
            | (
                (p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_EXCLUDE_PARENT)
                if self.self_collision
                else 0
            ),
            physicsClientId=c,
        )
        if p.getNumJoints(self.robot_id, physicsClientId=c) != self.n_joints + 1:
            raise ValueError(
                f"ReachScene: URDF must have {self.n_joints} movable joints then one fixed tool joint"
            )
        if self.self_collision:
            self._filter_overlapping_links()
        self.set_joints(self.robot.home if q is None else q)
        self.object_spec, self.placement, self.object_id = object_spec, placement, -1
        if object_spec is not None:
            self.object_id = self._add_object(object_spec, placement)

    def _filter_overlapping_links(self) -> None:
        """Switch off self-collision between the link pairs whose simplified collision shapes
        overlap by construction (:func:`lfd.sim.collision.overlapping_link_pairs`, the one
        self-collision rule); every other non-adjacent pair collides. Re-applied after each
        :meth:`reset`."""
        c, rid = self.client, self.robot_id
        self.overlapping_links = overlapping_link_pairs(self.robot, c, rid, self._urdf.read_text())
        for a, b in self.overlapping_links:
            p.setCollisionFilterPair(rid, rid, a, b, 0, physicsClientId=c)

    def _add_static_bodies(self, client: int, *, visible: bool) -> int:
        """Floor and table in ``client``, drawn (backdrop client) or transparent, which the
        TinyRenderer skips (physics client); returns the table's body id."""
        top = self.base_to_world[2, 3] + self.table_z
        table_half = ((TABLE_X[1] - TABLE_X[0]) / 2, TABLE_HALF_Y, top / 2)
        table_centre = ((TABLE_X[0] + TABLE_X[1]) / 2, 0.0, top / 2)
        ids = []
        for half, centre, rgba in (
            ((20.0, 20.0, 0.01), (0.0, 0.0, -0.01), FLOOR_RGBA),
            (table_half, table_centre, TABLE_RGBA),
        ):
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
            vis = p.createVisualShape(
                p.GEOM_BOX,
                halfExtents=half,
                rgbaColor=rgba if visible else (0, 0, 0, 0),
                physicsClientId=client,
            )
            ids.append(p.createMultiBody(0.0, col, vis, basePosition=centre, physicsClientId=client))
        return ids[1]

    def _add_object(self, spec: ObjectSpec, placement: Placement) -> int:
        c = self.client
        if spec.shape == "box":
            kw_col = kw_vis = {"halfExtents": [d / 2 for d in spec.dims]}
            geom = p.GEOM_BOX
        elif spec.shape == "sphere":
            kw_col = kw_vis = {"radius": spec.dims[0]}
            geom = p.GEOM_SPHERE
        else:
            radius, length = spec.dims
            geom = p.GEOM_CYLINDER if spec.shape == "cylinder" else p.GEOM_CAPSULE
            kw_col, kw_vis = {"radius": radius, "height": length}, {"radius": radius, "length": length}
        col = p.createCollisionShape(geom, physicsClientId=c, **kw_col)
        vis = p.createVisualShape(geom, rgbaColor=spec.rgba, physicsClientId=c, **kw_vis)
        position = self.to_world(np.array([placement.x, placement.y, self.table_z + spec.height / 2]))
        body = p.createMultiBody(
            spec.mass,
            col,
            vis,
            basePosition=position.tolist(),
            baseOrientation=yaw_quaternion(placement.yaw),
            physicsClientId=c,
        )
        p.changeDynamics(
            body,
            -1,
            rollingFriction=OBJECT_ROLLING_FRICTION,
            spinningFriction=OBJECT_ROLLING_FRICTION,
            physicsClientId=c,
        )
        return body

    def to_world(self, points: np.ndarray) -> np.ndarray:
        """Torso-frame points ``(..., 3)`` -> PyBullet world."""
        return np.asarray(points) + self.base_to_world[:3, 3]

    # ------------------------------------------------------------------ control
    def set_joints(self, q: np.ndarray) -> None:
        """Teleport the arm to ``q (n_joints,)`` at rest and command it to hold there."""
        q = _as_vector(q, self.n_joints, "q")
        for j in range(self.n_joints):
            p.resetJointState(self.robot_id, j, float(q[j]), 0.0, physicsClientId=self.client)
        self.command(q, np.zeros(self.n_joints))

    def step_velocity(self, qd_target: np.ndarray) -> None:
        """One control step of velocity control: joint velocities ``qd_target (n_joints,)``
        rad/s (clipped to the velocity limits), within the effort limits, for
        ``control_dt`` seconds. The velocity policy's actuation: the joints move at the
        command, as its labels are the demonstrations' joint motion per control period."""
        qd = np.clip(
            _as_vector(qd_target, self.n_joints, "qd_target"), -self.max_velocities, self.max_velocities
        )
        p.setJointMotorControlArray(
            self.robot_id,
            list(range(self.n_joints)),
            p.VELOCITY_CONTROL,
            targetVelocities=qd.tolist(),
            forces=self.forces.tolist(),
            physicsClientId=self.client,
        )
        for _ in range(self.substeps):
            p.stepSimulation(physicsClientId=self.client)

    def step(self, q_target: np.ndarray, qd_target: np.ndarray | None = None) -> None:
        """One control step: position control towards ``q_target (n_joints,)`` (with
        velocity feed-forward ``qd_target``, default zero) for ``control_dt`` seconds."""
        q_target = _as_vector(q_target, self.n_joints, "q_target")
        qd_target = (
            np.zeros(self.n_joints)
            if qd_target is None
            else _as_vector(qd_target, self.n_joints, "qd_target")
        )
        self.command(q_target, qd_target)
        self.step_physics(self.substeps)

    # ------------------------------------------------------------------ state
    def ee_pose(self) -> np.ndarray:
        """``(4, 4)`` tool-frame pose in the torso frame."""
        state = p.getLinkState(
            self.robot_id, self.n_joints, computeForwardKinematics=True, physicsClientId=self.client
        )
        return self._from_world(pose_matrix(state[4], state[5]))

    def tool_position(self) -> np.ndarray:
        """``(3,)`` tool position in the torso frame, m."""
        return self.ee_pose()[:3, 3]

    def object_pose(self) -> np.ndarray:
        """``(4, 4)`` pose of the object's centre in the torso frame."""
        if self.object_id < 0:
            raise ValueError("ReachScene.object_pose: the scene has no object (reset with an object_spec)")
        pos, quat = p.getBasePositionAndOrientation(self.object_id, physicsClientId=self.client)
        return self._from_world(pose_matrix(pos, quat))

    def _from_world(self, pose: np.ndarray) -> np.ndarray:
        out = pose.copy()
        out[:3, 3] -= self.base_to_world[:3, 3]
        return out

    def arm_touches(self, body: str, margin: float = 0.0) -> bool:
        """Whether any link of the arm is within ``margin`` metres of (or penetrating)
        ``body`` (``"table"`` or ``"object"``)."""
        target = {"table": self.table_id, "object": self.object_id}.get(body)
        if target is None:
            raise ValueError(f"ReachScene.arm_touches: body must be 'table' or 'object', got {body!r}")
        if target < 0:
            return False
        pts = p.getClosestPoints(self.robot_id, target, distance=margin, physicsClientId=self.client)
        return len(pts) > 0

    # ------------------------------------------------------------------ images
    def set_lighting(self, lighting: Lighting | None) -> None:
        """Render every later image (fixed and wrist camera, the table and floor included) under
        ``lighting`` (None: PyBullet's default light). Lasts across :meth:`reset`."""
        if lighting is not None and not isinstance(lighting, Lighting):
            raise ValueError(
                f"ReachScene.set_lighting: expected a Lighting or None, got {type(lighting).__name__}"
            )
        if lighting == self.lighting:
            return
        self.lighting = lighting
        self._render_backdrop()

    def set_camera(self, camera: Camera) -> None:
        """Render every later fixed-camera image through ``camera`` (its size must be the
        scene's). Lasts across :meth:`reset`.

        Raises:
            ValueError: ``camera`` is not a Camera of the scene's image size.
        """
        if not isinstance(camera, Camera):
            raise ValueError(f"ReachScene.set_camera: expected a Camera, got {type(camera).__name__}")
        if (camera.width, camera.height) != (self.camera.width, self.camera.height):
            raise ValueError(
                f"ReachScene.set_camera: expected a {self.camera.width}x{self.camera.height} camera "
                f"(the scene's image size), got {camera.width}x{camera.height}"
            )
        if camera == self.camera:
            return
        self.camera = camera
        self._render_backdrop()

    def set_table_texture(self, texture: TableTexture | None) -> None:
        """Draw the table top of every later image (fixed and wrist camera) with ``texture``
        (None: the plain grey table). Lasts across :meth:`reset`; the depth does not change."""
        if texture is not None and not isinstance(texture, TableTexture):
            raise ValueError(
                f"ReachScene.set_table_texture: expected a TableTexture or None, got {type(texture).__name__}"
            )
        if texture == self.table_texture:
            return
        self.table_texture = texture
        self._build_backdrop()

    def set_clutter(self, items: tuple[FlatItem, ...] | list[FlatItem]) -> None:
        """Lay ``items`` (:class:`~lfd.sim.clutter.FlatItem`, torso frame) on the table in every
        later image (fixed and wrist camera, colour and depth); ``()`` clears the table. They are
        drawn, not simulated: the arm and the object pass through them. Lasts across :meth:`reset`."""
        items = tuple(items)
        if not all(isinstance(i, FlatItem) for i in items):
            raise ValueError("ReachScene.set_clutter: expected a sequence of FlatItem")
        if items == self.clutter:
            return
        self.clutter = items
        self._build_backdrop()

    def _build_backdrop(self) -> None:
        """(Re)build the backdrop client's floor and table, the table with :attr:`table_texture`
        and :attr:`clutter` on it, and render it."""
        c, texture = self._backdrop_client, self.table_texture
        p.resetSimulation(physicsClientId=c)
        table = self._add_static_bodies(c, visible=True)
        if texture is not None:
            # one file per texture: PyBullet caches textures by file name, even across resetSimulation
            path = self._tmpdir / f"table-{hashlib.sha1(texture.as_array().tobytes()).hexdigest()[:16]}.png"
            if not path.exists():
                cv2.imwrite(str(path), texture.image()[..., ::-1])  # RGB -> OpenCV's BGR
            tex = p.loadTexture(str(path), physicsClientId=c)
            p.changeVisualShape(table, -1, textureUniqueId=tex, rgbaColor=[1, 1, 1, 1], physicsClientId=c)
        for item in self.clutter:
            half = (item.length / 2, item.width / 2, item.height / 2)
            vis = p.createVisualShape(
                p.GEOM_BOX, halfExtents=half, rgbaColor=(*item.colour, 1.0), physicsClientId=c
            )
            centre = self.base_to_world @ np.array([item.x, item.y, self.table_z + half[2], 1.0])
            p.createMultiBody(
                0.0,
                -1,
                vis,
                basePosition=centre[:3].tolist(),
                baseOrientation=yaw_quaternion(item.yaw),
                physicsClientId=c,
            )
        self._render_backdrop()

    def _render_backdrop(self) -> None:
        """Render the backdrop (table and floor) through the camera under the light."""
        self._backdrop, self._backdrop_depth = self.camera.render(
            self._backdrop_client, self.base_to_world, with_depth=True, lighting=self.lighting
        )

    def render(self, with_depth: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """RGB frame ``(H, W, 3)`` uint8 of the fixed camera; with ``with_depth`` the pair
        ``(rgb, depth)``, depth ``(H, W)`` uint16 mm along the optical axis (one render call;
        :func:`lfd.sim.depth.rgbd_image` turns the pair into a policy's RGB-D input)."""
        return self.camera.render(
            self.client,
            self.base_to_world,
            self._backdrop,
            backdrop_depth=self._backdrop_depth,
            with_depth=with_depth,
            lighting=self.lighting,
        )

    def render_wrist(self) -> np.ndarray:
        """RGB frame ``(H, W, 3)`` uint8 of a camera 12 cm behind and 5 cm above the tool
        frame, looking 10 cm past the tool along the gripper."""
        tool = self.ee_pose()
        x_axis, z_axis, origin = tool[:3, 0], tool[:3, 2], tool[:3, 3]
        cam = Camera(
            eye=tuple(origin - 0.12 * x_axis + 0.05 * z_axis),
            target=tuple(origin + 0.10 * x_axis),
            up=tuple(z_axis),
            fov_deg=70.0,
            width=self.image_size,
            height=self.image_size,
            near=0.02,
        )
        backdrop = cam.render(self._backdrop_client, self.base_to_world, lighting=self.lighting)
        return cam.render(self.client, self.base_to_world, backdrop, lighting=self.lighting)

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        """Disconnect the PyBullet clients and remove the temp URDF (idempotent)."""
        if self.client >= 0:
            p.disconnect(physicsClientId=self.client)
            p.disconnect(physicsClientId=self._backdrop_client)
            self.client = -1
        shutil.rmtree(self._tmpdir, ignore_errors=True)

    def __del__(self) -> None:
        if getattr(self, "client", -1) >= 0:
            self.close()


def _as_vector(x, n: int, name: str) -> np.ndarray:
    """``x`` (numpy, torch or sequence) as a finite float64 ``(n,)`` array."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    arr = np.asarray(x, dtype=np.float64).reshape(-1)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"ReachScene: {name} must be {n} finite values, got shape {np.shape(x)}")
    return arr
