"""Smooth fits of joint-angle trajectories and their time derivatives.

* ``"polynomial"`` (the thesis' method): a Chebyshev polynomial per joint whose order is
  chosen by K-fold cross-validation (interleaved folds) up to ``max_order``. Recordings
  longer than ``window`` seconds are covered by overlapping windows blended with a
  ``cos^2`` partition of unity (exact derivatives of the blend), because one polynomial
  cannot follow minutes of motion.
* ``"spline"``: a cubic smoothing spline per joint with the smoothing parameter chosen by
  generalised cross-validation (:func:`scipy.interpolate.make_smoothing_spline`).

Both return the value, velocity and acceleration at the sample times. NaN samples split
the signal into finite segments fitted separately; segments shorter than ``min_samples``
keep their values and get NaN derivatives.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import chebyshev as C
from scipy.interpolate import make_smoothing_spline

__all__ = ["FITS", "fit_derivatives", "fit_polynomial", "fit_spline"]

FITS = ("spline", "polynomial")


def _cv_order(x: np.ndarray, y: np.ndarray, max_order: int, folds: int) -> np.ndarray:
    """Per-column polynomial order (in x in [-1, 1]) by K-fold CV with the one-standard-error
    rule: the lowest order whose mean held-out error is within one standard error of the best."""
    n = len(x)
    top = int(max(1, min(max_order, n // 2 - 1)))
    fold = np.arange(n) % folds
    errors = np.zeros((folds, top + 1, y.shape[1]))
    full = C.chebvander(x, top)
    for k in range(folds):
        train, test = fold != k, fold == k
        for order in range(top + 1):
            coef, *_ = np.linalg.lstsq(full[train, : order + 1], y[train], rcond=None)
            errors[k, order] = ((full[test, : order + 1] @ coef - y[test]) ** 2).mean(0)
    mean, se = errors.mean(0), errors.std(0, ddof=1) / np.sqrt(folds)
    best = mean.argmin(0)
    cols = np.arange(y.shape[1])
    threshold = mean[best, cols] + se[best, cols]
    return (mean <= threshold).argmax(0)


def _poly_window(t: np.ndarray, y: np.ndarray, max_order: int, folds: int) -> tuple[np.ndarray, ...]:
    """Fit one window: returns (value, d/dt, d2/dt2) at t, each (n, D), and the chosen orders."""
    a, b = t[0], t[-1]
    scale = 2.0 / (b - a)
    x = (t - a) * scale - 1.0
    orders = _cv_order(x, y, max_order, folds)
    out = np.empty((3, len(t), y.shape[1]))
    for d, order in enumerate(orders):
        coef = C.chebfit(x, y[:, d], int(order))
        out[0, :, d] = C.chebval(x, coef)
        out[1, :, d] = C.chebval(x, C.chebder(coef, 1)) * scale if order >= 1 else 0.0
        out[2, :, d] = C.chebval(x, C.chebder(coef, 2)) * scale**2 if order >= 2 else 0.0
    return out[0], out[1], out[2], orders


def fit_polynomial(
    t: np.ndarray, y: np.ndarray, *, max_order: int = 12, folds: int = 5, window: float = 4.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Polynomial fit with cross-validated order (see module docstring).

    Args:
        t: (T,) s, increasing. y: (T, D) finite values.
        max_order: highest polynomial order tried. folds: CV folds.
        window: s; longer signals are fitted in windows of this length (50 % overlap).

    Returns:
        ``(value, velocity, acceleration, info)``, arrays (T, D); ``info["orders"]`` is the
        (W, D) array of chosen orders per window.
    """
    if max_order < 0 or folds < 2:
        raise ValueError(f"need max_order >= 0 and folds >= 2, got {max_order}, {folds}")
    if not (np.isfinite(window) and window > 0):
        raise ValueError(f"polynomial window must be a positive number of seconds, got {window!r}")
    duration = t[-1] - t[0]
    if duration <= window:
        v, dv, ddv, orders = _poly_window(t, y, max_order, folds)
        return v, dv, ddv, {"orders": orders[None]}
    n_windows = int(np.ceil(duration / (window / 2)))
    h = duration / n_windows
    centres = t[0] + h * np.arange(n_windows + 1)
    out = np.zeros((3, len(t), y.shape[1]))
    all_orders = []
    for c in centres:
        inside = (t >= c - h) & (t <= c + h)
        tt = t[inside]
        v, dv, ddv, orders = _poly_window(tt, y[inside], max_order, folds)
        all_orders.append(orders)
        phase = np.pi * (tt - c) / (2 * h)
        w = np.cos(phase) ** 2
        dw = -(np.pi / (2 * h)) * np.sin(2 * phase)
        ddw = -(np.pi**2 / (2 * h * h)) * np.cos(2 * phase)
        # cos^2 bumps spaced h apart sum to 1 on [t0, t_end]; derivatives by the product rule.
        out[0, inside] += w[:, None] * v
        out[1, inside] += w[:, None] * dv + dw[:, None] * v
        out[2, inside] += w[:, None] * ddv + 2 * dw[:, None] * dv + ddw[:, None] * v
    return out[0], out[1], out[2], {"orders": np.array(all_orders)}


def spline_lambda(cutoff: float, dt: float) -> float:
    """Smoothing parameter of a cubic smoothing spline that is -3 dB at ``cutoff`` Hz.

    ``make_smoothing_spline`` minimises ``sum (y_i - g(t_i))^2 + lam * int g''^2``; for samples
    ``dt`` apart the sum is ``int (y - g)^2 / dt``, so the spline acts (away from the ends)
    as the filter ``1 / (1 + lam dt w^4)``, which is ``1/sqrt(2)`` at ``w = 2 pi cutoff``
    when ``lam = (sqrt(2) - 1) / (dt w^4)``.
    """
    if not (np.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"spline cutoff must be a positive frequency in Hz, got {cutoff!r}")
    return float((np.sqrt(2.0) - 1.0) / (dt * (2 * np.pi * cutoff) ** 4))


def fit_spline(
    t: np.ndarray, y: np.ndarray, *, cutoff: float | None = 3.0, lam: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Cubic smoothing spline per column.

    Args:
        t: (T,) s. y: (T, D).
        cutoff: Hz, sets the smoothing (:func:`spline_lambda`); ``None`` with ``lam=None``
            chooses it by generalised cross-validation per column (slow, and it under-smooths
            data that was already low-pass filtered, whose noise is no longer white).
        lam: explicit smoothing parameter (overrides ``cutoff``).

    Returns ``(value, velocity, acceleration, info)``, arrays (T, D).
    """
    if lam is None and cutoff is not None:
        lam = spline_lambda(cutoff, float(np.median(np.diff(t))))
    out = np.empty((3, *y.shape))
    for d in range(y.shape[1]):
        spline = make_smoothing_spline(t, y[:, d], lam=lam)
        out[0, :, d] = spline(t)
        out[1, :, d] = spline(t, 1)
        out[2, :, d] = spline(t, 2)
    return out[0], out[1], out[2], {}


def _reflect(t: np.ndarray, y: np.ndarray, pad: int) -> tuple[np.ndarray, np.ndarray, slice]:
    """Odd reflection of ``pad`` samples at both ends: ``y(t0 - s) = 2 y(t0) - y(t0 + s)``."""
    k = min(pad, len(t) - 1)
    if k <= 0:
        return t, y, slice(0, len(t))
    t_pre, y_pre = 2 * t[0] - t[k:0:-1], 2 * y[0] - y[k:0:-1]
    t_post, y_post = 2 * t[-1] - t[-2 : -k - 2 : -1], 2 * y[-1] - y[-2 : -k - 2 : -1]
    return np.concatenate([t_pre, t, t_post]), np.concatenate([y_pre, y, y_post]), slice(k, k + len(t))


#: Shortest run of finite samples that is fitted (shorter runs get no velocity or acceleration).
MIN_SAMPLES = 8


def fit_derivatives(
    t: np.ndarray,
    q: np.ndarray,
    method: str = "spline",
    *,
    min_samples: int = MIN_SAMPLES,
    pad: int = 15,
    **options,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smoothed angles and their first and second time derivatives.

    Args:
        t: (T,) s. q: (T, D) rad, NaN rows = missing. method: one of :data:`FITS`.
        pad: samples of odd reflection added at both ends of each segment before fitting
            (point symmetry about the end sample keeps value and slope continuous), which
            removes most of the end effects of both fits.
        **options: passed to :func:`fit_spline` / :func:`fit_polynomial`.

    Returns:
        ``(q_fit, qd, qdd)``, (T, D) each, rad, rad/s, rad/s^2.
    """
    if method not in FITS:
        raise ValueError(f"fit must be one of {', '.join(FITS)}, got {method!r}")
    fit = fit_spline if method == "spline" else fit_polynomial
    q = np.asarray(q, dtype=float)
    value, vel, acc = np.full_like(q, np.nan), np.full_like(q, np.nan), np.full_like(q, np.nan)
    if pad < 0:
        raise ValueError(f"pad must be >= 0 samples, got {pad!r}")
    finite = np.isfinite(q).all(1)
    padded = np.concatenate([[0], finite.astype(np.int8), [0]])
    edges = np.diff(padded)
    for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        if stop - start < min_samples:
            value[start:stop] = q[start:stop]
            continue
        tt, qq, inner = _reflect(t[start:stop], q[start:stop], pad)
        v, dv, ddv, _ = fit(tt, qq, **options)
        value[start:stop], vel[start:stop], acc[start:stop] = v[inner], dv[inner], ddv[inner]
    return value, vel, acc
