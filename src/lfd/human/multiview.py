"""Several calibrated cameras: calibration files, confidence-weighted DLT triangulation.

Calibration formats (:func:`read_calibration`):

* Qualisys ``.qca.txt`` (XML; what Pose2Sim ships): per camera the position (mm) and
  orientation of the camera in the lab, intrinsics in sub-pixel units (1/64 px). The camera
  looks along its ``-z`` with ``y`` up, so the OpenCV rotation is ``Rx(pi) @ M`` with ``M``
  the file's matrix (``r11 .. r33`` row by row), translation ``-R @ position``. Distortion
  is radial ``k1, k2`` and tangential ``p1, p2`` of normalised coordinates.
* TOML (Pose2Sim/Sports2D style): one table per camera with ``matrix`` (3x3), ``distortions``
  (k1, k2, p1, p2), ``rotation`` (Rodrigues vector, world -> camera), ``translation`` (m),
  ``size`` ([w, h] px).
* JSON: ``{"cameras": [{"name", "matrix", "distortions", "rotation" (3x3 or Rodrigues),
  "translation", "size"}, ...]}``, the same meaning.

:func:`triangulate` solves each joint by weighted DLT on undistorted normalised
coordinates (weights = landmark confidence), then repeatedly drops the view with the largest
reprojection error while that error exceeds ``max_error_px`` and at least ``min_views``
views remain (``strategy="subsets"``: Pose2Sim's search over subsets of views instead); it
reports the per-joint reprojection error (px).

The ``.qca.txt`` reader follows the conventions of Pose2Sim's own converter
(``Pose2Sim.calibration.read_qca`` + ``calib_qca_fun``: ``R = Rx(pi) @ M``, principal point
minus the video field's ``left``/``top``, sizes from ``fov_video``), except that Pose2Sim
also divides the distortion coefficients by 64 and this reader does not.

Example::

    >>> from lfd.human.multiview import read_calibration, triangulate   # doctest: +SKIP
    >>> calib = read_calibration("calibration/Calib.qca.txt")           # doctest: +SKIP
    >>> result = triangulate(calib, pixels, confidence)                 # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from lfd.io.files import read_text

__all__ = ["Calibration", "Triangulation", "read_calibration", "triangulate"]

_FLIP = np.diag([1.0, -1.0, -1.0])


def _rodrigues(v) -> np.ndarray:
    v = np.asarray(v, float)
    if v.shape == (3, 3):
        return v
    theta = np.linalg.norm(v)
    if theta < 1e-12:
        return np.eye(3)
    k = v / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * kx @ kx


@dataclasses.dataclass
class Calibration:
    """Pinhole cameras with distortion.

    Attributes:
        names: C camera names. K: (C, 3, 3) px. dist: (C, 4) k1, k2, p1, p2.
        R: (C, 3, 3) world -> camera rotation. t: (C, 3) m. size: (C, 2) [w, h] px.
    """

    names: tuple[str, ...]
    K: np.ndarray
    dist: np.ndarray
    R: np.ndarray
    t: np.ndarray
    size: np.ndarray
    source: str = ""

    @property
    def n_cameras(self) -> int:
        return len(self.names)

    def project(self, points: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` m -> pixels ``(C, ..., 2)`` (with distortion)."""
        pts = np.asarray(points, float)
        cam = np.einsum("cij,...j->c...i", self.R, pts) + self.t.reshape((-1,) + (1,) * (pts.ndim - 1) + (3,))
        with np.errstate(invalid="ignore", divide="ignore"):
            x, y = cam[..., 0] / cam[..., 2], cam[..., 1] / cam[..., 2]
        shape = (-1,) + (1,) * (pts.ndim - 1)
        k1, k2, p1, p2 = (self.dist[:, i].reshape(shape) for i in range(4))
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2 * r2
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        fx, fy, cx, cy = (self.K[:, i, j].reshape(shape) for i, j in ((0, 0), (1, 1), (0, 2), (1, 2)))
        return np.stack([fx * xd + cx, fy * yd + cy], -1)

    def undistort(self, pixels: np.ndarray) -> np.ndarray:
        """Pixels ``(C, ..., 2)`` -> normalised image coordinates ``(C, ..., 2)`` (iterative inverse)."""
        px = np.asarray(pixels, float)
        shape = (-1,) + (1,) * (px.ndim - 2)
        fx, fy, cx, cy = (self.K[:, i, j].reshape(shape) for i, j in ((0, 0), (1, 1), (0, 2), (1, 2)))
        k1, k2, p1, p2 = (self.dist[:, i].reshape(shape) for i in range(4))
        xd, yd = (px[..., 0] - cx) / fx, (px[..., 1] - cy) / fy
        x, y = xd.copy(), yd.copy()
        for _ in range(10):
            r2 = x * x + y * y
            radial = 1 + k1 * r2 + k2 * r2 * r2
            dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
            dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
            x, y = (xd - dx) / radial, (yd - dy) / radial
        return np.stack([x, y], -1)


def _read_qca(path: Path) -> Calibration:
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"calibration {path}: not valid Qualisys XML ({exc})") from exc
    names, K, dist, R, t, size = [], [], [], [], [], []
    for cam in root.findall("cameras/camera"):
        try:
            fov, tr, intr = cam.find("fov_video"), cam.find("transform").attrib, cam.find("intrinsic").attrib
            left, top = float(fov.get("left")), float(fov.get("top"))
            size.append([float(fov.get("right")) - left + 1, float(fov.get("bottom")) - top + 1])
            f = lambda key, intr=intr: float(intr[key])  # noqa: E731
            K.append([[f("focalLengthU") / 64, 0, f("centerPointU") / 64 - left],
                      [0, f("focalLengthV") / 64, f("centerPointV") / 64 - top], [0, 0, 1]])  # fmt: skip
            dist.append(
                [
                    f("radialDistortion1"),
                    f("radialDistortion2"),
                    f("tangentalDistortion1"),
                    f("tangentalDistortion2"),
                ]
            )
            m = np.array([[float(tr[f"r{i}{j}"]) for j in (1, 2, 3)] for i in (1, 2, 3)])
            pos = np.array([float(tr[k]) for k in "xyz"]) / 1000.0
        except (AttributeError, KeyError, TypeError, ValueError) as exc:
            raise ValueError(
                f"calibration {path}, camera {cam.get('serial')!r}: missing or bad field ({exc})"
            ) from exc
        rot = _FLIP @ m
        names.append(cam.get("serial") or f"cam{len(names) + 1:02d}")
        R.append(rot)
        t.append(-rot @ pos)
    if not names:
        raise ValueError(f"calibration {path}: no <camera> entries")
    return Calibration(
        tuple(names), np.array(K), np.array(dist), np.array(R), np.array(t), np.array(size), str(path)
    )


def _from_entries(entries: list[tuple[str, dict]], path: Path) -> Calibration:
    names, K, dist, R, t, size = [], [], [], [], [], []
    for name, cam in entries:
        try:
            K.append(np.asarray(cam["matrix"], float).reshape(3, 3))
            d = np.zeros(4)
            given = np.asarray(cam.get("distortions", [0, 0, 0, 0]), float).ravel()[:4]
            d[: len(given)] = given
            dist.append(d)
            R.append(_rodrigues(np.asarray(cam["rotation"], float)))
            t.append(np.asarray(cam["translation"], float).reshape(3))
            size.append(np.asarray(cam.get("size", [np.nan, np.nan]), float).reshape(2))
        except (KeyError, ValueError, TypeError) as exc:
            raise ValueError(
                f"calibration {path}, camera {name!r}: needs matrix (3x3), rotation, translation ({exc})"
            ) from exc
        names.append(str(cam.get("name", name)))
    if not names:
        raise ValueError(f"calibration {path}: no cameras")
    return Calibration(
        tuple(names), np.array(K), np.array(dist), np.array(R), np.array(t), np.array(size), str(path)
    )


def read_calibration(path: str | os.PathLike, n_cameras: int | None = None) -> Calibration:
    """Read a ``.qca.txt``, ``.toml`` or ``.json`` calibration (see module docstring).

    Raises:
        FileNotFoundError; ValueError for malformed content or when ``n_cameras`` is given and
        the file has a different number of cameras.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"calibration file not found: {p}")
    name = p.name.lower()
    if name.endswith(".qca.txt") or name.endswith(".qca"):
        calib = _read_qca(p)
    elif name.endswith(".toml"):
        import tomllib

        try:
            doc = tomllib.loads(read_text(p))
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"calibration {p}: invalid TOML ({exc})") from exc
        calib = _from_entries([(k, v) for k, v in doc.items() if isinstance(v, dict) and "matrix" in v], p)
    elif name.endswith(".json"):
        try:
            doc = json.loads(read_text(p))
        except json.JSONDecodeError as exc:
            raise ValueError(f"calibration {p}: invalid JSON ({exc})") from exc
        cams = doc.get("cameras") if isinstance(doc, dict) else None
        if not isinstance(cams, list):
            raise ValueError(f"calibration {p}: expected {{'cameras': [...]}}")
        calib = _from_entries([(c.get("name", f"cam{i + 1:02d}"), c) for i, c in enumerate(cams)], p)
    else:
        raise ValueError(f"calibration {p}: unknown format; expected .qca.txt, .toml or .json")
    if n_cameras is not None and calib.n_cameras != n_cameras:
        raise ValueError(
            f"calibration {p} has {calib.n_cameras} cameras ({', '.join(calib.names)}), expected {n_cameras}"
        )
    return calib


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
    import itertools

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
    norm = calib.undistort(px)  # (C, T, J, 2)
    P = np.concatenate([calib.R, calib.t[:, :, None]], 2)  # (C, 3, 4) normalised cameras
    used = (conf >= min_confidence) & np.isfinite(px).all(-1)
    # Rows of A: w (x P3 - P1), w (y P3 - P2), per view: (C, T, J, 2, 4).
    rows = np.stack([norm[..., :1] * P[:, None, None, 2] - P[:, None, None, 0],
                     norm[..., 1:] * P[:, None, None, 2] - P[:, None, None, 1]], -2)  # fmt: skip
    rows = np.nan_to_num(rows) * np.nan_to_num(conf)[..., None, None]
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
