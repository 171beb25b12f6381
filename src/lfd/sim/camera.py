"""Pinhole cameras: OpenGL view/projection matrices, PyBullet rendering, point projection.

Matrices are ordinary row-major ``(4, 4)`` numpy arrays acting on column vectors
(``clip = P @ V @ [x, y, z, 1]``); PyBullet wants them flattened column-major, which
:func:`to_pybullet` does. Pixel coordinates are ``(u, v)`` with ``u`` to the right and
``v`` down, ``(0, 0)`` the top-left corner of the top-left pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from lfd.sim._pybullet import pybullet as p
from lfd.sim.depth import depth_to_mm, linear_depth, plane_depth_mm
from lfd.sim.projection import project_points

#: Direction towards the light (world frame) of the default lighting.
LIGHT_DIRECTION = (0.4, -0.3, 1.0)
#: Ranges of :func:`sample_lighting`: the light's elevation above the table (degrees; its
#: azimuth is uniform), TinyRenderer's ambient and diffuse coefficients (the defaults are 0.6
#: and 0.35: from a dim room to a bright one) and the largest change of each colour channel of
#: the light (warm to cool white).
LIGHTING_RANGES = {"elevation_deg": (30.0, 90.0), "ambient": (0.4, 0.8), "diffuse": (0.2, 0.5), "tint": 0.15}
#: Ranges of :func:`jitter_camera`: the largest shift of the eye and of the point looked at
#: along each axis (m) and the largest roll about the viewing direction (degrees). A camera
#: put back on its mount, or a tripod bumped: a few centimetres, a degree or two of roll.
CAMERA_JITTER = {"eye_m": 0.02, "target_m": 0.03, "roll_deg": 2.0}


@dataclass(frozen=True)
class Lighting:
    """TinyRenderer's directional light.

    Attributes:
        direction: towards the light (world frame; any length > 0).
        colour: RGB of the light, each in ``[0, 1]``.
        ambient, diffuse, specular: shading coefficients, each in ``[0, 1]``.

    The defaults are PyBullet's own (:data:`LIGHT_DIRECTION`, white, 0.6, 0.35, 0.05): a
    default ``Lighting()`` renders exactly what rendering without one does.

    Raises:
        ValueError: naming the field when a value is invalid.
    """

    direction: tuple[float, float, float] = LIGHT_DIRECTION
    colour: tuple[float, float, float] = (1.0, 1.0, 1.0)
    ambient: float = 0.6
    diffuse: float = 0.35
    specular: float = 0.05

    def __post_init__(self) -> None:
        direction = tuple(float(v) for v in self.direction)
        if (
            len(direction) != 3
            or not all(math.isfinite(v) for v in direction)
            or math.hypot(*direction) < 1e-9
        ):
            raise ValueError(f"Lighting.direction: expected 3 finite values, not all 0, got {self.direction}")
        colour = tuple(float(v) for v in self.colour)
        if len(colour) != 3 or not all(0.0 <= v <= 1.0 for v in colour):
            raise ValueError(f"Lighting.colour: expected 3 values in [0, 1], got {self.colour}")
        for name in ("ambient", "diffuse", "specular"):
            value = float(getattr(self, name))
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"Lighting.{name}: expected a value in [0, 1], got {value}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "direction", direction)
        object.__setattr__(self, "colour", colour)

    def as_array(self) -> np.ndarray:
        """``(9,)`` float64: direction, colour, ambient, diffuse, specular (the
        ``lighting`` array of a dataset episode)."""
        return np.array([*self.direction, *self.colour, self.ambient, self.diffuse, self.specular])

    @classmethod
    def from_array(cls, a: np.ndarray) -> Lighting:
        a = np.asarray(a, dtype=np.float64).reshape(-1)
        if a.shape != (9,):
            raise ValueError(f"Lighting.from_array: expected 9 values, got {a.shape[0]}")
        return cls(tuple(a[:3]), tuple(a[3:6]), *a[6:].tolist())

    def pybullet_kwargs(self) -> dict:
        """The keyword arguments of ``pybullet.getCameraImage`` for this light."""
        return {
            "lightDirection": list(self.direction),
            "lightColor": list(self.colour),
            "lightAmbientCoeff": self.ambient,
            "lightDiffuseCoeff": self.diffuse,
            "lightSpecularCoeff": self.specular,
        }


#: PyBullet's default light (what a render with ``lighting=None`` passes).
DEFAULT_LIGHTING = Lighting()


def sample_lighting(rng: np.random.Generator) -> Lighting:
    """A random :class:`Lighting` from :data:`LIGHTING_RANGES`: azimuth uniform, elevation,
    ambient and diffuse uniform in their ranges, each colour channel ``1 - U(0, tint)``, the
    specular coefficient PyBullet's."""
    r = LIGHTING_RANGES
    azimuth = rng.uniform(0.0, 2 * math.pi)
    elevation = math.radians(rng.uniform(*r["elevation_deg"]))
    direction = (
        math.cos(elevation) * math.cos(azimuth),
        math.cos(elevation) * math.sin(azimuth),
        math.sin(elevation),
    )
    colour = tuple(1.0 - rng.uniform(0.0, r["tint"], size=3))
    return Lighting(direction, colour, rng.uniform(*r["ambient"]), rng.uniform(*r["diffuse"]))


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """OpenGL view matrix ``(4, 4)`` (same as ``pybullet.computeViewMatrix``): maps points
    from the frame ``eye``/``target``/``up`` are given in to camera coordinates (camera
    looking down its -z axis, y up)."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    side = np.cross(forward, up)
    norm = np.linalg.norm(side)
    if norm < 1e-9:
        raise ValueError("look_at: 'up' must not be parallel to the viewing direction")
    side /= norm
    true_up = np.cross(side, forward)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = side, true_up, -forward
    view[:3, 3] = -view[:3, :3] @ eye
    return view


def perspective(fov_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL projection matrix ``(4, 4)`` (same as ``pybullet.computeProjectionMatrixFOV``);
    ``fov_deg`` is the vertical field of view."""
    f = 1.0 / math.tan(math.radians(fov_deg) / 2)
    proj = np.zeros((4, 4))
    proj[0, 0], proj[1, 1] = f / aspect, f
    proj[2, 2] = (far + near) / (near - far)
    proj[2, 3] = 2 * far * near / (near - far)
    proj[3, 2] = -1.0
    return proj


def to_pybullet(matrix: np.ndarray) -> list[float]:
    """Flatten a ``(4, 4)`` matrix column-major, as PyBullet expects."""
    return [float(v) for v in np.asarray(matrix).T.reshape(-1)]


@dataclass(frozen=True)
class Camera:
    """A fixed pinhole camera; ``eye``/``target``/``up`` in the robot base (torso) frame.

    The default sits 0.45 m above the torso origin, roughly where the PR2 head camera is,
    and looks down at the middle of the placement area on the table top; at 45 degrees
    it sees the whole placement area (x 0.45..0.70 m, y -0.30..0.30 m) with a margin.
    """

    eye: tuple[float, float, float] = (0.0, 0.0, 0.45)
    target: tuple[float, float, float] = (0.58, 0.0, -0.33)
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    fov_deg: float = 45.0
    width: int = 128
    height: int = 128
    near: float = 0.05
    far: float = 4.0

    def __post_init__(self) -> None:
        if not (
            isinstance(self.width, int)
            and isinstance(self.height, int)
            and self.width > 0
            and self.height > 0
        ):
            raise ValueError(
                f"Camera: width and height must be positive ints, got {self.width}x{self.height}"
            )
        if not 0 < self.fov_deg < 180:
            raise ValueError(f"Camera.fov_deg: must lie in (0, 180), got {self.fov_deg}")
        if not 0 < self.near < self.far:
            raise ValueError(f"Camera: need 0 < near < far, got near={self.near}, far={self.far}")

    def pose_array(self) -> np.ndarray:
        """``(9,)`` float64: eye, target, up (the ``camera_pose`` array of a dataset episode
        whose camera was jittered)."""
        return np.array([*self.eye, *self.target, *self.up], dtype=np.float64)

    def with_pose(self, pose: np.ndarray) -> Camera:
        """This camera with eye, target and up from a :meth:`pose_array`.

        Raises:
            ValueError: ``pose`` is not 9 finite values.
        """
        a = np.asarray(pose, dtype=np.float64).reshape(-1)
        if a.shape != (9,) or not np.all(np.isfinite(a)):
            raise ValueError(
                f"Camera.with_pose: expected 9 finite values (eye, target, up), got {a.shape[0]}"
            )
        return replace(
            self, eye=tuple(a[:3].tolist()), target=tuple(a[3:6].tolist()), up=tuple(a[6:].tolist())
        )

    @property
    def view_matrix(self) -> np.ndarray:
        """``(4, 4)`` view matrix acting on torso-frame points."""
        return look_at(np.array(self.eye), np.array(self.target), np.array(self.up))

    @property
    def projection_matrix(self) -> np.ndarray:
        return perspective(self.fov_deg, self.width / self.height, self.near, self.far)

    def plane_depth_mm(self, plane_z: float) -> np.ndarray:
        """``(height, width)`` mm: the depth of the horizontal plane ``z = plane_z`` (torso
        frame) per pixel (:func:`plane_depth_mm`), the relief reference of :func:`lfd.sim.depth.rgbd_image`."""
        return plane_depth_mm(self.view_matrix, self.projection_matrix, self.width, self.height, plane_z)

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates ``(..., 2)`` of torso-frame ``points (..., 3)``."""
        return project_points(points, self.view_matrix, self.projection_matrix, self.width, self.height)

    def render(
        self,
        client: int,
        base_to_world: np.ndarray,
        backdrop: np.ndarray | None = None,
        *,
        backdrop_depth: np.ndarray | None = None,
        with_depth: bool = False,
        lighting: Lighting | None = None,
    ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """RGB image ``(height, width, 3)`` uint8 from PyBullet's TinyRenderer, and with
        ``with_depth`` also the depth image ``(height, width)`` uint16 mm (same render call).

        Args:
            client: PyBullet physics client id.
            base_to_world: ``(4, 4)`` pose of the torso frame in the PyBullet world.
            backdrop: ``(height, width, 3)`` uint8 image shown where nothing of ``client``
                was drawn (see :class:`~lfd.sim.scene.ReachScene`), else white.
            backdrop_depth: ``(height, width)`` uint16 mm depth of the backdrop, used where
                nothing of ``client`` was drawn (else ``far``).
            with_depth: return ``(rgb, depth_mm)``.
            lighting: the light (None: PyBullet's default light from :data:`LIGHT_DIRECTION`).
        """
        view = self.view_matrix @ np.linalg.inv(base_to_world)
        _, _, rgba, depth, _ = p.getCameraImage(
            self.width,
            self.height,
            viewMatrix=to_pybullet(view),
            projectionMatrix=to_pybullet(self.projection_matrix),
            renderer=p.ER_TINY_RENDERER,
            # every coefficient, every time: TinyRenderer keeps the last values it was given
            **(lighting if lighting is not None else DEFAULT_LIGHTING).pybullet_kwargs(),
            shadow=0,
            flags=p.ER_NO_SEGMENTATION_MASK,
            physicsClientId=client,
        )
        rgb = np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)[..., :3]
        buffer = np.asarray(depth, dtype=np.float64).reshape(self.height, self.width)
        empty = buffer >= 1.0
        rgb = rgb.copy() if backdrop is None else np.where(empty[..., None], backdrop, rgb)
        if not with_depth:
            return rgb
        depth_mm = depth_to_mm(linear_depth(buffer, self.near, self.far))
        if backdrop_depth is not None:
            depth_mm = np.where(empty, backdrop_depth, depth_mm)
        return rgb, depth_mm


def jitter_camera(camera: Camera, rng: np.random.Generator) -> Camera:
    """``camera`` moved a little (:data:`CAMERA_JITTER`): eye and target each shifted by
    ``U(-r, r)`` per axis, the up vector rolled about the new viewing direction by
    ``U(-roll, roll)`` degrees; intrinsics (field of view, size, clipping) unchanged."""
    r = CAMERA_JITTER
    eye = np.asarray(camera.eye, dtype=np.float64) + rng.uniform(-r["eye_m"], r["eye_m"], 3)
    target = np.asarray(camera.target, dtype=np.float64) + rng.uniform(-r["target_m"], r["target_m"], 3)
    forward = (target - eye) / np.linalg.norm(target - eye)
    up = np.asarray(camera.up, dtype=np.float64)
    up = up - forward * (up @ forward)  # the up vector look_at actually uses
    up /= np.linalg.norm(up)
    roll = math.radians(rng.uniform(-r["roll_deg"], r["roll_deg"]))
    up = up * math.cos(roll) + np.cross(forward, up) * math.sin(roll)  # Rodrigues, up _|_ forward
    return replace(camera, eye=tuple(eye.tolist()), target=tuple(target.tolist()), up=tuple(up.tolist()))


def third_person_camera(width: int = 640, height: int = 480) -> Camera:
    """A camera a person would watch a rollout through: to the right of and in front of
    the robot (torso frame), looking at the arm and the placement area from outside, at a
    watchable resolution (default 640 x 480). Not a policy input."""
    return Camera(
        eye=(0.95, -1.45, 0.55),
        target=(0.35, -0.05, -0.18),
        up=(0.0, 0.0, 1.0),
        fov_deg=50.0,
        width=width,
        height=height,
        near=0.05,
        far=6.0,
    )
