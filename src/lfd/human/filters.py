"""Filters for joint trajectories ``x (T, ...)`` sampled at ``rate`` Hz, applied along time.

* :func:`median_filter`: the thesis's running median (odd kernel, 3-5 samples).
* :func:`butterworth_filter`: zero-phase low-pass (forward-backward Butterworth). A
  forward-backward pass squares the magnitude response, which moves the -3 dB point
  below the design cutoff; the design cutoff is raised so that the *combined* response
  is -3 dB at the requested cutoff (Winter 2009, "Biomechanics and motor control of human
  movement", section 3.4.4.3: ``C = (2^(1/n_pass) - 1)^(1/(2 N))``, applied to the
  pre-warped frequency of the bilinear transform).
* :func:`hampel_filter`: replaces samples further than ``n_sigma`` robust standard
  deviations (1.4826 x MAD) from the running median by that median.

NaN samples split the signal into finite segments that are filtered separately (segments
too short for a filter are left as they are), so long gaps stay gaps.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, signal

__all__ = [
    "FILTERS",
    "butterworth_filter",
    "butterworth_sos",
    "filter_positions",
    "hampel_filter",
    "median_filter",
]

FILTERS = ("butterworth", "median", "none")


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
    """Filter (T, J, 3) joint positions with ``kind`` in :data:`FILTERS`."""
    if kind == "butterworth":
        return butterworth_filter(positions, rate, cutoff, order)
    if kind == "median":
        return median_filter(positions, kernel)
    if kind == "none":
        return np.array(positions, dtype=float)
    raise ValueError(f"filter must be one of {', '.join(FILTERS)}, got {kind!r}")
