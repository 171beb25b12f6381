"""Single-configuration forward kinematics and Jacobian in NumPy, for the interactive loop.

:class:`lfd.robots.Robot` is batched torch (about 0.6 ms of dispatch per call for one
configuration); a drag update needs FK and a Jacobian for *one* configuration tens of
times within 20 ms, so this module evaluates the same :class:`~lfd.robots.RobotSpec`
chain with a handful of 4 x 4 NumPy products (~30 us). ``tests/teach`` checks it
against ``Robot.fk`` / ``Robot.jacobian``.

Example::

    >>> import numpy as np
    >>> from lfd.robots import load_robot
    >>> from lfd.teach.kinematics import ChainKinematics
    >>> kin = ChainKinematics(load_robot("wam4").spec)
    >>> kin.frames(np.zeros(4)).shape            # 4 link frames + the tool, world frame
    (5, 4, 4)
    >>> kin.tool_position(np.zeros(4)).round(3)  # stretched up: 0.55 + 0.35 m
    array([0.   , 0.   , 0.9])
"""

from __future__ import annotations

import numpy as np

from lfd.robots import RobotSpec

__all__ = ["ChainKinematics"]


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    v = 1.0 - c
    return np.array(
        [
            [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
            [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
            [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
        ]
    )


class ChainKinematics:
    """FK of all link frames and the positional Jacobian of one configuration.

    Args:
        spec: the robot description (its base and tool transforms included).
    """

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec
        self.n = spec.n_dof
        first = spec.base_transform @ spec.joint_origin(0)
        self._origins = [first] + [spec.joint_origin(i) for i in range(1, self.n)]
        self._axes = np.asarray(spec.joint_axis, dtype=float)
        self._tool = np.asarray(spec.tool_transform, dtype=float)

    def frames(self, q: np.ndarray) -> np.ndarray:
        """``(n + 1, 4, 4)`` world poses: link ``i`` (child of joint ``i``) for ``i < n``, tool last.

        Args:
            q: (n,) joint angles, rad.
        """
        q = np.asarray(q, dtype=float)
        out = np.empty((self.n + 1, 4, 4))
        frame = np.eye(4)
        rot = np.eye(4)
        for i in range(self.n):
            rot[:3, :3] = _axis_rotation(self._axes[i], q[i])
            frame = frame @ self._origins[i] @ rot
            out[i] = frame
        out[self.n] = frame @ self._tool
        return out

    def tool_position(self, q: np.ndarray) -> np.ndarray:
        """(3,) tool point in the world frame, m."""
        return self.frames(q)[-1, :3, 3]

    def jacobian(self, q: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
        """``(6, n)`` geometric Jacobian at the tool point (linear rows first), world frame."""
        f = self.frames(q) if frames is None else frames
        tool = f[-1, :3, 3]
        z = np.einsum("nij,nj->ni", f[:-1, :3, :3], self._axes)  # joint axes in the world
        linear = np.cross(z, tool - f[:-1, :3, 3])
        return np.concatenate([linear.T, z.T], axis=0)
