r"""Retargeting a person's arm motion onto a robot arm.

Two mappings, both from shoulder/elbow/wrist positions in the trunk frame (x forward,
y left, z up; :attr:`lfd.human.ArmAnalysis.positions`):

* :func:`retarget_wam4` (posture, 4 DoF): the WAM has a shoulder (yaw ``q1``, pitch ``q2``),
  an upper-arm twist ``q3`` and an elbow ``q4`` like a human arm, but its shoulder axes
  differ from the human model's, so angle values cannot be copied. The posture is mapped
  through the geometry instead: the robot is side-mounted at the person's shoulder (its base
  ``z`` points laterally outward, ``x`` forward, so its singular direction ``q2 = 0`` is the
  arm raised straight sideways, a rare pose, and the cone of reachable upper-arm directions,
  ``|q2| <= 2.0`` rad, covers the arm hanging, forward, across the chest and overhead). In
  the mount frame the upper-arm direction ``u = (cos q1 sin q2, sin q1 sin q2, cos q2)`` gives
  ``q1, q2``; the forearm direction expressed in the upper-arm frame of the robot's own FK
  at ``(q1, q2, 0, 0)`` is ``(cos q3 sin q4, sin q3 sin q4, cos q4)``, giving the twist ``q3``
  and the elbow ``q4 = angle(u, f)`` (equal to the human elbow flexion). Of the two
  shoulder branches the one within the limits and closest to the previous frame is taken;
  near the singularity ``q1`` is interpolated in time; values outside the limits are
  clamped and flagged.
* :func:`retarget_wrist_path` (7-DoF arms, PR2, Sawyer): the wrist path relative to the
  shoulder, scaled by ``robot reach / (upper arm + forearm)``, expressed in the robot's base
  frame (same axes as the trunk) with its centre (median) at the tool of the robot's home
  pose, then damped least-squares IK per frame warm-started from the previous solution
  (continuous in joint space) with an elbow hint in the null space (the robot's elbow drawn
  towards the person's scaled elbow).

:func:`time_scale` stretches time where joint velocities exceed the robot's limits.

Example::

    >>> import numpy as np
    >>> from lfd.human.arm_ik import arm_fk
    >>> from lfd.human.retarget import retarget_wam4
    >>> q_h = np.array([[0.4, -0.6, 0.2, 1.2]])
    >>> e, w = arm_fk(q_h, 0.3, 0.26)
    >>> res = retarget_wam4(np.zeros((1, 3)), e, w, side="right")
    >>> bool(np.isclose(res.q[0, 3], 1.2))
    True
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from lfd.robots import load_robot
from lfd.robots.ik import solve_ik

from .arm_ik import mirror

__all__ = ["WAM_MOUNT", "RetargetResult", "retarget_wam4", "retarget_wrist_path", "time_scale"]

# Columns: the WAM base axes in the (right-arm) trunk frame: x forward, y up, z outward (-y).
WAM_MOUNT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


@dataclasses.dataclass
class RetargetResult:
    """Robot joint trajectory from a human arm motion.

    Attributes:
        q: (T, n) rad, within the robot's joint limits.
        clamped: (T,) bool, some joint was clamped (posture outside the robot's range).
        singular: (T,) bool, an angle was interpolated (WAM shoulder singularity).
        target: (T, 3) m, the tool target in the robot base frame (7-DoF) or the mapped
            wrist direction (WAM, unit vector in the mount frame); error: (T,) m or rad.
        scale: human -> robot length scale (7-DoF), 1 for the posture mapping.
        robot: catalogue name. base_rotation: (3, 3) robot base axes in the trunk frame.
    """

    q: np.ndarray
    clamped: np.ndarray
    singular: np.ndarray
    target: np.ndarray
    error: np.ndarray
    scale: float
    robot: str
    base_rotation: np.ndarray


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / n


def _check_points(**points) -> int:
    shape = None
    for name, x in points.items():
        x = np.asarray(x, float)
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"{name} must have shape (T, 3) in metres, got {x.shape}")
        if not np.isfinite(x).all():
            raise ValueError(f"{name} contains NaN or inf; fill gaps first (e.g. analyze_arm positions)")
        if shape is not None and x.shape != shape:
            raise ValueError(f"{name} has shape {x.shape}, expected {shape} like the others")
        shape = x.shape
    return shape[0]


def _fibonacci_sphere(n: int) -> np.ndarray:
    """(n, 3) nearly uniform unit vectors."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5**0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


def _mount_about(axis: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Mount with base ``z = axis`` and ``x`` towards the mean azimuth of ``u`` (q1 centred on 0)."""
    z = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    x0 = _unit(helper - z * (helper @ z))
    y0 = np.cross(z, x0)
    az = np.arctan2(u @ y0, u @ x0)
    mean = np.arctan2(np.sin(az).mean(), np.cos(az).mean())
    x = np.cos(mean) * x0 + np.sin(mean) * y0
    return np.stack([x, np.cross(z, x), z], 1)


#: Hz: cutoff of the twist smoother (:func:`_smooth_twist`) where the elbow is bent at 90 deg
#: (the analysis filter's 6 Hz); lower where it straightens. Chosen on the validation recordings
#: (UI-PRMD s02-s05, KIMORE exercise 1; docs/imitation.md); ``None`` turns the smoother off.
TWIST_CUTOFF_HZ: float | None = 6.0


def _smooth_twist(q3: np.ndarray, sin_elbow: np.ndarray, dt: np.ndarray | float, cutoff_hz) -> np.ndarray:
    """The upper-arm twist ``q3`` (rad, unwrapped) smoothed in proportion to how ill-defined it is.

    Near a straight elbow the twist is ill-defined: an error ``d`` in it moves the forearm by
    only ``sin(q4) * d``. So ``q3`` is replaced by the weighted Whittaker smoother
    ``argmin_z sum_t sin(q4_t)^2 (z_t - q3_t)^2 + lam * sum_t (second difference of z)_t^2``:
    the squared forearm-direction change plus a roughness penalty. ``lam = (fs / (2 pi
    cutoff_hz))**4`` (``fs`` = 1 / median ``dt``) makes it a low-pass of cutoff ``cutoff_hz``
    where the elbow is bent at 90 deg, and a lower one (``cutoff * sin(q4)**0.5``) where it
    straightens, so the twist follows its neighbours there instead of its noise.
    """
    from scipy.linalg import solveh_banded

    n = len(q3)
    if n < 3 or cutoff_hz is None:
        return q3
    fs = 1.0 / float(np.median(dt))
    lam = (fs / (2.0 * np.pi * float(cutoff_hz))) ** 4
    w = np.maximum(sin_elbow**2, 1e-12)
    # D^T D of the second difference as the bands (upper form) of a symmetric banded matrix.
    d0 = np.full(n, 6.0)
    d0[[0, -1]], d0[[1, -2]] = 1.0, 5.0
    d1 = np.full(n, -4.0)
    d1[[1, -1]] = -2.0
    d2 = np.ones(n)
    ab = np.stack([lam * d2, lam * d1, w + lam * d0])
    ab[0, :2] = 0.0
    ab[1, 0] = 0.0
    return solveh_banded(ab, w * q3)


def _wam_posture(s, e, w, mount, singular_deg, robot, dt=1.0 / 30.0):
    n = len(s)
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    u = _unit(e - s) @ mount  # mount-frame coordinates
    f = _unit(w - e) @ mount
    q2a = np.arccos(np.clip(u[:, 2], -1.0, 1.0))
    q1a = np.arctan2(u[:, 1], u[:, 0])
    singular = np.sin(q2a) < np.sin(np.deg2rad(singular_deg))
    if singular.all():
        q1a[:] = 0.0
    elif singular.any():
        idx = np.arange(n)
        q1a[singular] = np.interp(idx[singular], idx[~singular], np.unwrap(q1a[~singular]))
    branches = [(q1a, q2a), (_wrap(q1a + np.pi), -q2a)]
    q = np.zeros((n, 4))
    clamped = np.zeros(n, bool)
    prev = None
    for t in range(n):
        best = None
        for q1, q2 in branches:
            cand = np.array([_wrap(q1[t]), q2[t], 0.0, 0.0])
            viol = np.maximum(lo[:2] - cand[:2], 0).sum() + np.maximum(cand[:2] - hi[:2], 0).sum()
            step = 0.0 if prev is None else np.abs(_wrap(cand[:2] - prev[:2])).sum()
            cost = viol + step  # a branch switch (a jump of ~pi in q1 and q3) only for a larger violation
            if best is None or cost < best[0]:
                best = (cost, cand)
        q[t] = best[1]
        prev = q[t]
    shoulder_ok = np.clip(q[:, :2], lo[:2], hi[:2])
    clamped |= (np.abs(shoulder_ok - q[:, :2]) > 1e-9).any(1)
    q[:, :2] = shoulder_ok
    # Forearm in the robot's upper-arm frame (its own FK at q3 = q4 = 0).
    frames = robot.fk(torch.from_numpy(np.c_[q[:, :2], np.zeros((n, 2))]), all_links=True).numpy()
    r_upper = frames[:, 2, :3, :3]
    f_loc = np.einsum("tji,tj->ti", r_upper, f)
    q[:, 3] = np.arccos(np.clip(f_loc[:, 2], -1.0, 1.0))
    q3 = np.arctan2(f_loc[:, 1], f_loc[:, 0])
    straight = np.sin(q[:, 3]) < np.sin(np.deg2rad(singular_deg))
    if straight.any() and not straight.all():
        idx = np.arange(n)
        q3[straight] = np.interp(idx[straight], idx[~straight], np.unwrap(q3[~straight]))
    q[:, 2] = _smooth_twist(np.unwrap(q3), np.sin(q[:, 3]), dt, TWIST_CUTOFF_HZ)
    q[:, 2] -= 2 * np.pi * np.round(np.median(q[:, 2]) / (2 * np.pi))
    limited = np.clip(q, lo, hi)
    clamped |= (np.abs(limited - q) > 1e-9).any(1)
    q = limited
    tool = robot.fk(torch.from_numpy(q)).numpy()[:, :3, 2]
    err = np.arccos(np.clip((tool * f).sum(1), -1.0, 1.0))
    return q, clamped, singular | straight, f, err


def _speed_ratio(q: np.ndarray, t: np.ndarray | None, vmax: np.ndarray) -> float:
    """Largest |dq/dt| / velocity limit (per frame when ``t`` is None)."""
    if len(q) < 2:
        return 0.0
    qd = np.gradient(q, axis=0) if t is None else np.gradient(q, t, axis=0)
    return float(np.max(np.abs(qd) / vmax))


def retarget_wam4(
    shoulder,
    elbow,
    wrist,
    side: str = "right",
    *,
    singular_deg: float = 10.0,
    mount="side",
    t=None,
    n_mounts: int = 300,
) -> RetargetResult:
    """WAM 4-DoF joint angles reproducing the arm posture (see module docstring).

    Args:
        shoulder, elbow, wrist: (T, 3) m in the trunk frame.
        side: ``"right"`` or ``"left"`` (the left arm is mirrored onto a right-side mount).
        singular_deg: upper arm within this angle of the mount axis = singular (q1 interpolated).
        mount: orientation of the WAM base at the person's shoulder (columns: base axes in the
            right-arm trunk frame). ``"side"`` = :data:`WAM_MOUNT` (base ``z`` laterally outward);
            a (3, 3) rotation; or ``"auto"``: of ``n_mounts`` base ``z`` directions spread over the
            sphere (``x`` turned so that ``q1`` is centred on the motion's mean azimuth), the one
            whose posture mapping clamps the fewest frames and, among those, needs the least time
            scaling (smallest peak joint speed / velocity limit). A motion that sweeps the arm through
            the side mount's singular direction (arm straight out sideways) then gets a mount whose
            singular axis lies away from the demonstrated upper-arm directions.
        t: (T,) s, strictly increasing frame times, for ``mount="auto"`` and the twist smoother
            (:data:`TWIST_CUTOFF_HZ`); None = uniform frames at 30 Hz.
        n_mounts: candidates of ``mount="auto"``.

    Returns:
        :class:`RetargetResult` with ``q`` (T, 4) rad; ``error`` is the angle (rad) between
        the robot's and the person's forearm direction after clamping (0 when in range);
        ``base_rotation`` is the mount used (mirrored for the left arm).
    """
    n = _check_points(shoulder=shoulder, elbow=elbow, wrist=wrist)
    s, e, w = (mirror(np.asarray(x, float), side) for x in (shoulder, elbow, wrist))
    robot = load_robot("wam4")
    if t is not None and np.shape(t) != (n,):
        raise ValueError(f"t must have shape ({n},) (frame times in s), got {np.shape(t)}")
    dt = np.diff(np.asarray(t, float)) if t is not None and n > 1 else 1.0 / 30.0
    if not np.all(np.isfinite(dt)) or np.any(np.asarray(dt) <= 0):
        raise ValueError("t must be finite and strictly increasing (frame times in s)")
    if isinstance(mount, str):
        if mount == "side":
            mount = WAM_MOUNT
        elif mount == "auto":
            vmax = robot.velocity_limits.numpy()
            u = _unit(e - s)
            best = None
            for axis in np.concatenate([WAM_MOUNT[:, 2:].T, _fibonacci_sphere(int(n_mounts))]):
                m = WAM_MOUNT if best is None else _mount_about(axis, u)
                q, clamped = _wam_posture(s, e, w, m, singular_deg, robot, dt)[:2]
                key = (int(clamped.sum()), _speed_ratio(q, None if t is None else np.asarray(t, float), vmax))
                if best is None or key < best[0]:
                    best = (key, m)
            mount = best[1]
        else:
            raise ValueError(f"mount must be 'side', 'auto' or a (3, 3) rotation, got {mount!r}")
    mount = np.asarray(mount, float)
    if (
        mount.shape != (3, 3)
        or not np.allclose(mount.T @ mount, np.eye(3), atol=1e-6)
        or np.linalg.det(mount) < 0
    ):
        raise ValueError(
            f"mount must be a (3, 3) rotation matrix (columns = base axes), got {mount.tolist()}"
        )
    q, clamped, singular, f, err = _wam_posture(s, e, w, mount, singular_deg, robot, dt)
    return RetargetResult(q, clamped, singular, f, err, 1.0, "wam4", mount if side == "right" else
                          np.diag([1.0, -1.0, 1.0]) @ mount)  # fmt: skip


def _shoulder_and_reach(robot) -> tuple[np.ndarray, float]:
    """Robot shoulder point (origin of the second joint, base frame) and a comfortable reach (m)."""
    gen = torch.Generator().manual_seed(0)
    q = robot.sample_q(2048, gen)
    frames = robot.fk(robot.home[None], all_links=True)[0].numpy()
    shoulder = frames[1, :3, 3]
    tool = robot.fk(q).numpy()[:, :3, 3]
    reach = float(np.quantile(np.linalg.norm(tool - shoulder, axis=1), 0.95))
    return shoulder, 0.8 * reach


def _largest_scale(a: np.ndarray, b: np.ndarray, radius: float) -> float:
    """Largest ``s`` with ``|a + s b_t| <= radius`` for every row ``b_t`` of ``b (T, 3)``; inf when ``a``
    itself is not inside (no scale helps) or nothing moves."""
    bb = np.einsum("ti,ti->t", b, b)
    ab = b @ a
    moving = bb > 1e-12
    if not moving.any() or a @ a >= radius**2:
        return np.inf
    disc = ab[moving] ** 2 - bb[moving] * (a @ a - radius**2)
    return float(np.min((-ab[moving] + np.sqrt(np.maximum(disc, 0.0))) / bb[moving]))


def retarget_wrist_path(
    shoulder,
    elbow,
    wrist,
    robot: str = "sawyer",
    *,
    scale: float | None = None,
    iters: int = 20,
    elbow_weight: float = 0.1,
    tol: float = 1e-4,
    max_jump: float = 0.5,
    within_reach: bool = True,
    reach_fraction: float = 0.8,
) -> RetargetResult:
    """Joint trajectory of a 7-DoF arm whose tool follows the person's scaled wrist path.

    The path is centred (its median wrist, relative to the shoulder) on the tool at the home pose and
    scaled by ``scale``; with ``within_reach`` the scale is reduced, when needed, until every target
    lies within ``reach_fraction`` x the robot's reach of its shoulder (the 95th percentile of the
    tool's distance from the shoulder over sampled postures), so motions spanning the person's whole
    reach (an arm raised above the head) stay inside the robot's workspace, shape kept.

    Args:
        shoulder, elbow, wrist: (T, 3) m in the trunk frame (x forward, y left, z up).
        robot: catalogue name (``sawyer``, ``pr2_right_arm``).
        scale: human -> robot length factor; default the robot's comfortable reach over the person's
            arm length (upper arm + forearm, median).
        iters: damped least-squares iterations per frame (warm-started from the last frame).
        elbow_weight: gain of the null-space elbow hint (0 = none).
        tol: m, stop iterating a frame once the tool is this close.
        max_jump: rad, largest joint change from the previous frame a restarted IK solution may make (a
            farther one is another IK branch: the frame keeps the warm-started solution and its error).
        within_reach: shrink ``scale`` (given or default) so every target is within reach (above).
        reach_fraction: the fraction of the robot's reach the targets must stay within.

    Returns:
        :class:`RetargetResult` with ``q`` (T, n) rad; ``error`` is the tool-to-target distance (m).
    """
    n = _check_points(shoulder=shoulder, elbow=elbow, wrist=wrist)
    model = load_robot(robot)
    s, e, w = (np.asarray(x, float) for x in (shoulder, elbow, wrist))
    origin, reach = _shoulder_and_reach(model)
    arm = np.median(np.linalg.norm(e - s, axis=1) + np.linalg.norm(w - e, axis=1))
    if scale is None:
        scale = reach / arm
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive number, got {scale!r}")
    # The path's centre (median wrist, relative to the shoulder) lands on the tool at the home pose.
    home_tool = model.fk(model.home[None])[0, :3, 3].numpy()
    centre = np.median(w - s, axis=0)
    if within_reach:  # reach is 0.8 x the 95th percentile of the tool's distance from the shoulder
        scale = min(scale, _largest_scale(home_tool - origin, w - s - centre, reach_fraction * reach / 0.8))
    target = home_tool + scale * (w - s - centre)
    elbow_target = home_tool + scale * (e - s - centre)
    lo, hi = model.lower.numpy(), model.upper.numpy()
    q = np.zeros((n, model.n_dof))
    err = np.zeros(n)
    current = model.home.numpy().copy()
    elbow_link = model.n_dof // 2  # PR2/Sawyer: the elbow joint's frame
    for t in range(n):
        qt = torch.from_numpy(current)
        for _ in range(iters if t else 10 * iters):  # the first frame starts from the home pose
            jac = model.jacobian(qt[None])[0, :3].numpy()
            pos = model.fk(qt[None])[0, :3, 3].numpy()
            res = target[t] - pos
            if np.linalg.norm(res) < tol:
                break
            jj = jac @ jac.T + 1e-4 * np.eye(3)
            pinv = jac.T @ np.linalg.solve(jj, np.eye(3))
            dq = pinv @ res
            if elbow_weight > 0:
                qe = qt.clone().requires_grad_(True)
                pe = model.fk(qe[None], all_links=True)[0, elbow_link, :3, 3]
                loss = ((pe - torch.from_numpy(elbow_target[t])) ** 2).sum()
                (grad,) = torch.autograd.grad(loss, qe)
                dq += (np.eye(model.n_dof) - pinv @ jac) @ (-elbow_weight * grad.numpy())
            step = np.clip(dq, -0.3, 0.3)
            qt = torch.from_numpy(np.clip(qt.numpy() + step, lo, hi))
        miss = np.linalg.norm(target[t] - model.fk(qt[None])[0, :3, 3].numpy())
        if miss > 10 * tol:  # stuck at a limit or far from the start: LM with restarts from here
            sol = solve_ik(
                model, torch.from_numpy(target[t][None]), qt[None], position_only=True, tol_pos=tol
            )
            # keep the arm on its branch: a restart that lands farther than max_jump from the last frame
            # would be a jump the robot cannot make between two frames
            if sol.pos_error[0] < miss and (t == 0 or np.abs(sol.q[0].numpy() - current).max() <= max_jump):
                qt = sol.q[0]
                miss = float(sol.pos_error[0])
        current = qt.numpy()
        q[t] = current
        err[t] = miss
    clamped = ((np.abs(q - lo) < 1e-9) | (np.abs(q - hi) < 1e-9)).any(1)
    return RetargetResult(q, clamped, np.zeros(n, bool), target, err, float(scale), robot, np.eye(3))


def time_scale(t, q, velocity_limits) -> tuple[np.ndarray, float]:
    """Stretch time so no joint exceeds its velocity limit.

    Args:
        t: (T,) s. q: (T, n) rad. velocity_limits: (n,) rad/s.

    Returns:
        ``(t_scaled (T,), factor)``, factor >= 1 (1 = the motion was already within limits).
    """
    t, q = np.asarray(t, float), np.asarray(q, float)
    vmax = np.asarray(velocity_limits, float)
    if len(t) < 2:
        return t.copy(), 1.0
    qd = np.gradient(q, t, axis=0)
    factor = float(max(1.0, np.max(np.abs(qd) / vmax)))
    return t[0] + (t - t[0]) * factor, factor
