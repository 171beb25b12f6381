"""Trunk frame from spine and shoulder joints.

Per frame the trunk frame has its origin at ``spine_shoulder`` (the base of the neck; the
shoulder midpoint when the source has no such joint) and axes

* ``z`` (up): from ``spine_base`` to ``spine_shoulder`` (the hip midpoint stands in for a
  missing ``spine_base``; the source's ``up`` vector when neither exists);
* ``y`` (left): ``shoulder_left - shoulder_right`` made orthogonal to ``z``;
* ``x`` (forward): ``y x z``.

This is the base frame of the human-arm model (x forward, y left, z up), so joint angles do
not depend on where the camera stands.
"""

from __future__ import annotations

import numpy as np

from .skeleton import Skeleton

__all__ = ["to_trunk", "trunk_frames"]


def _unit(v: np.ndarray, what: str) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = v / n
    return np.where(n > 1e-9, out, np.nan)


def trunk_frames(skeleton: Skeleton, positions: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Trunk frames of every frame.

    Args:
        skeleton: provides joint names and the ``up`` vector.
        positions: (T, J, 3) m to use instead of ``skeleton.positions`` (e.g. filtered).

    Returns:
        ``(rotation (T, 3, 3), origin (T, 3))``: columns of ``rotation`` are the trunk x, y, z
        axes in the source frame; NaN where a needed joint is missing.

    Raises:
        ValueError: the skeleton lacks ``shoulder_left``/``shoulder_right``.
    """
    pos = skeleton.positions if positions is None else positions
    if not skeleton.has("shoulder_left", "shoulder_right"):
        raise ValueError(
            "trunk frame needs joints shoulder_left and shoulder_right; "
            f"{skeleton.source or 'skeleton'} has {skeleton.names}"
        )

    def joint(name):
        return pos[:, skeleton.names.index(name)]

    left, right = joint("shoulder_left"), joint("shoulder_right")
    top = joint("spine_shoulder") if skeleton.has("spine_shoulder") else 0.5 * (left + right)
    if skeleton.has("spine_base"):
        bottom = joint("spine_base")
    elif skeleton.has("hip_left", "hip_right"):
        bottom = 0.5 * (joint("hip_left") + joint("hip_right"))
    else:
        bottom = top - skeleton.up
    z = _unit(top - bottom, "trunk z")
    lateral = left - right
    y = _unit(lateral - (lateral * z).sum(-1, keepdims=True) * z, "trunk y")
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=-1), top


def to_trunk(points: np.ndarray, rotation: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Express points ``(T, ..., 3)`` (source frame) in the trunk frames ``(T, 3, 3)``, ``(T, 3)``."""
    rel = points - origin.reshape(origin.shape[0], *([1] * (points.ndim - 2)), 3)
    return np.einsum("tij,t...i->t...j", rotation, rel)
