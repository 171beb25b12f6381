"""Episode metrics and their summaries (pure numpy).

Definitions (used in ``metrics.json`` / ``episodes.csv``):

- ``final_distance_m``: Euclidean distance (m) between the tool point and the
  demonstrated end point (the pre-grasp target) at the end of the episode.
- ``object_distance_m``: distance (m) between the tool point at the end and the object's
  centre where it was placed (the thesis's metric; it includes the pre-grasp clearance,
  so it is never near zero for a correct reach).
- ``success_5cm`` / ``success_2cm``: fraction of episodes whose final distance is below
  5 cm / 2 cm **and** whose object moved less than :data:`MAX_DISPLACEMENT_M` (2 cm)
  during the episode (knocking the object over is no success).
- ``approach_correct``: fraction of episodes that end within 5 cm of the end point **and**
  whose final tool approach axis lies within ``approach_tol_deg`` of the approach
  direction the object's shape asks for (horizontal towards the object for side grasps,
  straight down for top grasps; :func:`approach_angle_deg`). The distance condition keeps
  an arm that never leaves its home pose from scoring.
- Intervals (``*_ci``, ``final_distance_m.ci``): 95 % percentile intervals of a *cluster*
  bootstrap (:func:`cluster_bootstrap_ci`) that resamples whole objects with their
  placements, because errors cluster by object; ``ci_clusters`` is how many objects
  there were (with one object the interval is degenerate). Without cluster labels
  (``clusters=None``) proportions get Wilson score intervals.
- ``arm_table_contacts`` / ``arm_object_contacts``: fraction of episodes in which the
  arm touched the table / the object before the final step; ``object_displacement_m``:
  mean and max distance the object's centre moved during an episode.
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

#: An episode whose object moved at least this far (m) is no success.
MAX_DISPLACEMENT_M = 0.02
#: Distance (m) from the end point within which a reach counts (success_5cm, approach_correct).
SUCCESS_RADIUS_M = 0.05


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


def cluster_bootstrap_ci(
    values: np.ndarray, clusters: np.ndarray, n_boot: int = 2000, level: float = 0.95, seed: int = 0
) -> tuple[float, float]:
    """Percentile interval of the pooled mean of ``values (N,)`` under a bootstrap that
    resamples whole clusters (``clusters (N,)``: one label per episode, e.g. the object)
    with replacement: each replicate draws as many clusters as there are and pools their
    episodes. Deterministic for a given ``seed``.

    Example::

        >>> v = np.array([1.0, 1.0, 0.0, 0.0]); c = np.array([0, 0, 1, 1])
        >>> low, high = cluster_bootstrap_ci(v, c)
        >>> (low, high)
        (0.0, 1.0)
    """
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    clusters = np.asarray(clusters).reshape(-1)
    if values.shape != clusters.shape or values.size == 0:
        raise ValueError(
            f"cluster_bootstrap_ci: need equal-length non-empty values and clusters, got {values.shape}, "
            f"{clusters.shape}"
        )
    if not 0 < level < 1 or n_boot < 1:
        raise ValueError(f"cluster_bootstrap_ci: need 0 < level < 1 and n_boot >= 1, got {level}, {n_boot}")
    labels, inverse = np.unique(clusters, return_inverse=True)
    k = len(labels)
    sums = np.bincount(inverse, weights=values, minlength=k)
    counts = np.bincount(inverse, minlength=k).astype(np.float64)
    draws = np.random.default_rng(seed).integers(0, k, size=(n_boot, k))
    stats = sums[draws].sum(1) / counts[draws].sum(1)
    alpha = (1 - level) / 2
    return float(np.quantile(stats, alpha)), float(np.quantile(stats, 1 - alpha))


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
    *,
    displacement: np.ndarray | None = None,
    clusters: np.ndarray | None = None,
    object_distance: np.ndarray | None = None,
    table_contact: np.ndarray | None = None,
    object_contact: np.ndarray | None = None,
    n_boot: int = 2000,
) -> dict:
    """One method's ``metrics.json`` entry from per-episode arrays (``demo_jerk``: NaN where
    the case has no demonstration; ``latency_ms``: one value per policy call).

    ``approach_ok`` is the angle condition alone; the distance condition of
    ``approach_correct`` is applied here. ``displacement`` (m, per episode; None: not
    measured, success by distance alone), ``clusters`` (object label per episode; None:
    Wilson intervals), ``object_distance`` (m), ``table_contact`` / ``object_contact``
    (bool per episode) add their entries when given.
    """
    d = np.asarray(final_distance, dtype=np.float64)
    n = int(d.size)
    still = (
        np.ones(n, dtype=bool)
        if displacement is None
        else np.asarray(displacement, dtype=np.float64) < MAX_DISPLACEMENT_M
    )
    near = d < SUCCESS_RADIUS_M
    out: dict = {
        "episodes": n,
        "final_distance_m": {
            "mean": float(d.mean()),
            "median": float(np.median(d)),
            "p90": float(np.percentile(d, 90)),
        },
    }

    def interval(flags: np.ndarray) -> list[float]:
        if clusters is None:
            return list(wilson_interval(int(flags.sum()), n))
        return list(cluster_bootstrap_ci(flags.astype(np.float64), clusters, n_boot=n_boot))

    if clusters is not None:
        out["final_distance_m"]["ci"] = list(cluster_bootstrap_ci(d, clusters, n_boot=n_boot))
        out["ci_clusters"] = int(len(np.unique(np.asarray(clusters))))
        out["ci_method"] = "cluster bootstrap over objects (95 %, percentile)"
    else:
        out["ci_method"] = "Wilson score (95 %, episodes independent)"
    for cm in (5, 2):
        ok = (d < cm / 100.0) & still
        out[f"success_{cm}cm"] = float(ok.mean())
        out[f"success_{cm}cm_ci"] = interval(ok)
    correct = np.asarray(approach_ok, dtype=bool) & near
    out["approach_correct"] = float(correct.mean())
    out["approach_correct_ci"] = interval(correct)
    if object_distance is not None:
        od = np.asarray(object_distance, dtype=np.float64)
        out["object_distance_m"] = {"mean": float(od.mean()), "median": float(np.median(od))}
        if clusters is not None:
            out["object_distance_m"]["ci"] = list(cluster_bootstrap_ci(od, clusters, n_boot=n_boot))
    if displacement is not None:
        disp = np.asarray(displacement, dtype=np.float64)
        out["object_displacement_m"] = {"mean": float(disp.mean()), "max": float(disp.max())}
        out["object_moved_2cm"] = float((~still).mean())
    for key, flags in (("arm_table_contacts", table_contact), ("arm_object_contacts", object_contact)):
        if flags is not None:
            out[key] = float(np.mean(np.asarray(flags, dtype=bool)))
    jerk, demo_jerk = np.asarray(jerk, dtype=np.float64), np.asarray(demo_jerk, dtype=np.float64)
    valid = np.isfinite(demo_jerk)
    out["jerk_ratio"] = float(jerk[valid].mean() / demo_jerk[valid].mean()) if valid.any() else None
    out["jerk_ratio_median"] = float(np.median(jerk[valid] / demo_jerk[valid])) if valid.any() else None
    out["joint_limit_violations"] = int(np.sum(limit_violations))
    lat = np.asarray(latency_ms, dtype=np.float64)
    out["latency_ms"] = {"median": float(np.median(lat)), "p95": float(np.percentile(lat, 95))}
    return out
