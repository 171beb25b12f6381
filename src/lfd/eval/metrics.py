"""Episode metrics and their summaries (pure numpy).

Definitions (used in ``metrics.json`` / ``episodes.csv``):

- ``final_distance_m``: Euclidean distance (m) between the tool point and the object's
  grasp target at the end of the episode.
- ``success_5cm`` / ``success_2cm``: fraction of episodes whose final distance is below
  5 cm / 2 cm, with Wilson score 95 % intervals.
- ``approach_correct``: fraction of episodes whose final tool approach axis lies within
  ``approach_tol_deg`` of the approach direction the object's shape asks for (horizontal
  towards the object for side grasps, straight down for top grasps). See
  :func:`approach_angle_deg`.
- ``jerk_ratio``: squared end-effector jerk of the rollouts, integrated over each episode
  and averaged over episodes, divided by the same for the scripted demonstrations of the
  same cases (1 = as smooth as the demonstrations; null when no case has a
  demonstration). Integrated rather than time-averaged, so that resting at the end of a
  longer episode does not count as smoothness. A few episodes in which the arm hits the
  object or the table can dominate it, so ``jerk_ratio_median`` (median over episodes of
  the per-episode ratio) is given too.
- ``joint_limit_violations``: number of control steps whose commanded joint target lay
  outside the robot's joint limits (the command is clamped before execution).
- ``latency_ms``: wall time of one policy call (``plan`` for the DMP policy, once per
  episode; ``act`` for the velocity policy, every control step).
"""

from __future__ import annotations

import math

import numpy as np


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion (95 % by default).

    Returns ``(low, high)`` in [0, 1]; ``(0, 1)`` when ``n == 0``.
    """
    if n < 0 or successes < 0 or successes > n:
        raise ValueError(f"wilson_interval: need 0 <= successes <= n, got successes={successes}, n={n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def integrated_squared_jerk(path: np.ndarray, dt: float) -> np.ndarray:
    """Integrated squared jerk of positions ``path (..., T, 3)`` sampled every ``dt`` s ->
    ``(...)`` in m^2/s^5: ``sum_t |dddx_t|^2 dt`` (third finite differences; ``T >= 4``).

    Unlike the time average it does not shrink when the arm rests after the motion, so
    episodes of different lengths compare fairly."""
    path = np.asarray(path, dtype=np.float64)
    if path.shape[-2] < 4:
        raise ValueError(f"integrated_squared_jerk needs at least 4 samples, got {path.shape[-2]}")
    jerk = np.diff(path, n=3, axis=-2) / dt**3
    return (jerk**2).sum(axis=(-2, -1)) * dt


def approach_angle_deg(tool_axis: np.ndarray, wanted_axis: np.ndarray) -> np.ndarray:
    """Angle (deg) between the tool approach axis and the wanted approach direction, ``(..., 3)`` each."""
    a = np.asarray(tool_axis, dtype=np.float64)
    b = np.asarray(wanted_axis, dtype=np.float64)
    cos = (a * b).sum(-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def summarise(
    final_distance: np.ndarray,
    approach_ok: np.ndarray,
    jerk: np.ndarray,
    demo_jerk: np.ndarray,
    limit_violations: np.ndarray,
    latency_ms: np.ndarray,
) -> dict:
    """One method's ``metrics.json`` entry from per-episode arrays (``demo_jerk``: NaN where
    the case has no demonstration; ``latency_ms``: one value per policy call)."""
    d = np.asarray(final_distance, dtype=np.float64)
    n = int(d.size)
    out: dict = {
        "episodes": n,
        "final_distance_m": {
            "mean": float(d.mean()),
            "median": float(np.median(d)),
            "p90": float(np.percentile(d, 90)),
        },
    }
    for cm in (5, 2):
        k = int((d < cm / 100.0).sum())
        out[f"success_{cm}cm"] = k / n
        out[f"success_{cm}cm_ci"] = list(wilson_interval(k, n))
    out["approach_correct"] = float(np.mean(approach_ok))
    jerk, demo_jerk = np.asarray(jerk, dtype=np.float64), np.asarray(demo_jerk, dtype=np.float64)
    valid = np.isfinite(demo_jerk)
    out["jerk_ratio"] = float(jerk[valid].mean() / demo_jerk[valid].mean()) if valid.any() else None
    out["jerk_ratio_median"] = float(np.median(jerk[valid] / demo_jerk[valid])) if valid.any() else None
    out["joint_limit_violations"] = int(np.sum(limit_violations))
    lat = np.asarray(latency_ms, dtype=np.float64)
    out["latency_ms"] = {"median": float(np.median(lat)), "p95": float(np.percentile(lat, 95))}
    return out
