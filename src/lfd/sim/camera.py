"""Pinhole cameras: OpenGL view/projection matrices, PyBullet rendering, point projection.

Matrices are ordinary row-major ``(4, 4)`` numpy arrays acting on column vectors
(``clip = P @ V @ [x, y, z, 1]``); PyBullet wants them flattened column-major, which
:func:`to_pybullet` does. Pixel coordinates are ``(u, v)`` with ``u`` to the right and
``v`` down, ``(0, 0)`` the top-left corner of the top-left pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

#: Direction towards the light (world frame) used for every rendering.
LIGHT_DIRECTION = (0.4, -0.3, 1.0)

#: Metric depth range (m, along the optical axis) mapped onto the 0..255 depth channel of
#: :func:`rgbd_image`: 4.9 mm per level; nearer is 0, farther (and "nothing") is 255.
DEPTH_RANGE_M = (0.25, 1.5)

#: Encodings of the RGB-D depth channel (:func:`rgbd_image`): ``"range"`` (the depth over
#: :data:`DEPTH_RANGE_M`) or ``"relief"`` (how far a surface stands in front of the table
#: plane, :data:`RELIEF_RANGE_MM`).
DEPTH_ENCODINGS = ("range", "relief")
#: Relief encoding: a surface ``r`` mm in front of the table plane along the optical axis
#: (less :data:`RELIEF_DEADBAND_MM`, which keeps the rendered table top at 0: it lies 1.5 to
#: 4.7 mm off the geometric plane at 96 px) maps to ``255 r / RELIEF_RANGE_MM``: 1.6 mm per
#: level, 3 times finer than the range encoding, and 0 for the table and everything behind
#: its plane. The tallest objects (24 cm) stand up to ~0.37 m in front of it.
RELIEF_RANGE_MM = 400.0
RELIEF_DEADBAND_MM = 5.0


def linear_depth(buffer: np.ndarray, near: float, far: float) -> np.ndarray:
    """Metric depth (m, along the optical axis) from an OpenGL depth buffer in ``[0, 1]``
    (PyBullet's ``getCameraImage`` depth) of a perspective camera with ``near``/``far``
    clip planes (m); a buffer value of 1 (nothing drawn) gives ``far``."""
    d = np.asarray(buffer, dtype=np.float64)
    return far * near / (far - (far - near) * d)


def depth_to_mm(depth_m: np.ndarray) -> np.ndarray:
    """Metric depth (m) -> uint16 millimetres, the usual depth-image format of RGB-D
    cameras (clipped to 0..65535)."""
    return np.clip(np.rint(np.asarray(depth_m, dtype=np.float64) * 1000.0), 0, 65535).astype(np.uint16)


def rgbd_image(
    rgb: np.ndarray, depth_mm: np.ndarray, relief_reference: np.ndarray | None = None
) -> np.ndarray:
    """RGB-D policy input: uint8 ``(..., H, W, 3)`` colour and uint16 ``(..., H, W)`` depth
    (mm) -> uint8 ``(..., H, W, 4)``, the 4th channel the depth mapped linearly from
    :data:`DEPTH_RANGE_M` onto 0..255 (clipped). Datasets and closed-loop evaluation both
    build policy inputs with this function, so training and execution see the same encoding.

    With ``relief_reference`` (``(H, W)`` mm, the table plane's depth per pixel:
    :func:`plane_depth_mm`) the 4th channel is the *relief* encoding instead
    (:data:`RELIEF_RANGE_MM`): ``reference - depth - RELIEF_DEADBAND_MM`` mapped from
    ``0..RELIEF_RANGE_MM`` onto 0..255, 0 on the table and behind it. The background drops
    out and the object's shape (a cylinder's curved front against a box's flat face) gets
    3 times as many levels.

    Example:
        >>> rgbd_image(np.zeros((1, 2, 3), np.uint8), np.array([[250, 1500]], np.uint16))[..., 3].tolist()
        [[0, 255]]
    """
    rgb, depth_mm = np.asarray(rgb), np.asarray(depth_mm)
    if rgb.dtype != np.uint8 or rgb.shape[-1] != 3 or depth_mm.shape != rgb.shape[:-1]:
        raise ValueError(
            f"rgbd_image: need uint8 rgb (..., H, W, 3) and depth (..., H, W) of the same H, W; "
            f"got {rgb.dtype} {rgb.shape} and {depth_mm.shape}"
        )
    if relief_reference is not None:
        reference = np.asarray(relief_reference, dtype=np.float64)
        if reference.shape != depth_mm.shape[-2:]:
            raise ValueError(
                f"rgbd_image.relief_reference: expected (H, W) = {depth_mm.shape[-2:]}, got {reference.shape}"
            )
        relief = (reference - depth_mm.astype(np.float64) - RELIEF_DEADBAND_MM) / RELIEF_RANGE_MM
        channel = np.rint(np.clip(relief, 0.0, 1.0) * 255.0).astype(np.uint8)
        return np.concatenate([rgb, channel[..., None]], axis=-1)
    low, high = DEPTH_RANGE_M
    scaled = (depth_mm.astype(np.float32) / 1000.0 - low) / (high - low)
    channel = np.rint(np.clip(scaled, 0.0, 1.0) * 255.0).astype(np.uint8)
    return np.concatenate([rgb, channel[..., None]], axis=-1)


def plane_depth_mm(
    view: np.ndarray, projection: np.ndarray, width: int, height: int, plane_z: float
) -> np.ndarray:
    """``(height, width)`` float64: the depth (mm, along the optical axis) at which the ray
    through each pixel's centre meets the horizontal plane ``z = plane_z`` of the frame
    ``view`` acts on (for :class:`Camera`, the torso frame); 0 where the ray never meets it
    in front of the camera. ``view``/``projection``: ``(4, 4)`` OpenGL matrices
    (:func:`look_at`, :func:`perspective`), as the datasets record them."""
    view, projection = np.asarray(view, dtype=np.float64), np.asarray(projection, dtype=np.float64)
    if view.shape != (4, 4) or projection.shape != (4, 4):
        raise ValueError(
            f"plane_depth_mm: view and projection must be (4, 4), got {view.shape} and {projection.shape}"
        )
    u = (np.arange(width) + 0.5) / width * 2 - 1
    v = 1 - (np.arange(height) + 0.5) / height * 2
    ones = np.ones((height, width))
    ray_cam = np.stack(
        [u[None, :] / projection[0, 0] * ones, v[:, None] / projection[1, 1] * ones, -ones], axis=-1
    )
    ray = ray_cam @ view[:3, :3]  # camera -> frame (the rotation's transpose); depth 1 along the axis
    eye = -view[:3, :3].T @ view[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (plane_z - eye[2]) / ray[..., 2]
    return np.where(np.isfinite(s) & (s > 0), s * 1000.0, 0.0)


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


def project_points(
    points: np.ndarray, view: np.ndarray, proj: np.ndarray, width: int, height: int
) -> np.ndarray:
    """Pixel coordinates ``(..., 2)`` of ``points (..., 3)`` (given in the frame ``view``
    was built in). Points behind the camera give NaN."""
    pts = np.asarray(points, dtype=np.float64)
    homo = np.concatenate([pts, np.ones(pts.shape[:-1] + (1,))], axis=-1)
    clip = homo @ (proj @ view).T
    w = clip[..., 3:4]
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = np.where(w > 0, clip[..., :2] / w, np.nan)
    u = (ndc[..., 0] + 1) / 2 * width
    v = (1 - ndc[..., 1]) / 2 * height
    return np.stack([u, v], axis=-1)


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

    @property
    def view_matrix(self) -> np.ndarray:
        """``(4, 4)`` view matrix acting on torso-frame points."""
        return look_at(np.array(self.eye), np.array(self.target), np.array(self.up))

    @property
    def projection_matrix(self) -> np.ndarray:
        return perspective(self.fov_deg, self.width / self.height, self.near, self.far)

    def plane_depth_mm(self, plane_z: float) -> np.ndarray:
        """``(height, width)`` mm: the depth of the horizontal plane ``z = plane_z`` (torso
        frame) per pixel (:func:`plane_depth_mm`), the relief reference of :func:`rgbd_image`."""
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
        """
        view = self.view_matrix @ np.linalg.inv(base_to_world)
        _, _, rgba, depth, _ = p.getCameraImage(
            self.width,
            self.height,
            viewMatrix=to_pybullet(view),
            projectionMatrix=to_pybullet(self.projection_matrix),
            renderer=p.ER_TINY_RENDERER,
            lightDirection=list(LIGHT_DIRECTION),
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
