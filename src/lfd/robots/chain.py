"""Single-configuration forward kinematics and Jacobian in NumPy, for interactive loops.

:class:`lfd.robots.Robot` is batched torch (about 0.6 ms of dispatch per call for one
configuration); an interactive drag update needs FK and a Jacobian for *one*
configuration tens of times within 20 ms, so :class:`ChainKinematics` evaluates the same
:class:`~lfd.robots.RobotSpec` chain with a handful of 4 x 4 NumPy products (~30 us).

It shares the joint-transform definition with :class:`~lfd.robots.Robot`: the constants
come from the same compilation of the spec (``lfd.robots.robot._compile``: every joint
axis turned into the local z axis, folded into the joint origins), so each joint step is
``T_i = T_{i-1} @ O'_i @ Rz(q_i)``; link ``i``'s URDF frame is ``T_i`` with its rotation
times ``A_i^T`` (see :mod:`lfd.robots.robot`). ``tests/robots/test_robots_chain.py`` checks
it against ``Robot.fk`` / ``Robot.jacobian``.

Example::

    >>> import numpy as np
    >>> from lfd.robots import ChainKinematics, load_robot
    >>> kin = ChainKinematics(load_robot("wam4").spec)
    >>> kin.frames(np.zeros(4)).shape            # 4 link frames + the tool, world frame
    (5, 4, 4)
    >>> kin.tool_position(np.zeros(4)).round(3)  # stretched up: 0.55 + 0.35 m
    array([0. , 0. , 0.9])
"""

from __future__ import annotations

import numpy as np

from .robot import _compile
from .spec import RobotSpec

__all__ = ["ChainKinematics"]


class ChainKinematics:
    """FK of all link frames and the geometric Jacobian of one configuration.

    Args:
        spec: the robot description (its base and tool transforms included).
    """

    def __init__(self, spec: RobotSpec) -> None:
        self.spec = spec
        self.n = spec.n_dof
        c = _compile(spec)
        origins = np.empty((self.n, 4, 4))
        origins[:, 3] = (0.0, 0.0, 0.0, 1.0)
        origins[0, :3] = c["first_cols"][:, :, 0].T
        origins[1:] = np.swapaxes(c["next_origins_t"], 1, 2)
        self._origins = origins  # O'_i: joint origins in the internal z-axis frames
        self._tool = c["tool_t"].T
        self._link_rotations = np.swapaxes(c["axis_frames"], 1, 2)  # A_i^T
        self._axes = np.asarray(spec.joint_axis, dtype=float)

    def frames(self, q: np.ndarray) -> np.ndarray:
        """``(n + 1, 4, 4)`` world poses: link ``i`` (child of joint ``i``) for ``i < n``, tool last.

        Args:
            q: (n,) joint angles, rad.
        """
        q = np.asarray(q, dtype=float)
        out = np.empty((self.n + 1, 4, 4))
        frame = np.eye(4)
        rz = np.eye(4)
        for i in range(self.n):
            c, s = np.cos(q[i]), np.sin(q[i])
            rz[0, 0], rz[0, 1], rz[1, 0], rz[1, 1] = c, -s, s, c
            frame = frame @ self._origins[i] @ rz
            out[i] = frame
            out[i, :3, :3] = frame[:3, :3] @ self._link_rotations[i]
        out[self.n] = frame @ self._tool
        return out

    def tool_position(self, q: np.ndarray) -> np.ndarray:
        """(3,) tool point in the world frame, m."""
        return self.frames(q)[-1, :3, 3]

    def jacobian(self, q: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
        """``(6, n)`` geometric Jacobian at the tool point (linear rows first), world frame.

        Args:
            q: (n,) joint angles, rad.
            frames: ``frames(q)`` if already computed.
        """
        f = self.frames(q) if frames is None else frames
        tool = f[-1, :3, 3]
        z = np.einsum("nij,nj->ni", f[:-1, :3, :3], self._axes)  # joint axes in the world
        linear = np.cross(z, tool - f[:-1, :3, 3])
        return np.concatenate([linear.T, z.T], axis=0)
