"""Where a camera leaves a point's position open: a 3-D point seen by a fixed camera is fixed by its
pixel up to its depth along the line of sight. Over many placements, the residual of the point's
position regressed on its pixel lies along that line; :func:`open_directions` finds it (used by
:meth:`lfd.visuomotor.policies.cnn_dmp.CNNDMPPolicy.fit_depth_directions`)."""

from __future__ import annotations

import torch

#: A placement point whose position its pixel leaves undetermined by more than this (root mean
#: square over the training placements, m) gets a depth along its line of sight (the same 1 cm below
#: which a placement's entries count as constant).
DEPTH_MIN_M = 0.01
#: Fewest placements with a finite pixel for a point to be fitted (the quadratic has 6 terms).
MIN_POINTS = 8


def pixel_design(uv: torch.Tensor) -> torch.Tensor:
    """``(E, 2)`` pixels (standardised) -> ``(E, 6)`` ``[1, u, v, u^2, u v, v^2]``: the design of the
    quadratic regression of a point's position on its pixel (:func:`open_directions`,
    ``scripts/metaworld_plan_error.py``)."""
    u, v = uv[:, :1], uv[:, 1:]
    return torch.cat([torch.ones_like(u), u, v, u * u, u * v, v * v], dim=1)


def open_directions(placement: torch.Tensor, pixels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Each point's open direction: the largest principal component of the residual of its position
    (m) regressed on its pixel (quadratic least squares), scaled to its root mean square, where that
    exceeds :data:`DEPTH_MIN_M`; zero otherwise.

    Args:
        placement: ``(E, p)`` m, the points' coordinates in threes (the last point may be shorter).
        pixels: ``(E, 2 m)`` px, ``[u_0, v_0, ...]``, ``m = ceil(p / 3)``; NaN (padding) left out, a
            point with fewer than :data:`MIN_POINTS` finite pixels gets no direction.

    Returns:
        ``(m, p)`` float64 rows in metres (point ``k``'s entries only) and ``(m,)`` each point's
        residual root mean square (m; 0 where not fitted).
    """
    x, uv_all = placement.detach().double().cpu(), pixels.detach().double().cpu()
    p, m = x.shape[1], uv_all.shape[1] // 2
    rows = torch.zeros(m, p, dtype=torch.float64)
    rms = torch.zeros(m, dtype=torch.float64)
    for k in range(m):
        cols = slice(3 * k, min(3 * k + 3, p))
        uv = uv_all[:, 2 * k : 2 * k + 2]
        ok = torch.isfinite(uv).all(dim=1)
        if int(ok.sum()) < MIN_POINTS:
            continue
        uv = uv[ok]
        design = pixel_design((uv - uv.mean(0)) / uv.std(0).clamp_min(1e-9))
        y = x[ok][:, cols]
        residual = y - design @ torch.linalg.lstsq(design, y).solution
        _, s, vt = torch.linalg.svd(residual - residual.mean(0), full_matrices=False)
        rms[k] = s[0] / len(y) ** 0.5
        if rms[k] > DEPTH_MIN_M:
            rows[k, cols] = vt[0] * rms[k]
    return rows, rms
