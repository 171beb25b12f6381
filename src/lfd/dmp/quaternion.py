"""Batched unit-quaternion helpers ``[w, x, y, z]`` (numpy), for :class:`lfd.dmp.CartesianDMP`.

Rotation vectors are ``axis * angle`` (radians); ``exp`` / ``log`` map between them and unit
quaternions (``log`` returns the full rotation vector, i.e. Ude et al.'s ``2 log q``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["conjugate", "continuous", "exp", "log", "multiply", "normalise", "unwrap"]


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p q`` of ``(..., 4)`` quaternions."""
    pw, px, py, pz = np.moveaxis(p, -1, 0)
    qw, qx, qy, qz = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def conjugate(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` conjugates (inverses of unit quaternions)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def normalise(q: np.ndarray) -> np.ndarray:
    """``(..., 4)`` quaternions scaled to unit norm."""
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def exp(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)`` of rotation vectors ``(..., 3)`` (radians)."""
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(a/2)/a, with its Taylor series near 0
    scale = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0), 0.5 - angle**2 / 48.0)
    return np.concatenate([np.cos(half), scale * rotvec], axis=-1)


def log(q: np.ndarray) -> np.ndarray:
    """Rotation vectors ``(..., 3)`` (radians, angle in ``[0, pi]``) of unit quaternions ``(..., 4)``.

    ``q`` and ``-q`` give the same rotation vector (the shorter way round).
    """
    q = np.where(q[..., :1] < 0, -q, q)
    vector = q[..., 1:]
    norm = np.linalg.norm(vector, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(norm, q[..., :1])
    scale = np.where(norm > 1e-12, angle / np.where(norm > 1e-12, norm, 1.0), 2.0)
    return scale * vector


def continuous(q: np.ndarray, axis: int = -2) -> np.ndarray:
    """Flip signs along ``axis`` (time) so consecutive quaternions lie in the same hemisphere."""
    q = np.moveaxis(np.array(q, dtype=np.float64), axis, 0)
    for n in range(1, q.shape[0]):
        flip = np.sum(q[n] * q[n - 1], axis=-1, keepdims=True) < 0
        q[n] = np.where(flip, -q[n], q[n])
    return np.moveaxis(q, 0, axis)


def unwrap(rotvec: np.ndarray, axis: int = -2) -> np.ndarray:
    """Make a sequence of rotation vectors ``(..., T, 3)`` continuous along ``axis`` (time).

    ``r`` and ``r - 2 pi k r / |r|`` are the same rotation; at each sample the one nearest to
    the previous sample is kept (``|k| <= 2``), so a rotation that passes ``pi`` does not jump.
    """
    r = np.moveaxis(np.array(rotvec, dtype=np.float64), axis, 0)
    for n in range(1, r.shape[0]):
        norm = np.linalg.norm(r[n], axis=-1, keepdims=True)
        unit = r[n] / np.where(norm > 1e-12, norm, 1.0)
        candidates = np.stack([r[n] + 2.0 * np.pi * k * unit for k in (-2, -1, 0, 1, 2)])
        best = np.argmin(np.linalg.norm(candidates - r[n - 1], axis=-1), axis=0)
        r[n] = np.take_along_axis(candidates, best[None, ..., None], axis=0)[0]
    return np.moveaxis(r, 0, axis)
