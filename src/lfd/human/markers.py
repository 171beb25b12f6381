"""Arm angles from marker geometry and from raw joint geometry, and per-trial summaries (docs/human.md).

The validation of :func:`lfd.human.analyze_arm` against marker motion capture (UI-PRMD's Vicon
Plug-in Gait markers, :mod:`lfd.human.readers.vicon`) compares per-trial summaries, because
the Vicon and Kinect recordings of a trial are not frame-synchronised:

* :func:`marker_arm_angles`: the thorax frame of the ISB recommendation (Wu et al. 2005) from
  the trunk markers (IJ = ``CLAV``, PX = ``STRN``, C7 = ``C7``, T8 ~ ``T10``, one vertebra
  lower: Plug-in Gait has no T8 marker): origin IJ; ``Y`` (up) from the midpoint of PX and T8
  to the midpoint of IJ and C7; ``Z`` (right) perpendicular to the plane of IJ, C7 and that
  lower midpoint; ``X`` (forward) = ``Y x Z``; in lfd's trunk axes x = X, y = -Z, z = Y. The
  arm is the glenohumeral centre (estimated from the acromion marker ``SHO``, Rab et al. 2002)
  -> elbow marker (``ELB``, lateral epicondyle) -> wrist (midpoint of ``WRA`` and ``WRB``), and
  its ISB angles are :func:`lfd.human.arm_ik.arm_ik` of those points in that frame, frame by frame.
* :func:`raw_arm_angles`: the same per-frame IK of a skeleton's shoulder, elbow and wrist as
  read, in lfd's trunk frame (:func:`lfd.human.trunk.trunk_frames`) of the same raw joints, with
  no gap handling, filtering or fitting: the sensor's own geometry.
* :func:`trial_summary`: peak and range of the elevation, mean and peak elbow flexion.

Surface markers are not joint centres: the acromion marker sits a few centimetres above and
lateral to the humeral head and the epicondyle marker lateral to the elbow axis, so the
marker humerus differs from a joint-centre humerus by a few degrees (most when the arm hangs).
"""

from __future__ import annotations

import numpy as np

from .arm_ik import arm_ik
from .skeleton import Skeleton
from .trunk import to_trunk, trunk_frames

__all__ = [
    "SUMMARY_KEYS",
    "isb_thorax_frames",
    "marker_arm_angles",
    "moving_side",
    "raw_arm_angles",
    "trial_summary",
    "trunk_marker_shape",
]

#: The per-trial summary quantities of :func:`trial_summary` (degrees).
SUMMARY_KEYS = ("peak_elevation", "elevation_range", "mean_elbow_flexion", "peak_elbow_flexion")


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _need(markers: Skeleton, names: list[str]) -> None:
    missing = [n for n in names if n not in markers.names]
    if missing:
        raise ValueError(f"{markers.source or 'markers'}: missing marker(s) {missing}; has {markers.names}")


_TRUNK = ("clav", "strn", "c7", "t10")


def trunk_marker_shape(markers: Skeleton) -> np.ndarray | None:
    """(4, 3) m median positions of the trunk markers ``clav, strn, c7, t10`` relative to their centroid, in
    the frames' own ISB thorax axes, over the frames where all four are seen; None if there is none."""
    _need(markers, list(_TRUNK))
    pts = np.stack([markers.joint(n) for n in _TRUNK], 1)
    ok = np.isfinite(pts).all((1, 2))
    if not ok.any():
        return None
    rotation, _ = _frames(pts[ok])
    local = np.einsum("tij,tki->tkj", rotation, pts[ok] - pts[ok].mean(1, keepdims=True))
    return np.median(local, axis=0)


def _frames(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ij, px, c7, t8 = pts[:, 0], pts[:, 1], pts[:, 2], pts[:, 3]
    y_isb = _unit(0.5 * (ij + c7) - 0.5 * (px + t8))
    z_isb = _unit(np.cross(ij - c7, y_isb))  # normal of the plane (IJ, C7, lower midpoint), to the right
    x_isb = np.cross(y_isb, z_isb)
    return np.stack([x_isb, -z_isb, y_isb], axis=-1), ij


def _fill_rigid(pts: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Fill one lost marker per frame from the other three and the rigid ``shape`` (Kabsch fit)."""
    pts = pts.copy()
    for t in np.flatnonzero(np.isnan(pts).any(2).sum(1) == 1).tolist():
        seen = np.isfinite(pts[t]).all(1)
        a, b = shape[seen], pts[t, seen]
        ca, cb = a.mean(0), b.mean(0)
        u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
        d = np.sign(np.linalg.det(u @ vt))
        r = (u @ np.diag([1.0, 1.0, d]) @ vt).T
        pts[t, ~seen] = (shape[~seen] - ca) @ r.T + cb
    return pts


def isb_thorax_frames(markers: Skeleton, shape: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """ISB thorax frames from the Plug-in Gait trunk markers ``clav``, ``strn``, ``c7``, ``t10``.

    A marker lost in a frame where the other three are seen is filled as a rigid body from
    ``shape`` ((4, 3), :func:`trunk_marker_shape`; default: this recording's own, when it has
    a frame with all four).

    Returns:
        ``(rotation (T, 3, 3), origin (T, 3))``: columns of ``rotation`` are the thorax axes in
        lfd's trunk convention (x forward, y left, z up) in the marker frame; origin IJ (``clav``);
        NaN where two or more trunk markers are lost.

    Raises:
        ValueError: a trunk marker is missing from ``markers.names``.
    """
    _need(markers, list(_TRUNK))
    pts = np.stack([markers.joint(n) for n in _TRUNK], 1)
    shape = trunk_marker_shape(markers) if shape is None else np.asarray(shape, float)
    if shape is not None:
        pts = _fill_rigid(pts, shape)
    return _frames(pts)


def marker_arm_angles(
    markers: Skeleton,
    side: str,
    singular_deg: float = 10.0,
    shape: np.ndarray | None = None,
    shoulder: str = "gh",
) -> np.ndarray:
    """(T, 4) rad ISB angles (:mod:`lfd.human.arm_ik`) of the marker arm of ``side`` in the ISB thorax
    (:func:`isb_thorax_frames`, ``shape`` passed on); the wrist is the midpoint of WRA and WRB, or the
    one of them that is seen. ``shoulder``: ``"gh"`` (default) the glenohumeral centre estimated as in
    Rab et al. (2002, Gait Posture 15:113), 17 % of the distance between the two acromion markers below
    the acromion marker along the thorax's vertical; ``"acromion"`` the acromion marker itself (it sits
    above the humeral head, so it reads the elevation of a raised arm lower by up to ~10 deg).

    Raises:
        ValueError: a needed marker is missing, a bad side.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    s = side[0]
    _need(markers, ["lsho", "rsho", f"{s}elb", f"{s}wra", f"{s}wrb"])
    if shoulder not in ("gh", "acromion"):
        raise ValueError(f"shoulder must be 'gh' or 'acromion', got {shoulder!r}")
    rotation, origin = isb_thorax_frames(markers, shape)
    joint = markers.joint(f"{s}sho")
    if shoulder == "gh":
        width = np.linalg.norm(markers.joint("lsho") - markers.joint("rsho"), axis=1)
        joint = joint - 0.17 * np.nanmedian(width) * rotation[:, :, 2]
    wra, wrb = markers.joint(f"{s}wra"), markers.joint(f"{s}wrb")
    wrist = np.where(np.isnan(wra), wrb, np.where(np.isnan(wrb), wra, 0.5 * (wra + wrb)))
    points = np.stack([joint, markers.joint(f"{s}elb"), wrist], 1)
    arm = to_trunk(points, rotation, origin)
    return arm_ik(arm[:, 0], arm[:, 1], arm[:, 2], side, singular_deg=singular_deg).q


def raw_arm_angles(skeleton: Skeleton, side: str, singular_deg: float = 10.0) -> np.ndarray:
    """(T, 4) rad ISB angles of the skeleton's ``side`` arm as read (no filtering, gap filling or fit),
    in lfd's trunk frame of the raw joints.

    Raises:
        ValueError: missing shoulder, elbow or wrist joints, a bad side.
    """
    if side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {side!r}")
    names = [f"{j}_{side}" for j in ("shoulder", "elbow", "wrist")]
    missing = [n for n in names if n not in skeleton.names]
    if missing:
        raise ValueError(f"{skeleton.source or 'skeleton'}: missing joint(s) {missing}")
    rotation, origin = trunk_frames(skeleton)
    arm = to_trunk(np.stack([skeleton.joint(n) for n in names], 1), rotation, origin)
    return arm_ik(arm[:, 0], arm[:, 1], arm[:, 2], side, singular_deg=singular_deg).q


def moving_side(wrist_left: np.ndarray, wrist_right: np.ndarray) -> str:
    """``"left"`` or ``"right"``: the wrist (T, 3) that moves more (larger sum of per-axis ranges, robust
    2-98 % percentiles) - which arm exercises."""

    def spread(w):
        w = w[np.isfinite(w).all(1)]
        return float(np.sum(np.percentile(w, 98, axis=0) - np.percentile(w, 2, axis=0))) if len(w) else 0.0

    return "left" if spread(wrist_left) > spread(wrist_right) else "right"


def trial_summary(q: np.ndarray) -> dict[str, float]:
    """Per-trial summary (degrees) of ISB angles ``q (T, 4)`` rad: ``SUMMARY_KEYS`` (peak elevation,
    elevation range max - min, mean and peak elbow flexion) over the finite frames.

    Raises:
        ValueError: ``q`` not (T, 4) or without a finite frame.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4:
        raise ValueError(f"q must have shape (T, 4) in rad, got {q.shape}")
    ok = np.isfinite(q).all(1)
    if not ok.any():
        raise ValueError("q has no finite frame")
    deg = np.rad2deg(q[ok])
    return {
        "peak_elevation": float(deg[:, 1].max()),
        "elevation_range": float(np.ptp(deg[:, 1])),
        "mean_elbow_flexion": float(deg[:, 3].mean()),
        "peak_elbow_flexion": float(deg[:, 3].max()),
    }
