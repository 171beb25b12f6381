"""Feature statistics of a LeRobot v3.0 dataset (``meta/stats.json`` and the per-episode
``stats/<feature>/<stat>`` columns of ``meta/episodes``).

Keys and shapes follow ``lerobot.datasets.compute_stats``: ``min``, ``max``, ``mean``,
``std``, ``count`` and the quantiles ``q01``, ``q10``, ``q50``, ``q90``, ``q99``; vector
features get ``(D,)`` arrays, images ``(3, 1, 1)`` per channel scaled to ``[0, 1]``.
Both are computed exactly: vector quantiles with :func:`numpy.quantile` over all frames,
image quantiles from exact per-channel histograms of the uint8 pixels.
"""

from __future__ import annotations

import math

import numpy as np

QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)
STAT_KEYS = ("min", "max", "mean", "std", "count") + tuple(f"q{int(q * 100):02d}" for q in QUANTILES)


def _quantile_keys() -> list[str]:
    return [k for k in STAT_KEYS if k.startswith("q")]


def vector_stats(values: np.ndarray) -> dict[str, np.ndarray]:
    """Stats of ``values (N,)`` or ``(N, D)`` over the first axis, keyed by :data:`STAT_KEYS`:
    ``(D,)`` arrays (``min`` and ``max`` keep an integer dtype, the rest are float64) and
    ``count = [N]`` (int64)."""
    v = np.asarray(values)
    v2 = v.reshape(len(v), -1)
    f = v2.astype(np.float64)
    out = {
        "min": v2.min(axis=0),
        "max": v2.max(axis=0),
        "mean": f.mean(axis=0),
        "std": f.std(axis=0),
        "count": np.array([len(v)], dtype=np.int64),
    }
    qs = np.quantile(f, QUANTILES, axis=0)
    for key, q in zip(_quantile_keys(), qs, strict=True):
        out[key] = q
    return out


def image_histograms(frames: np.ndarray) -> np.ndarray:
    """Per-channel histograms ``(3, 256)`` int64 of uint8 frames ``(T, H, W, 3)``."""
    return np.stack([np.bincount(frames[..., c].ravel(), minlength=256) for c in range(3)]).astype(np.int64)


def image_stats(hist: np.ndarray, n_frames: int) -> dict[str, np.ndarray]:
    """Exact per-channel stats from histograms ``(3, 256)`` (:func:`image_histograms`, summed
    over any number of frames), keyed by :data:`STAT_KEYS`: ``(3, 1, 1)`` float64 in
    ``[0, 1]`` (quantiles as :func:`numpy.quantile`, linear, over every pixel would give
    them) and ``count = [n_frames]`` (int64)."""
    levels = np.arange(256, dtype=np.float64)
    n = hist.sum(axis=1).astype(np.float64)
    mean = (hist * levels).sum(axis=1) / n
    var = (hist * levels**2).sum(axis=1) / n - mean**2
    cum = np.cumsum(hist, axis=1)
    out = {
        "min": np.array([levels[np.nonzero(h)[0][0]] for h in hist]),
        "max": np.array([levels[np.nonzero(h)[0][-1]] for h in hist]),
        "mean": mean,
        "std": np.sqrt(np.maximum(var, 0.0)),
    }
    for key, q in zip(_quantile_keys(), QUANTILES, strict=True):
        vals = []
        for c in range(3):
            pos = q * (n[c] - 1)
            lo = math.floor(pos)
            a = np.searchsorted(cum[c], lo, side="right")
            b = np.searchsorted(cum[c], min(lo + 1, n[c] - 1), side="right")
            vals.append(levels[a] + (pos - lo) * (levels[b] - levels[a]))
        out[key] = np.array(vals)
    stats = {k: (v / 255.0).reshape(3, 1, 1) for k, v in out.items()}
    stats["count"] = np.array([n_frames], dtype=np.int64)
    return {k: stats[k] for k in STAT_KEYS}


def stats_to_lists(stats: dict[str, dict[str, np.ndarray]]) -> dict[str, dict[str, list]]:
    """``{feature: {stat: array}}`` with every array as nested lists (JSON-serialisable)."""
    return {feat: {k: np.asarray(v).tolist() for k, v in s.items()} for feat, s in stats.items()}
