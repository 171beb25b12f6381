"""Calibrated cameras (:class:`Calibration`: projection with distortion, undistortion) and the
calibration readers (Qualisys ``.qca.txt``, TOML, JSON; :func:`read_calibration`); the formats are
described in :mod:`lfd.human.multiview`."""

from __future__ import annotations

import dataclasses
import json
import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from lfd.io.files import read_text

__all__ = ["Calibration", "read_calibration"]

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
