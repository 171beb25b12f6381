"""Latency statistics of a teach session (drag IK + collision check per update)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["latency_summary"]


def latency_summary(latencies: Sequence[float]) -> dict[str, float]:
    """``{"latency_median_ms", "latency_p95_ms"}`` of ``latencies`` (s); 0 for none."""
    lat = np.array(latencies) if len(latencies) else np.zeros(1)
    return {
        "latency_median_ms": float(np.median(lat) * 1e3),
        "latency_p95_ms": float(np.percentile(lat, 95) * 1e3),
    }
