"""Pinhole projection of 3-D points to pixels with OpenGL view/projection matrices. Pure NumPy:
datasets and policies that label images with where a point appears do not load PyBullet
(:mod:`lfd.sim.camera` builds the matrices and renders).

Matrices are row-major ``(4, 4)`` arrays acting on column vectors (``clip = P @ V @ [x, y, z, 1]``);
pixel coordinates are ``(u, v)``, ``u`` to the right and ``v`` down, ``(0, 0)`` the top-left corner
of the top-left pixel (a pixel's centre at ``+0.5``).
"""

from __future__ import annotations

import numpy as np


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
