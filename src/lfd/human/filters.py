"""Filters for joint trajectories ``x (T, ...)`` sampled at ``rate`` Hz, applied along time.

* :func:`median_filter`: the thesis's running median (odd kernel, 3-5 samples).
* :func:`butterworth_filter`: zero-phase low-pass (forward-backward Butterworth). A
  forward-backward pass squares the magnitude response, which moves the -3 dB point
  below the design cutoff; the design cutoff is raised so that the *combined* response
  is -3 dB at the requested cutoff (Winter 2009, "Biomechanics and motor control of human
  movement", section 3.4.4.3: ``C = (2^(1/n_pass) - 1)^(1/(2 N))``, applied to the
  pre-warped frequency of the bilinear transform).
* :func:`auto_cutoff`: a Butterworth cutoff chosen from the recording itself (the discrepancy
  principle): the highest cutoff whose residual still holds the sensor noise estimated from the
  third differences. A stream the sensor already smoothed keeps its peaks; a noisy one is filtered
  harder.
* :func:`hampel_filter`: replaces samples further than ``n_sigma`` robust standard
  deviations (1.4826 x MAD) from the running median by that median.

NaN samples split the signal into finite segments that are filtered separately (segments
too short for a filter are left as they are), so long gaps stay gaps.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, signal

__all__ = [
    "AUTO_CUTOFFS",
    "FILTERS",
    "auto_cutoff",
    "butterworth_filter",
    "butterworth_sos",
    "filter_positions",
    "hampel_filter",
    "median_filter",
    "noise_level",
]

FILTERS = ("butterworth", "median", "none")

#: Hz: the cutoffs :func:`auto_cutoff` chooses among (capped below 0.4 x the sampling rate).
AUTO_CUTOFFS = tuple(np.arange(2.0, 12.01, 0.5))


def _segments(finite: np.ndarray) -> list[tuple[int, int]]:
    """Runs of True in a (T,) mask as (start, stop)."""
    padded = np.concatenate([[False], finite, [False]]).astype(np.int8)
    edges = np.diff(padded)
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


def _per_segment(x: np.ndarray, fn, min_length: int) -> np.ndarray:
    """Apply ``fn`` to each run of frames where every channel is finite (x is (T, C))."""
    out = x.copy()
    for start, stop in _segments(np.isfinite(x).all(axis=1)):
        if stop - start >= min_length:
            out[start:stop] = fn(x[start:stop])
    # Channels finite where others are not (rare): filter them on their own.
    partial = np.isfinite(x).any(axis=1) & ~np.isfinite(x).all(axis=1)
    if partial.any():
        for c in range(x.shape[1]):
            col = x[:, c : c + 1]
            for start, stop in _segments(np.isfinite(col[:, 0])):
                if stop - start >= min_length and partial[start:stop].any():
                    out[start:stop, c : c + 1] = fn(col[start:stop])
    return out


def _flat(x: np.ndarray) -> tuple[np.ndarray, tuple[int, ...]]:
    x = np.asarray(x, dtype=float)
    if x.ndim < 1 or len(x) == 0:
        raise ValueError(f"signal must have shape (T, ...) with T >= 1, got {x.shape}")
    return x.reshape(len(x), -1), x.shape


def median_filter(x: np.ndarray, kernel: int = 5) -> np.ndarray:
    """Running median along time, odd ``kernel`` samples, edges reflected. ``x (T, ...)``."""
    if not isinstance(kernel, (int, np.integer)) or kernel < 1 or kernel % 2 == 0:
        raise ValueError(
            f"median kernel must be a positive odd integer (3 or 5 as in the thesis), got {kernel!r}"
        )
    flat, shape = _flat(x)
    out = _per_segment(flat, lambda seg: ndimage.median_filter(seg, size=(kernel, 1), mode="nearest"), kernel)
    return out.reshape(shape)


def butterworth_sos(cutoff: float, rate: float, order: int = 2, passes: int = 2) -> np.ndarray:
    """Second-order sections of a low-pass whose ``passes``-fold cascade is -3 dB at ``cutoff`` Hz.

    ``order`` is the order of one pass (the zero-phase result has order ``2 * order``).
    """
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"sampling rate must be positive, got {rate!r} Hz")
    if not (np.isfinite(cutoff) and 0 < cutoff < rate / 2):
        raise ValueError(f"butterworth cutoff must be in (0, rate/2) = (0, {rate / 2:g}) Hz, got {cutoff!r}")
    if not isinstance(order, (int, np.integer)) or order < 1:
        raise ValueError(f"butterworth order must be a positive integer, got {order!r}")
    correction = (2.0 ** (1.0 / passes) - 1.0) ** (1.0 / (2.0 * order))
    warped = np.tan(np.pi * cutoff / rate) / correction
    design = np.arctan(warped) * rate / np.pi
    if design >= rate / 2:
        raise ValueError(
            f"butterworth cutoff {cutoff} Hz is too close to the Nyquist frequency {rate / 2} Hz"
        )
    return signal.butter(order, design, btype="low", fs=rate, output="sos")


def butterworth_filter(x: np.ndarray, rate: float, cutoff: float = 6.0, order: int = 2) -> np.ndarray:
    """Zero-phase Butterworth low-pass along time (cutoff corrected for the double pass).

    Args:
        x: (T, ...) signal. rate: Hz. cutoff: Hz, where the zero-phase response is -3 dB.
        order: order of each pass.
    """
    sos = butterworth_sos(cutoff, rate, order)
    flat, shape = _flat(x)
    pad = 3 * (2 * len(sos) + 1)

    def run(seg: np.ndarray) -> np.ndarray:
        return signal.sosfiltfilt(sos, seg, axis=0, padlen=min(pad, len(seg) - 1))

    return _per_segment(flat, run, 2 * order + 2).reshape(shape)


#: median of the chi distribution with 3 degrees of freedom (the length of a 3-D standard normal vector)
_CHI3_MEDIAN = 1.5381722544550522


def noise_level(points: np.ndarray) -> float:
    """Robust estimate of the white measurement noise (standard deviation per coordinate, same unit as
    ``points``) of point trajectories ``(T, ..., 3)`` with finite samples: the smallest over points of
    ``median |third difference| / (sqrt(20) x 1.5382)`` (the third difference of white noise of standard
    deviation ``s`` per coordinate has variance ``20 s^2`` per coordinate, and its length the chi
    distribution with 3 degrees of freedom; the point that moves least, e.g. the shoulder of an arm,
    has the least motion in its third differences). It does not depend on the orientation of the
    frame the points are given in."""
    d3 = np.diff(np.asarray(points, dtype=float), 3, axis=0)
    lengths = np.linalg.norm(d3, axis=-1).reshape(len(d3), -1)
    return float(np.min(np.median(lengths, axis=0)) / (np.sqrt(20.0) * _CHI3_MEDIAN))


def auto_cutoff(points: np.ndarray, rate: float, order: int = 2, default: float = 6.0) -> float:
    """A Butterworth cutoff (Hz) for point trajectories ``points (T, ..., 3)`` sampled at ``rate`` Hz,
    chosen by the discrepancy principle: the highest of :data:`AUTO_CUTOFFS` (at most ``0.4 rate``) at
    which the filter still removes at least the noise, i.e. the RMS per coordinate of
    ``points - butterworth_filter(points, rate, cutoff)`` is at least :func:`noise_level`. Frames with a NaN
    are left out; with fewer than 10 finite frames, ``default``. The choice does not depend on the
    frame's orientation.

    On UI-PRMD's Kinect recordings (already smoothed by the Kinect SDK) it chooses high cutoffs (little
    smoothing), and with 2 cm of added white noise low ones (``docs/human.md``)."""
    pts = np.asarray(points, dtype=float)
    if pts.shape[-1] != 3:
        raise ValueError(f"auto_cutoff: points must have shape (T, ..., 3), got {pts.shape}")
    pts = pts.reshape(len(pts), -1, 3)
    pts = pts[np.isfinite(pts).all(axis=(1, 2))]
    candidates = [c for c in AUTO_CUTOFFS if c <= 0.4 * rate]
    if len(pts) < 10 or not candidates:
        return float(default)
    sigma = noise_level(pts)
    chosen = candidates[0]
    for c in candidates:
        residual = float(np.sqrt(np.mean((pts - butterworth_filter(pts, rate, c, order)) ** 2)))
        if residual >= sigma:
            chosen = c
    return float(chosen)


def hampel_filter(x: np.ndarray, window: int = 7, n_sigma: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    """Hampel outlier filter along time.

    Args:
        x: (T, ...) signal. window: odd number of samples of the running median.
        n_sigma: threshold in robust standard deviations (1.4826 x median absolute deviation).

    Returns:
        ``(filtered (T, ...), outliers (T, ...) bool)``.
    """
    if not isinstance(window, (int, np.integer)) or window < 3 or window % 2 == 0:
        raise ValueError(f"hampel window must be an odd integer >= 3, got {window!r}")
    if not (np.isfinite(n_sigma) and n_sigma > 0):
        raise ValueError(f"hampel n_sigma must be positive, got {n_sigma!r}")
    flat, shape = _flat(x)
    med = _per_segment(flat, lambda s: ndimage.median_filter(s, size=(window, 1), mode="nearest"), window)
    mad = _per_segment(
        np.abs(flat - med), lambda s: ndimage.median_filter(s, size=(window, 1), mode="nearest"), window
    )
    outliers = np.abs(flat - med) > n_sigma * 1.4826 * mad
    outliers &= np.isfinite(flat)
    out = np.where(outliers, med, flat)
    return out.reshape(shape), outliers.reshape(shape)


def filter_positions(positions: np.ndarray, rate: float, kind: str = "butterworth", *, cutoff: float = 6.0,
                     order: int = 2, kernel: int = 5) -> np.ndarray:  # fmt: skip
    """Filter (T, J, 3) joint positions with ``kind`` in :data:`FILTERS` (``cutoff`` in Hz; for ``"auto"``
    choose it first with :func:`auto_cutoff`)."""
    if kind == "butterworth":
        return butterworth_filter(positions, rate, cutoff, order)
    if kind == "median":
        return median_filter(positions, kernel)
    if kind == "none":
        return np.array(positions, dtype=float)
    raise ValueError(f"filter must be one of {', '.join(FILTERS)}, got {kind!r}")
