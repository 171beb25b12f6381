"""Spatial maths on NumPy arrays: rotation matrices to unit quaternions, in either order.

The one owner of matrix -> quaternion conversion (the teach app's scene poses, robomimic's
``robot0_eef_quat``). Quaternions are ``(..., 4)``; ``"wxyz"`` puts the scalar first (viser,
:mod:`lfd.dmp.quaternion`), ``"xyzw"`` last (robomimic, SciPy, PyBullet). The sign is fixed so
that ``w >= 0``.

Example::

    >>> import numpy as np
    >>> matrix_to_quaternion(np.eye(3))
    array([1., 0., 0., 0.])
    >>> matrix_to_quaternion(np.eye(3)[None].repeat(2, 0), order="xyzw").shape
    (2, 4)
"""

from __future__ import annotations

import numpy as np

__all__ = ["QUATERNION_ORDERS", "matrix_to_quaternion"]

#: Component orders of :func:`matrix_to_quaternion`.
QUATERNION_ORDERS = ("wxyz", "xyzw")


def matrix_to_quaternion(R: np.ndarray, order: str = "wxyz") -> np.ndarray:
    """Unit quaternions ``(..., 4)`` of rotation matrices ``(..., 3, 3)``, with ``w >= 0``.

    Shepperd's method: the largest of the trace and the three diagonal entries picks the
    formula, so no division is by a small number.

    Raises:
        ValueError: ``R`` is not ``(..., 3, 3)``, is not finite, or ``order`` is unknown.
    """
    R = np.asarray(R, dtype=np.float64)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise ValueError(f"R: expected rotation matrices of shape (..., 3, 3), got {R.shape}")
    if not np.all(np.isfinite(R)):
        raise ValueError("R: rotation matrices must be finite (got NaN or inf)")
    if order not in QUATERNION_ORDERS:
        raise ValueError(f"order: expected one of {QUATERNION_ORDERS}, got {order!r}")
    m = R.reshape(-1, 3, 3)
    m00, m11, m22 = m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]
    tr = m00 + m11 + m22
    # one candidate (w, x, y, z) per branch, then pick
    with np.errstate(divide="ignore", invalid="ignore"):
        s0 = 2.0 * np.sqrt(np.maximum(tr + 1.0, 0.0))
        q0 = np.stack(
            [
                0.25 * s0,
                (m[:, 2, 1] - m[:, 1, 2]) / s0,
                (m[:, 0, 2] - m[:, 2, 0]) / s0,
                (m[:, 1, 0] - m[:, 0, 1]) / s0,
            ],
            -1,
        )
        s1 = 2.0 * np.sqrt(np.maximum(1.0 + m00 - m11 - m22, 0.0))
        q1 = np.stack(
            [
                (m[:, 2, 1] - m[:, 1, 2]) / s1,
                0.25 * s1,
                (m[:, 0, 1] + m[:, 1, 0]) / s1,
                (m[:, 0, 2] + m[:, 2, 0]) / s1,
            ],
            -1,
        )
        s2 = 2.0 * np.sqrt(np.maximum(1.0 + m11 - m00 - m22, 0.0))
        q2 = np.stack(
            [
                (m[:, 0, 2] - m[:, 2, 0]) / s2,
                (m[:, 0, 1] + m[:, 1, 0]) / s2,
                0.25 * s2,
                (m[:, 1, 2] + m[:, 2, 1]) / s2,
            ],
            -1,
        )
        s3 = 2.0 * np.sqrt(np.maximum(1.0 + m22 - m00 - m11, 0.0))
        q3 = np.stack(
            [
                (m[:, 1, 0] - m[:, 0, 1]) / s3,
                (m[:, 0, 2] + m[:, 2, 0]) / s3,
                (m[:, 1, 2] + m[:, 2, 1]) / s3,
                0.25 * s3,
            ],
            -1,
        )
    branch = np.where(tr > 0, 0, np.where((m00 > m11) & (m00 > m22), 1, np.where(m11 > m22, 2, 3)))
    q = np.choose(branch[:, None], [q0, q1, q2, q3])
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(q[:, :1] < 0, -q, q)
    if order == "xyzw":
        q = q[:, [1, 2, 3, 0]]
    return q.reshape(*R.shape[:-2], 4)
