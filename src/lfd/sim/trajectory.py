"""Smooth joint-space trajectories: quintic segments through via points, polynomial
warps of a demonstration to new goals, and paths followed with exponential progress.

Pure numpy (no PyBullet: importable without a simulator), batched over paths and degrees
of freedom. Units: seconds and radians (or whatever unit the positions are in).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "follow_paths",
    "quintic_coefficients",
    "smoothstep",
    "via_quintic",
    "via_velocities",
    "warp_to_goals",
]


def quintic_coefficients(
    q0: np.ndarray,
    q1: np.ndarray,
    v0: np.ndarray,
    v1: np.ndarray,
    a0: np.ndarray,
    a1: np.ndarray,
    duration: float,
) -> np.ndarray:
    """Coefficients ``(6, D)`` (ascending powers of time) of the quintic going from
    position/velocity/acceleration ``(q0, v0, a0)`` at ``t = 0`` to ``(q1, v1, a1)`` at
    ``t = duration``; all boundary arrays ``(D,)``."""
    if not duration > 0:
        raise ValueError(f"quintic_coefficients: duration must be > 0 s, got {duration}")
    T = float(duration)
    dq = q1 - q0
    c3 = (20 * dq - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T**2) / (2 * T**3)
    c4 = (-30 * dq + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T**2) / (2 * T**4)
    c5 = (12 * dq - 6 * (v1 + v0) * T - (a0 - a1) * T**2) / (2 * T**5)
    return np.stack([q0, v0, a0 / 2, c3, c4, c5]).astype(np.float64)


def _eval_poly(coeffs: np.ndarray, t: np.ndarray, order: int) -> np.ndarray:
    """Value (order 0), first or second derivative of polynomials ``coeffs (6, D)`` at
    ``t (T,)`` -> ``(T, D)``."""
    out = np.zeros((t.shape[0], coeffs.shape[1]))
    for power in range(order, coeffs.shape[0]):
        factor = np.prod(np.arange(power - order + 1, power + 1)) if order else 1.0
        out += factor * np.outer(t ** (power - order), coeffs[power])
    return out


def via_velocities(times: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Knot velocities ``(K, D)`` for knots ``points (K, D)`` at ``times (K,)``: zero at the
    two ends; at a via point the mean of the neighbouring segment slopes where they have
    the same sign, else zero (so the path never overshoots a via point it turns at)."""
    vel = np.zeros_like(points, dtype=np.float64)
    slopes = np.diff(points, axis=0) / np.diff(times)[:, None]
    same_sign = np.sign(slopes[:-1]) == np.sign(slopes[1:])
    vel[1:-1] = np.where(same_sign, (slopes[:-1] + slopes[1:]) / 2, 0.0)
    return vel


def via_quintic(
    t: np.ndarray, times: np.ndarray, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Piecewise-quintic trajectory through knots ``points (K, D)`` at ``times (K,)``
    (strictly increasing, K >= 2), at rest (zero velocity and acceleration) at both ends,
    zero acceleration and :func:`via_velocities` at the via points (C2-continuous).

    Returns position, velocity and acceleration, each ``(T, D)``, at ``t (T,)`` (clamped
    to ``[times[0], times[-1]]``).
    """
    t = np.clip(np.asarray(t, dtype=np.float64), times[0], times[-1])
    times = np.asarray(times, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or times.shape != (points.shape[0],) or points.shape[0] < 2:
        raise ValueError(
            f"via_quintic: need times (K,) and points (K, D) with K >= 2, got {times.shape}, {points.shape}"
        )
    if np.any(np.diff(times) <= 0):
        raise ValueError(f"via_quintic: times must be strictly increasing, got {times}")
    vel = via_velocities(times, points)
    zero = np.zeros(points.shape[1])
    q, qd, qdd = (np.zeros((t.shape[0], points.shape[1])) for _ in range(3))
    segment = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    for k in range(len(times) - 1):
        mask = segment == k
        coeffs = quintic_coefficients(
            points[k], points[k + 1], vel[k], vel[k + 1], zero, zero, times[k + 1] - times[k]
        )
        local = t[mask] - times[k]
        q[mask], qd[mask], qdd[mask] = (_eval_poly(coeffs, local, order) for order in range(3))
    return q, qd, qdd


def smoothstep(p: np.ndarray, order: int) -> np.ndarray:
    """Rest-to-rest polynomial blend from 0 to 1 on ``p`` in [0, 1]: order 3
    (``3p^2 - 2p^3``) or 5 (``10p^3 - 15p^4 + 6p^5``)."""
    if order == 3:
        return p * p * (3 - 2 * p)
    if order == 5:
        return p**3 * (10 - 15 * p + 6 * p * p)
    raise ValueError(f"smoothstep: order must be 3 or 5, got {order}")


def warp_to_goals(demo_q: np.ndarray, goal_q: np.ndarray, orders: Sequence[int]) -> np.ndarray:
    """Paths ``(G, T, n)``: the demonstration ``demo_q (T, n)`` bent to end at each
    ``goal_q (G, n)`` by a third- or fifth-order polynomial blend of the offset,
    ``q_demo(p) + s(p) (q_goal - q_demo(1))``; ``orders (G,)`` picks 3 or 5 per path. The
    start and the demonstrated shape are kept; the path ends exactly at its goal."""
    p = np.linspace(0.0, 1.0, demo_q.shape[0])
    blend = np.stack([smoothstep(p, int(o)) for o in orders])  # (G, T)
    return demo_q[None] + blend[:, :, None] * (goal_q - demo_q[-1])[:, None, :]


def follow_paths(
    paths: np.ndarray, time_constant: float, dt: float, n_steps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Follow each path with exponential progress: ``sigma(t) = 1 - exp(-t / time_constant)``
    of its joint-space arc length, so the velocity is the tangent times ``(1 - sigma) / time_constant``.

    Args:
        paths: ``(G, P, n)`` joint paths (rad), ``P >= 2`` points each, not of zero length.
        time_constant: seconds for the remaining path to shrink by ``e``.
        dt: sample spacing (s); ``n_steps`` samples from ``t = 0``.

    Returns:
        ``t (N,)`` (s), positions ``q (G, N, n)`` (rad) and velocities ``qd (G, N, n)`` (rad/s).
    """
    steps = np.linalg.norm(np.diff(paths, axis=1), axis=-1)  # (G, P-1)
    length = steps.sum(axis=1)
    if np.any(length <= 1e-9):
        raise ValueError("follow_paths: a path has zero length (its goal is its start)")
    sigma_path = np.concatenate(
        [np.zeros((len(paths), 1)), np.cumsum(steps, axis=1) / length[:, None]], axis=1
    )
    t = np.arange(n_steps) * dt
    sigma = 1.0 - np.exp(-t / time_constant)  # (N,)
    # Batched segment lookup: offset row g by 2g so one sorted array holds every path.
    offsets = 2.0 * np.arange(len(paths))[:, None]
    flat = (sigma_path + offsets).ravel()
    idx = np.searchsorted(flat, (sigma[None] + offsets).ravel(), side="right").reshape(len(paths), -1) - 1
    idx = np.clip(idx - np.arange(len(paths))[:, None] * paths.shape[1], 0, paths.shape[1] - 2)
    rows = np.arange(len(paths))[:, None]
    s0, s1 = sigma_path[rows, idx], sigma_path[rows, idx + 1]
    q0, q1 = paths[rows, idx], paths[rows, idx + 1]
    width = np.maximum(s1 - s0, 1e-12)
    frac = ((sigma[None] - s0) / width)[..., None]
    q = q0 + frac * (q1 - q0)
    tangent = (q1 - q0) / width[..., None]
    qd = tangent * ((1.0 - sigma) / time_constant)[None, :, None]
    return t, q, qd
