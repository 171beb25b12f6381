"""Depth images as policy input: metric depth <-> uint16 mm, and the 4th (depth) channel of an
RGB-D image in its two encodings (``"range"``, ``"relief"``). Pure NumPy: no renderer, so the
policies and datasets that build or check RGB-D inputs do not load PyBullet
(:mod:`lfd.sim.camera` renders the depth).
"""

from __future__ import annotations

import numpy as np

#: Metric depth range (m, along the optical axis) mapped onto the 0..255 depth channel of
#: :func:`rgbd_image`: 4.9 mm per level; nearer is 0, farther (and "nothing") is 255.
DEPTH_RANGE_M = (0.25, 1.5)

#: Encodings of the RGB-D depth channel (:func:`rgbd_image`): ``"range"`` (the depth over
#: :data:`DEPTH_RANGE_M`) or ``"relief"`` (how far a surface stands in front of the table
#: plane, :data:`RELIEF_RANGE_MM`).
DEPTH_ENCODINGS = ("range", "relief")
#: Relief encoding: a surface ``r`` mm in front of the table plane along the optical axis
#: (less :data:`RELIEF_DEADBAND_MM`, which keeps the rendered table top, a few mm off the
#: geometric plane, at 0) maps to ``255 r / RELIEF_RANGE_MM``: 1.6 mm per
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
    ``view`` acts on (for :class:`lfd.sim.camera.Camera`, the torso frame); 0 where the ray never meets it
    in front of the camera. ``view``/``projection``: ``(4, 4)`` OpenGL matrices
    (:func:`lfd.sim.camera.look_at`, :func:`lfd.sim.camera.perspective`), as the datasets record them."""
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
