"""Closed-form position IK of the 4-DoF Barrett WAM with joint 3 held fixed.

With the standard DH table of the thesis (``a3 = 0.045``, ``d3 = 0.55``, ``a4 = -0.045``,
tool ``d = 0.35``) the tool point in the base frame is::

    x = cos q1 (cos q2 cos q3 A + sin q2 C) - sin q1 sin q3 A
    y = sin q1 (cos q2 cos q3 A + sin q2 C) + cos q1 sin q3 A
    z = cos q2 C - sin q2 cos q3 A

with ``A = a3 + a4 cos q4 + d sin q4`` and ``C = d3 - a4 sin q4 + d cos q4``. Hence
``|p|^2 = A^2 + C^2 = K + P sin q4 + Q cos q4`` (``K = a3^2 + a4^2 + d3^2 + d^2``,
``P = 2 (a3 d - d3 a4)``, ``Q = 2 (a3 a4 + d3 d)``) fixes the elbow ``q4`` (two
solutions, elbow up/down); the horizontal radius ``u = +-sqrt(x^2 + y^2 - (sin q3 A)^2)``
(shoulder flip) fixes ``q1 = atan2(y, x) - atan2(sin q3 A, u)`` (``atan2(y, x)`` or its
opposite for ``q3 = 0``) and then ``q2`` follows from a 2 x 2 rotation. Up to four
solutions; those outside the joint limits or not real are masked out.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import torch
from torch import Tensor

from .catalogue import WAM4_DH, WAM4_TOOL_D, load_robot
from .robot import Robot
from .spec import RobotSpec

__all__ = ["wam4_ik_closed_form"]

_A3, _D3 = WAM4_DH[2][1], WAM4_DH[2][2]
_A4 = WAM4_DH[3][1]
_D_TOOL = WAM4_TOOL_D


def _elbow_terms(q4: Tensor) -> tuple[Tensor, Tensor]:
    """``A(q4)`` and ``C(q4)``: tool point in frame 2 before the q3 rotation (m)."""
    c4, s4 = torch.cos(q4), torch.sin(q4)
    return _A3 + _A4 * c4 + _D_TOOL * s4, _D3 - _A4 * s4 + _D_TOOL * c4


@lru_cache(maxsize=1)
def _reference() -> RobotSpec:
    return load_robot("wam4").spec


def _wrap(angle: Tensor) -> Tensor:
    return torch.atan2(torch.sin(angle), torch.cos(angle))


def wam4_ik_closed_form(position, q3: float = 0.0, robot: Robot | None = None) -> tuple[Tensor, Tensor]:
    """All IK solutions of the 4-DoF WAM for tool positions, joint 3 fixed at ``q3``.

    Args:
        position: (B, 3) tool positions in the world frame, m.
        q3: fixed angle of joint 3, rad (within its limits).
        robot: a ``wam4`` robot whose base transform to use (default
            ``load_robot("wam4")``); its chain must be the catalogue WAM's.

    Returns:
        ``(q, valid)``: ``q`` (B, 4, 4) rad, up to four solutions per row ordered
        (elbow branch, shoulder branch) = (+, +), (+, -), (-, +), (-, -), invalid
        entries NaN; ``valid`` (B, 4) bool, real solutions within the joint limits.
        Coincident solutions (workspace boundary, target on the base z axis) may
        repeat; on the z axis joint 1 is set to its branch value of ``atan2(0, 0)``.
    """
    robot = load_robot("wam4") if robot is None else robot
    reference, spec = _reference(), robot.spec
    fields = ("joint_xyz", "joint_rpy", "joint_axis", "tool_transform")
    same_chain = spec.n_dof == reference.n_dof and all(
        np.allclose(getattr(spec, f), getattr(reference, f)) for f in fields
    )
    if robot.name != "wam4" or not same_chain:
        raise ValueError("wam4_ik_closed_form needs the catalogue 'wam4' chain (any base transform)")
    if not spec.lower[2] <= q3 <= spec.upper[2]:
        raise ValueError(f"q3 = {q3} is outside joint 3's limits [{spec.lower[2]}, {spec.upper[2]}]")
    p = position if isinstance(position, Tensor) else torch.from_numpy(np.asarray(position, dtype=np.float64))
    p = p if p.is_floating_point() else p.to(torch.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"position must have shape (B, 3), got {tuple(p.shape)}")
    if not bool(torch.isfinite(p).all()):
        raise ValueError("position contains NaN or inf")

    base_inv = torch.as_tensor(np.linalg.inv(spec.base_transform), dtype=p.dtype, device=p.device)
    p = p @ base_inv[:3, :3].T + base_inv[:3, 3]
    x, y, z = p.unbind(1)
    k = _A3**2 + _A4**2 + _D3**2 + _D_TOOL**2
    sin_coef, cos_coef = 2 * (_A3 * _D_TOOL - _D3 * _A4), 2 * (_A3 * _A4 + _D3 * _D_TOOL)
    ratio = (p.square().sum(1) - k) / float(np.hypot(sin_coef, cos_coef))
    elbow = torch.acos(ratio.clamp(-1.0, 1.0))
    phase = float(np.arctan2(sin_coef, cos_coef))
    q4 = _wrap(torch.stack((phase + elbow, phase + elbow, phase - elbow, phase - elbow), dim=1))  # (B, 4)
    a, c = _elbow_terms(q4)
    v = np.sin(q3) * a
    radial_sq = (x.square() + y.square())[:, None] - v.square()
    u = torch.sqrt(radial_sq.clamp_min(0.0)) * torch.tensor(
        [1.0, -1.0, 1.0, -1.0], dtype=p.dtype, device=p.device
    )
    q1 = _wrap(torch.atan2(y, x)[:, None] - torch.atan2(v, u))
    a_cos = np.cos(q3) * a
    q2 = torch.atan2(c * u - a_cos * z[:, None], a_cos * u + c * z[:, None])
    q = torch.stack((q1, q2, torch.full_like(q1, q3), q4), dim=2)

    within = (q >= robot.lower.to(p)) & (q <= robot.upper.to(p))
    valid = (ratio.abs() <= 1.0)[:, None] & (radial_sq >= 0.0) & within.all(dim=2)
    return torch.where(valid[:, :, None], q, torch.nan), valid
