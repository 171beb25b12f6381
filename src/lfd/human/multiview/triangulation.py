"""Confidence-weighted DLT triangulation with rejection of disagreeing views (:func:`triangulate`)."""

from __future__ import annotations

import dataclasses
import itertools
import warnings

import numpy as np

from .calibration import Calibration

__all__ = ["Triangulation", "triangulate"]


@dataclasses.dataclass
class Triangulation:
    """Result of :func:`triangulate`.

    Attributes:
        points: (T, J, 3) m, world frame; NaN where fewer than 2 views agree.
        error: (T, J) px, mean reprojection error over the views used.
        used: (C, T, J) bool, views used per joint.
    """

    points: np.ndarray
    error: np.ndarray
    used: np.ndarray


def dlt_rows(calib: Calibration, px: np.ndarray, conf: np.ndarray, min_confidence: float):
    """Rows of the weighted DLT system, (C, T, J, 2, 4): ``w (x P3 - P1)``, ``w (y P3 - P2)`` on
    undistorted normalised coordinates (``w`` = confidence), and the usable views (C, T, J) bool
    (confidence >= ``min_confidence``, finite pixels)."""
    norm = calib.undistort(px)  # (C, T, J, 2)
    P = np.concatenate([calib.R, calib.t[:, :, None]], 2)  # (C, 3, 4) normalised cameras
    used = (conf >= min_confidence) & np.isfinite(px).all(-1)
    rows = np.stack([norm[..., :1] * P[:, None, None, 2] - P[:, None, None, 0],
                     norm[..., 1:] * P[:, None, None, 2] - P[:, None, None, 1]], -2)  # fmt: skip
    return np.nan_to_num(rows) * np.nan_to_num(conf)[..., None, None], used


def _solve(calib: Calibration, rows: np.ndarray, px: np.ndarray, used: np.ndarray, min_views: int):
    """Weighted DLT of the views in ``used`` (C, T, J): points (T, J, 3), per-view error (C, T, J) px."""
    C, T, J = used.shape
    a = (rows * used[..., None, None]).transpose(1, 2, 0, 3, 4).reshape(T, J, 2 * C, 4)
    _, _, vt = np.linalg.svd(a)
    h = vt[..., -1, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        X = h[..., :3] / h[..., 3:]
    X[used.sum(0) < min_views] = np.nan
    reproj = np.linalg.norm(calib.project(X) - px, axis=-1)  # (C, T, J)
    return X, np.where(used, reproj, np.nan)


def triangulate(
    calib: Calibration,
    pixels: np.ndarray,
    confidence: np.ndarray,
    *,
    min_confidence: float = 0.3,
    max_error_px: float = 20.0,
    min_views: int = 2,
    strategy: str = "greedy",
) -> Triangulation:
    """Confidence-weighted DLT with rejection of disagreeing views.

    Args:
        calib: C cameras. pixels: (C, T, J, 2) px (NaN = missing). confidence: (C, T, J) in [0, 1].
        min_confidence: views below are not used (Pose2Sim's ``likelihood_threshold_triangulation``).
        max_error_px: px, accepted reprojection error (Pose2Sim's
            ``reproj_error_threshold_triangulation`` is 15 px in its demo configuration).
        min_views: never fewer views than this.
        strategy: ``"greedy"``: drop the view with the largest own error while that error
            exceeds ``max_error_px``. ``"subsets"`` (what Pose2Sim's ``triangulation_from_best_cameras`` does): all
            views; when the error exceeds ``max_error_px``, every subset with one view fewer and
            the best of them, then two fewer, ... until the error is below the threshold or only
            ``min_views`` remain.

    Returns:
        :class:`Triangulation`.
    """
    px = np.asarray(pixels, float)
    conf = np.asarray(confidence, float)
    C = calib.n_cameras
    if px.ndim != 4 or px.shape[0] != C or px.shape[-1] != 2:
        raise ValueError(f"pixels must have shape (C={C}, T, J, 2), got {px.shape}")
    if conf.shape != px.shape[:3]:
        raise ValueError(f"confidence must have shape {px.shape[:3]}, got {conf.shape}")
    if strategy not in ("subsets", "greedy"):
        raise ValueError(f"strategy must be 'subsets' or 'greedy', got {strategy!r}")
    if not (max_error_px > 0 and min_views >= 2):
        raise ValueError(f"max_error_px must be > 0 and min_views >= 2; got {max_error_px!r}, {min_views!r}")
    rows, used = dlt_rows(calib, px, conf, min_confidence)
    if strategy == "greedy":
        for _ in range(C):
            points, reproj = _solve(calib, rows, px, used, min_views)
            with np.errstate(all="ignore"):
                worst = np.nanargmax(np.nan_to_num(reproj, nan=-1.0), axis=0)
                worst_err = np.take_along_axis(np.nan_to_num(reproj, nan=-1.0), worst[None], 0)[0]
            drop = (used.sum(0) > min_views) & (worst_err > max_error_px)
            if not drop.any():
                break
            t_idx, j_idx = np.nonzero(drop)
            used[worst[t_idx, j_idx], t_idx, j_idx] = False
    else:
        shape = used.shape[1:]
        best_err, points, chosen = np.full(shape, np.inf), np.full(shape + (3,), np.nan), np.zeros_like(used)
        for k in range(C + 1 - min_views):  # k views left out, fewest first
            level_err, level_X, level_used = (
                np.full(shape, np.inf),
                np.full(shape + (3,), np.nan),
                np.zeros_like(used),
            )
            for keep in itertools.combinations(range(C), C - k):
                mask = np.zeros(C, bool)
                mask[list(keep)] = True
                sub = used & mask[:, None, None]
                X, reproj = _solve(calib, rows, px, sub, min_views)
                with np.errstate(all="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    err = np.where(sub.sum(0) >= min_views, np.nanmean(reproj, axis=0), np.inf)
                better = err < level_err
                level_err = np.where(better, err, level_err)
                level_X = np.where(better[..., None], X, level_X)
                level_used = np.where(better[None], sub, level_used)
            # Entries still above the threshold take this level's best subset (as Pose2Sim does).
            update = (best_err > max_error_px) & np.isfinite(level_err)
            best_err = np.where(update, level_err, best_err)
            points = np.where(update[..., None], level_X, points)
            chosen = np.where(update[None], level_used, chosen)
        used = chosen
        reproj = np.where(used, np.linalg.norm(calib.project(points) - px, axis=-1), np.nan)
    active = used.sum(0) >= min_views
    points = np.where(active[..., None], points, np.nan)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        error = np.where(active, np.nanmean(reproj, axis=0), np.nan)
    return Triangulation(points, error, used)
