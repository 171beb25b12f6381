"""Bounded-time, warm-started, continuous IK for one drag update.

Every drag update asks for the configuration that puts the tool at a new target, close
to the current configuration. :class:`DragIK` answers within ``time_budget`` seconds
(default 20 ms) with the best configuration found so far:

* **An arm with a closed form, its held joint fixed** (``wam_q3="fixed"``, the default; the robot's
  catalogue entry names the held joint, :class:`lfd.robots.catalogue.CatalogueEntry`): the closed form
  of :func:`lfd.robots.wam4_ik_closed_form` (the WAM's, joint 3 held) at the held joint's current value
  gives up to four solutions; the one nearest the current configuration is taken, so the elbow and
  shoulder branches never switch while dragging.
* **The held joint free** and **arms without a closed form** (the 7-DoF arms): damped least
  squares / Levenberg-Marquardt from the current configuration (position only, or the full pose when an orientation
  is given), with each iteration's joint step capped and the joints clamped into the
  limits.
* **Out of reach**: the closed form has no real solution; LM from the current
  configuration then converges to the nearest reachable tool position (best effort),
  ``reached`` is False.

The caller (:class:`~lfd.teach.session.TeachSession`) rejects a result whose largest
joint change exceeds ``max_joint_step`` (no branch jumps, no flips at the boundary).
:meth:`DragIK.clamp` and :meth:`DragIK.jump` are the joint-limit clamp and the joint-change measure
(continuous joints wrapped) that the 2-D panel shares.

Example::

    >>> import numpy as np
    >>> from lfd.robots import load_robot
    >>> from lfd.teach.drag_ik import DragIK
    >>> robot = load_robot("wam4")
    >>> ik = DragIK(robot)
    >>> q = robot.home.numpy()
    >>> step = ik.solve(q, ik.kin.tool_position(q) + [0.0, 0.05, 0.0])
    >>> bool(step.reached), step.method, bool(step.jump < 0.2)
    (True, 'closed_form', True)
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch

from lfd.checks import check_float
from lfd.robots import ChainKinematics, Robot, wam4_ik_closed_form
from lfd.robots.catalogue import catalogue_entry
from lfd.robots.spatial import QUATERNION_ORDERS

from .settings import WAM_Q3_MODES

__all__ = ["DragIK", "IKStep", "as_rotation", "rotation_angle"]


@dataclass(frozen=True)
class IKStep:
    """Result of one bounded IK call.

    Attributes:
        q: (n,) configuration, rad (within the limits).
        reached: tool within ``tol`` (m) of the target (and ``tol_rot`` rad for a pose).
        error: remaining tool position error, m.
        jump: largest joint change from the start configuration, rad.
        iterations: LM iterations used (0 for the closed form).
        timed_out: the time budget ran out before convergence.
        method: ``"closed_form"`` or ``"lm"``.
        rot_error: remaining tool orientation error, rad (0 when no orientation was asked for).
    """

    q: np.ndarray
    reached: bool
    error: float
    jump: float
    iterations: int
    timed_out: bool
    method: str
    rot_error: float = 0.0


def as_rotation(orientation, order: str = "wxyz") -> np.ndarray:
    """(3, 3) rotation from a (3, 3) matrix or a (4,) quaternion in ``order`` (``"wxyz"``: viser's,
    scalar first; ``"xyzw"``: the teach session's, scalar last), normalised.

    Raises:
        ValueError: not a finite rotation matrix, not a finite non-zero (4,) quaternion, unknown order.
    """
    if order not in QUATERNION_ORDERS:
        raise ValueError(f"order must be one of {QUATERNION_ORDERS}, got {order!r}")
    try:
        o = np.asarray(orientation, dtype=float)
    except (TypeError, ValueError):  # a mapping, a string, a ragged list
        raise ValueError(
            f"orientation must be a (3, 3) rotation or a finite non-zero (4,) quaternion ({', '.join(order)}), "
            f"got a {type(orientation).__name__}"
        ) from None
    if o.shape == (3, 3):
        if (
            not np.all(np.isfinite(o))
            or not np.allclose(o @ o.T, np.eye(3), atol=1e-6)
            or np.linalg.det(o) < 0
        ):
            raise ValueError("orientation (3, 3) must be a finite rotation matrix")
        return o
    if o.shape != (4,) or not np.all(np.isfinite(o)) or np.linalg.norm(o) < 1e-9:
        raise ValueError(
            f"orientation must be a (3, 3) rotation or a finite non-zero (4,) quaternion "
            f"({', '.join(order)}), got shape {o.shape}"
        )
    if order == "xyzw":
        o = o[[3, 0, 1, 2]]
    w, x, y, z = o / np.linalg.norm(o)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _rotation_error(target: np.ndarray, current: np.ndarray) -> np.ndarray:
    """(3,) axis-angle of ``target @ current.T`` (rad, world frame)."""
    r = target @ current.T
    cos = np.clip((np.trace(r) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = np.linalg.norm(axis)
    if s < 1e-9:
        if angle < 1e-6:
            return np.zeros(3)
        # 180 degrees: axis from the symmetric part
        axis = np.sqrt(np.maximum((np.diag(r) + 1.0) / 2.0, 0.0))
        return axis * angle
    return axis / s * angle


def rotation_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (rad, in [0, pi]) of the rotation between two (3, 3) rotations ``a`` and ``b``."""
    return float(np.linalg.norm(_rotation_error(a, b)))


class DragIK:
    """Warm-started IK for interactive dragging (see module docstring).

    Args:
        robot: the arm.
        time_budget: seconds one :meth:`solve` may take (default 0.02).
        tol: position tolerance, m (default 1 mm). tol_rot: orientation tolerance, rad.
        wam_q3: ``"fixed"`` (closed form, the held joint kept) or ``"free"`` (LM on every
            joint); ignored for robots without a closed form.
        max_iters: LM iteration cap (the time budget usually binds first).
        max_iter_step: largest joint change of one LM iteration, rad.
        orientation_weight: m per rad (>= 0): the orientation rows of the LM residual are the rotation
            error times this weight, so 1 rad of orientation error costs as much as this many metres of
            position error; 0 ignores an orientation (position only). Default 0.1.
    """

    def __init__(
        self,
        robot: Robot,
        time_budget: float = 0.02,
        tol: float = 1e-3,
        tol_rot: float = 1e-2,
        wam_q3: str = "fixed",
        max_iters: int = 100,
        max_iter_step: float = 0.2,
        orientation_weight: float = 0.1,
    ) -> None:
        if wam_q3 not in WAM_Q3_MODES:
            raise ValueError(f"wam_q3 must be one of {WAM_Q3_MODES}, got {wam_q3!r}")
        if not time_budget > 0 or not tol > 0 or not tol_rot > 0 or max_iters < 1 or not max_iter_step > 0:
            raise ValueError(
                "DragIK needs time_budget > 0, tol > 0, tol_rot > 0, max_iters >= 1, max_iter_step > 0"
            )
        self.robot = robot
        self.kin = ChainKinematics(robot.spec)
        self.time_budget = float(time_budget)
        self.tol, self.tol_rot = float(tol), float(tol_rot)
        self.wam_q3 = wam_q3
        self.max_iters = int(max_iters)
        self.max_iter_step = float(max_iter_step)
        self.orientation_weight = check_float(orientation_weight, "ik.orientation_weight", low=0.0)
        self.lower = np.asarray(robot.spec.lower, dtype=float)
        self.upper = np.asarray(robot.spec.upper, dtype=float)
        self.continuous = np.asarray(robot.spec.continuous, dtype=bool)
        held = catalogue_entry(robot.name).closed_form_held_joint
        self.held_joint = held if wam_q3 == "fixed" else None
        self.closed_form = self.held_joint is not None

    def clamp(self, q: np.ndarray) -> np.ndarray:
        """``q (n,)`` rad inside the limits: continuous joints wrapped, the others clipped."""
        wrapped = self.lower + np.remainder(q - self.lower, 2 * np.pi)
        return np.where(self.continuous, wrapped, np.clip(q, self.lower, self.upper))

    def jump(self, q_from: np.ndarray, q_to: np.ndarray) -> float:
        """Largest joint change ``q_from -> q_to`` (n,), rad (continuous joints the short way round)."""
        d = q_to - q_from
        d = np.where(self.continuous, np.arctan2(np.sin(d), np.cos(d)), d)
        return float(np.max(np.abs(d)))

    def solve(self, q_current, position, orientation=None) -> IKStep:
        """Configuration near ``q_current`` (n,) rad putting the tool at ``position`` (3,) m.

        ``orientation`` ((3, 3) rotation or quaternion ``(w, x, y, z)``, see :func:`as_rotation`) adds the
        tool orientation for robots with at least 6 joints, weighted by ``orientation_weight`` (0: ignored);
        the 4-DoF WAM controls the position only (an orientation is a ``ValueError``).
        """
        start = time.perf_counter()
        q0 = np.asarray(q_current, dtype=float)
        target = np.asarray(position, dtype=float)
        rot = None
        if orientation is not None:
            if self.robot.n_dof < 6:
                raise ValueError(
                    f"{self.robot.name} has {self.robot.n_dof} joints: it cannot follow an orientation; "
                    "pass orientation=None"
                )
            rot = as_rotation(orientation) if self.orientation_weight > 0 else None
        if self.closed_form and rot is None:
            step = self._closed_form(q0, target)
            if step is not None:
                return step
            free = np.ones(self.robot.n_dof, dtype=bool)  # best effort with the held joint still fixed
            free[self.held_joint] = False
        else:
            free = np.ones(self.robot.n_dof, dtype=bool)
        return self._lm(q0, target, rot, free, start)

    def _closed_form(self, q0: np.ndarray, target: np.ndarray) -> IKStep | None:
        j = self.held_joint
        q3 = float(np.clip(q0[j], self.lower[j], self.upper[j]))
        sols, valid = wam4_ik_closed_form(torch.from_numpy(target[None]), q3=q3, robot=self.robot)
        sols, valid = sols[0].numpy(), valid[0].numpy()
        if not valid.any():
            return None
        cands = sols[valid]
        dist = np.max(np.abs(cands - q0), axis=1)
        q = cands[int(np.argmin(dist))]
        err = float(np.linalg.norm(self.kin.tool_position(q) - target))
        return IKStep(q, err <= self.tol, err, float(dist.min()), 0, False, "closed_form")

    def _lm(self, q0: np.ndarray, target: np.ndarray, rot, free: np.ndarray, start: float) -> IKStep:
        deadline = start + self.time_budget

        def residual(q):
            f = self.kin.frames(q)
            e = target - f[-1, :3, 3]
            if rot is not None:
                e = np.concatenate([e, weight * _rotation_error(rot, f[-1, :3, :3])])
            return e, f

        weight = self.orientation_weight

        q = self.clamp(q0.copy())
        err, frames = residual(q)
        cost = float(err @ err)
        lam = 1e-2
        it, timed_out = 0, False
        rows = 3 if rot is None else 6
        while it < self.max_iters:
            pos_err = np.linalg.norm(err[:3])
            rot_ok = rot is None or np.linalg.norm(err[3:]) <= self.tol_rot * weight
            if pos_err <= self.tol and rot_ok:
                break
            if time.perf_counter() > deadline:
                timed_out = True
                break
            it += 1
            jac = self.kin.jacobian(q, frames)[:rows][:, free]
            if rot is not None:
                jac[3:] *= weight
            jjt = jac @ jac.T
            dq_free = jac.T @ np.linalg.solve(jjt + lam * np.eye(rows), err)
            big = np.max(np.abs(dq_free))
            if big > self.max_iter_step:
                dq_free *= self.max_iter_step / big
            dq = np.zeros_like(q)
            dq[free] = dq_free
            q_new = self.clamp(q + dq)
            err_new, frames_new = residual(q_new)
            cost_new = float(err_new @ err_new)
            if cost_new < cost:
                q, err, frames, cost = q_new, err_new, frames_new, cost_new
                lam = max(lam / 3.0, 1e-6)
                if cost - cost_new < 1e-14 and lam <= 1e-6:
                    break
            else:
                lam = min(lam * 4.0, 1e3)
                if lam >= 1e3:  # no further progress possible (boundary / limits)
                    break
        pos_err = float(np.linalg.norm(err[:3]))
        rot_err = 0.0 if rot is None else float(np.linalg.norm(err[3:])) / weight
        reached = pos_err <= self.tol and rot_err <= self.tol_rot
        return IKStep(q, reached, pos_err, self.jump(q0, q), it, timed_out, "lm", rot_err)
