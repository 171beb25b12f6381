"""Smooth joint-space trajectories: quintic segments through via points.

Pure numpy, batched over degrees of freedom. Units: seconds and radians (or whatever
unit the positions are in).
"""

from __future__ import annotations

import numpy as np


def quintic_coefficients(
    q0: np.ndarray, q1: np.ndarray, v0: np.ndarray, v1: np.ndarray, a0: np.ndarray, a1: np.ndarray, duration: float
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


def via_quintic(t: np.ndarray, times: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
        coeffs = quintic_coefficients(points[k], points[k + 1], vel[k], vel[k + 1], zero, zero, times[k + 1] - times[k])
        local = t[mask] - times[k]
        q[mask], qd[mask], qdd[mask] = (_eval_poly(coeffs, local, order) for order in range(3))
    return q, qd, qdd
