"""Batched inverse kinematics: Levenberg-Marquardt with joint limits and random restarts.

Each row of the batch is an independent problem. One *attempt* runs damped least
squares steps ``dq = J^T (J J^T + lambda I)^-1 e`` (or the ``n x n`` form when the
robot has fewer joints than constraints) with a per-row damping ``lambda`` that
shrinks after a step that lowers the squared error and grows after one that does
not (the step is then rejected). Steps are projected onto the joint limits
(clamped; continuous joints wrapped); joints already at a limit whose step points
outwards are removed from the Jacobian and the step re-solved with the others, so
redundant joints take over instead of the iteration creeping along the limit. Rows
leave the active set as soon as they meet both tolerances, or when their damping
saturates (a local minimum, usually at a joint limit). Rows that failed are retried
from uniformly random in-limit configurations drawn from a seeded generator, several
per row in parallel (one vectorised batch); only those rows are recomputed, and a
row's parallel attempts stop as soon as one of them succeeds.

The error is ``e = (p_target - p, log(R_target R^T))`` in the world frame (m, rad),
matching the geometric Jacobian's rows. Rows that never meet the tolerances are
returned with ``success = False`` and the residual of their best attempt.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import torch
from torch import Tensor

from .batch import as_batch

__all__ = ["IKResult", "Kinematic", "rotation_log", "solve_ik", "solve_near"]

_LAMBDA_INIT = 1e-2
_LAMBDA_MIN = 1e-9
_LAMBDA_MAX = 1e6
_LAMBDA_DOWN = 0.3
_LAMBDA_UP = 10.0


class Kinematic(Protocol):
    """What the solvers need of a robot (:class:`lfd.robots.Robot` is one): its name, ``n_dof``
    joints with limits ``lower``/``upper`` (rad, ``(n,)``), the ``continuous`` mask and ``home``
    configuration, the tool pose and geometric Jacobian of a batch, clamping into the limits and
    uniform sampling within them."""

    @property
    def name(self) -> str: ...

    @property
    def n_dof(self) -> int: ...

    @property
    def lower(self) -> Tensor: ...

    @property
    def upper(self) -> Tensor: ...

    @property
    def continuous(self) -> Tensor: ...

    @property
    def home(self) -> Tensor: ...

    def kinematics(self, q) -> tuple[Tensor, Tensor]:
        """Tool poses ``(B, 4, 4)`` and Jacobians ``(B, 6, n)`` of ``q (B, n)``."""

    def clamp(self, q) -> Tensor:
        """``q (B, n)`` moved into the joint limits."""

    def sample_q(self, batch_size: int, generator=None, dtype=torch.float64, device="cpu") -> Tensor:
        """``(batch_size, n)`` configurations uniform within the limits."""


@dataclass(frozen=True)
class IKResult:
    """Result of :func:`solve_ik` (or :func:`solve_near`) for a batch of B targets.

    Attributes:
        q: (B, n) joint angles, rad, within the joint limits (best attempt per row).
        success: (B,) bool, both tolerances met.
        pos_error: (B,) m, distance between the tool point and the target.
        rot_error: (B,) rad, angle between the tool and target orientations; zero
            for position-only problems.
        attempts: (B,) int64, attempts made (1 = converged from ``q0``).
    """

    q: Tensor
    success: Tensor
    pos_error: Tensor
    rot_error: Tensor
    attempts: Tensor


def rotation_log(rotation: Tensor) -> Tensor:
    """Rotation vectors ``(B, 3)`` (axis * angle, angle in [0, pi]) of rotations ``(B, 3, 3)``.

    Uses the skew part for angles below pi/2 and the symmetric part above, so it is
    accurate near both 0 and pi.
    """
    r = rotation
    skew = 0.5 * torch.stack(
        (r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]), dim=1
    )
    sin = skew.norm(dim=1)
    cos = 0.5 * (r.diagonal(dim1=1, dim2=2).sum(1) - 1.0)
    angle = torch.atan2(sin, cos)
    tiny = torch.finfo(r.dtype).tiny
    small = skew * (angle / sin.clamp_min(tiny))[:, None]
    if not bool((cos <= 0).any()):
        return small
    # Large angles: (R + R^T) / 2 - cos I = (1 - cos) a a^T; take its largest column.
    sym = 0.5 * (r + r.transpose(1, 2)) - cos[:, None, None] * torch.eye(3, dtype=r.dtype, device=r.device)
    column = sym.diagonal(dim1=1, dim2=2).argmax(dim=1)
    axis = torch.gather(sym, 2, column[:, None, None].expand(-1, 3, 1))[:, :, 0]
    sign = torch.where((axis * skew).sum(1) < 0, -1.0, 1.0).to(r.dtype)
    large = axis * (sign * angle / axis.norm(dim=1).clamp_min(tiny))[:, None]
    return torch.where((cos > 0)[:, None], small, large)


def _residual(robot: Kinematic, q: Tensor, t_pos: Tensor, t_rot: Tensor | None) -> tuple[Tensor, Tensor]:
    """Error ``(A, m)`` and Jacobian ``(A, m, n)``, m = 6 (pose) or 3 (position)."""
    pose, jac = robot.kinematics(q)
    e_pos = t_pos - pose[:, :3, 3]
    if t_rot is None:
        return e_pos, jac[:, :3]
    e_rot = rotation_log(t_rot @ pose[:, :3, :3].transpose(1, 2))
    return torch.cat((e_pos, e_rot), dim=1), jac


def _damped_step(jac: Tensor, err: Tensor, damping: Tensor) -> Tensor:
    """Levenberg-Marquardt step ``(A, n)``, solving the smaller of the two normal systems."""
    m, n = jac.shape[1:]
    jac_t = jac.transpose(1, 2)
    if m <= n:
        system = jac @ jac_t + damping[:, None, None] * torch.eye(m, dtype=jac.dtype, device=jac.device)
        return (jac_t @ torch.linalg.solve(system, err[:, :, None]))[:, :, 0]
    system = jac_t @ jac + damping[:, None, None] * torch.eye(n, dtype=jac.dtype, device=jac.device)
    return torch.linalg.solve(system, jac_t @ err[:, :, None])[:, :, 0]


def _split_errors(err: Tensor) -> tuple[Tensor, Tensor]:
    pos = err[:, :3].norm(dim=1)
    rot = err[:, 3:].norm(dim=1) if err.shape[1] > 3 else torch.zeros_like(pos)
    return pos, rot


def _score(err: Tensor, tol_pos: float, tol_rot: float) -> Tensor:
    """``max(pos / tol_pos, rot / tol_rot)`` per row: at most 1 means solved, lower is better."""
    pos, rot = _split_errors(err)
    return torch.maximum(pos / tol_pos, rot / tol_rot)


def _attempt(
    robot: Kinematic,
    q: Tensor,
    group: Tensor,
    t_pos: Tensor,
    t_rot: Tensor | None,
    max_iters: int,
    tol_pos: float,
    tol_rot: float,
) -> tuple[Tensor, Tensor]:
    """One LM attempt per row of ``q`` (A, n) towards target ``group[a]`` of ``t_pos``/``t_rot``.

    A row stops when it meets the tolerances, when its damping saturates, or when
    another row of its group has met them. Returns the final ``q`` and error ``(A, m)``.
    """
    tp, tr = t_pos[group], None if t_rot is None else t_rot[group]
    err, jac = _residual(robot, q, tp, tr)
    out_q, out_err = q.clone(), err.clone()
    rows = torch.arange(q.shape[0], device=q.device)
    solved = torch.zeros(t_pos.shape[0], dtype=torch.bool, device=q.device)
    damping = torch.full_like(q[:, 0], _LAMBDA_INIT)
    lower, upper = robot.lower.to(q), robot.upper.to(q)
    limited = ~robot.continuous.to(q.device)
    for _ in range(max_iters + 1):
        solved[group[_score(err, tol_pos, tol_rot) <= 1.0]] = True
        finished = solved[group] | (damping >= _LAMBDA_MAX)
        if bool(finished.any()):
            out_q[rows[finished]], out_err[rows[finished]] = q[finished], err[finished]
            keep = ~finished
            rows, group, q, err, jac, damping, tp = (x[keep] for x in (rows, group, q, err, jac, damping, tp))
            tr = None if tr is None else tr[keep]
        if rows.numel() == 0:
            break
        step = _damped_step(jac, err, damping)
        blocked = limited & (((q <= lower) & (step < 0)) | ((q >= upper) & (step > 0)))
        if bool(blocked.any()):  # drop joints pushing into their limits, re-solve with the others
            step = _damped_step(jac * (~blocked)[:, None, :], err, damping)
        candidate = robot.clamp(q + step)
        cand_err, cand_jac = _residual(robot, candidate, tp, tr)
        better = cand_err.square().sum(1) < err.square().sum(1)
        q = torch.where(better[:, None], candidate, q)
        err = torch.where(better[:, None], cand_err, err)
        jac = torch.where(better[:, None, None], cand_jac, jac)
        damping = torch.where(better, (damping * _LAMBDA_DOWN).clamp_min(_LAMBDA_MIN), damping * _LAMBDA_UP)
    out_q[rows], out_err[rows] = q, err
    return out_q, out_err


def _targets(target) -> tuple[Tensor, Tensor | None]:
    """Split a ``(B, 4, 4)`` pose or ``(B, 3)`` position target into position and rotation."""
    t = target if isinstance(target, Tensor) else torch.from_numpy(np.asarray(target, dtype=np.float64))
    if not t.is_floating_point():
        t = t.to(torch.float64)
    if t.ndim == 2 and t.shape[1] == 3:
        pos, rot = t, None
    elif t.ndim == 3 and t.shape[1:] == (4, 4):
        pos, rot = t[:, :3, 3], t[:, :3, :3]
    else:
        raise ValueError(
            f"target must have shape (B, 4, 4) (pose) or (B, 3) (position), got {tuple(t.shape)}"
        )
    if not bool(torch.isfinite(t).all()):
        raise ValueError("target contains NaN or inf")
    return pos, rot


def solve_ik(
    robot: Kinematic,
    target,
    q0=None,
    *,
    position_only: bool = False,
    max_iters: int = 30,
    tol_pos: float = 1e-4,
    tol_rot: float = 1e-3,
    restarts: int = 32,
    restart_batch: int = 8,
    seed: int = 0,
) -> IKResult:
    """Solve IK for a batch of targets in the world frame.

    Args:
        robot: the robot.
        target: (B, 4, 4) tool poses or (B, 3) tool positions (m); a position target
            implies ``position_only``. Computation uses its dtype and device.
        q0: (B, n) or (n,) initial guesses (rad), projected into the limits first;
            default the robot's home pose.
        position_only: ignore the target orientation.
        max_iters: LM iterations per attempt.
        tol_pos: position tolerance, m. tol_rot: orientation tolerance, rad.
        restarts: at most this many extra attempts per failed row, from uniformly
            random in-limit configurations.
        restart_batch: restarts run in rounds of this many parallel attempts per
            still-failing row (the best of a round is kept).
        seed: seed of the restart generator (results are deterministic).

    Returns:
        :class:`IKResult`. Unreachable targets give ``success = False`` with the best
        residual; no exception. Not differentiable (runs under ``torch.no_grad``).
    """
    if max_iters < 1 or restarts < 0 or restart_batch < 1 or tol_pos <= 0 or tol_rot <= 0:
        raise ValueError(
            "solve_ik needs max_iters >= 1, restarts >= 0, restart_batch >= 1 and positive tolerances"
        )
    t_pos, t_rot = _targets(target)
    if position_only:
        t_rot = None
    batch, n = t_pos.shape[0], robot.n_dof
    like = t_pos
    if q0 is None:
        start = robot.home.to(device=like.device, dtype=like.dtype).expand(batch, n)
    else:
        q0 = q0 if isinstance(q0, Tensor) else torch.from_numpy(np.asarray(q0, dtype=np.float64))
        start = as_batch(q0.expand(batch, -1) if q0.ndim == 1 else q0, "q0", n, like=like, robot=robot.name)
        if start.shape[0] != batch:
            raise ValueError(f"q0 must have {batch} rows like the target, got {start.shape[0]}")
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        best_q = robot.clamp(start).clone()
        best_err = torch.full(
            (batch, 3 if t_rot is None else 6), torch.inf, dtype=like.dtype, device=like.device
        )
        attempts = torch.zeros(batch, dtype=torch.int64, device=like.device)
        pending = torch.arange(batch, device=like.device)
        full, rest = divmod(restarts, restart_batch)
        schedule = [1] + [restart_batch] * full + [rest] * (rest > 0)  # attempts per row in each round
        for round_, copies in enumerate(schedule):
            if pending.numel() == 0:
                break
            if round_ == 0:
                init = best_q[pending]
            else:
                init = robot.sample_q(len(pending) * copies, generator, like.dtype, like.device)
            group = torch.arange(len(pending), device=like.device).repeat_interleave(copies)
            rot = None if t_rot is None else t_rot[pending]
            q, err = _attempt(robot, init, group, t_pos[pending], rot, max_iters, tol_pos, tol_rot)
            score = _score(err, tol_pos, tol_rot).reshape(-1, copies)
            pick = torch.arange(len(pending), device=like.device) * copies + score.argmin(dim=1)
            improved = score.min(dim=1).values < _score(best_err[pending], tol_pos, tol_rot)
            best_q[pending[improved]], best_err[pending[improved]] = q[pick[improved]], err[pick[improved]]
            attempts[pending] += copies
            pending = pending[_score(best_err[pending], tol_pos, tol_rot) > 1.0]
        pos, rot_err = _split_errors(best_err)
    return IKResult(
        q=best_q,
        success=(pos <= tol_pos) & (rot_err <= tol_rot),
        pos_error=pos,
        rot_error=rot_err,
        attempts=attempts,
    )


def solve_near(robot: Kinematic, poses, reference, n_seeds: int = 16, seed: int = 0) -> IKResult:
    """Full-pose IK of each target, choosing among several seeds the solution nearest ``reference``.

    Seeds per target: ``reference`` itself, half of the rest near it (Gaussian, 0.3 rad) and
    half uniform within the joint limits; each seed gets one :func:`solve_ik` attempt (no
    restarts). Picking the successful solution closest to the reference keeps a family of
    targets on one IK branch.

    Args:
        robot: the robot.
        poses: ``(G, 4, 4)`` target tool poses (m), world frame.
        reference: ``(n,)`` joint vector (rad) the solutions should stay close to.
        n_seeds: IK attempts per target (>= 1).
        seed: seed of the random seeds (results are deterministic).

    Returns:
        :class:`IKResult` of ``G`` rows (float64): per target the successful solution nearest
        ``reference``, or the best attempt where none succeeded (``success`` False);
        ``attempts`` is ``n_seeds``.

    Example::

        >>> import numpy as np
        >>> from lfd.robots import load_robot, solve_near
        >>> robot = load_robot("sawyer")
        >>> home = robot.home.numpy()
        >>> result = solve_near(robot, robot.fk(home[None]).numpy(), home, n_seeds=4)
        >>> bool(result.success[0]), tuple(result.q.shape)
        (True, (1, 7))
    """
    if n_seeds < 1:
        raise ValueError(f"solve_near: n_seeds must be >= 1, got {n_seeds}")
    poses = torch.as_tensor(np.asarray(poses, dtype=np.float64))
    ref = torch.as_tensor(np.asarray(reference, dtype=np.float64))
    n = robot.n_dof
    if poses.ndim != 3 or poses.shape[1:] != (4, 4):
        raise ValueError(f"solve_near: poses must have shape (G, 4, 4), got {tuple(poses.shape)}")
    if ref.shape != (n,):
        raise ValueError(
            f"solve_near: reference must have shape ({n},) for robot {robot.name!r}, got {tuple(ref.shape)}"
        )
    n_targets = poses.shape[0]
    gen = torch.Generator().manual_seed(seed)
    n_near = (n_seeds - 1) // 2
    near = ref + 0.3 * torch.randn(n_targets, n_near, n, generator=gen, dtype=torch.float64)
    uniform = robot.sample_q(n_targets * (n_seeds - 1 - n_near), gen).reshape(n_targets, -1, n)
    seeds = torch.cat(
        [ref.expand(n_targets, 1, n), robot.clamp(near.reshape(-1, n)).reshape(near.shape), uniform], 1
    )
    targets = poses[:, None].expand(n_targets, n_seeds, 4, 4).reshape(-1, 4, 4)
    result = solve_ik(robot, targets, seeds.reshape(-1, n), restarts=0)
    q = result.q.reshape(n_targets, n_seeds, n)
    distance = (q - ref).norm(dim=-1)
    ok = result.success.reshape(n_targets, n_seeds)
    pos_error = result.pos_error.reshape(n_targets, n_seeds)
    score = torch.where(ok, distance, distance + 1e3 + pos_error * 1e3)
    best = score.argmin(dim=1)
    rows = torch.arange(n_targets)
    return IKResult(
        q=q[rows, best],
        success=ok[rows, best],
        pos_error=pos_error[rows, best],
        rot_error=result.rot_error.reshape(n_targets, n_seeds)[rows, best],
        attempts=result.attempts.reshape(n_targets, n_seeds).sum(dim=1),
    )
