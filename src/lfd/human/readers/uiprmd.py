"""UI-PRMD Kinect recordings and their forward kinematics.

A recording is two comma-separated files: ``.../Positions/<name>_positions.txt`` (per frame,
22 joints x 3: the waist's absolute position, every other joint's offset in its parent's
frame, cm) and the sibling ``.../Angles/<name>_angles.txt`` (22 joints x 3 local Euler
angles, degrees, columns x, y, z). Frames are ``1 / rate`` s apart (30 Hz).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ..skeleton import Skeleton
from .common import SkeletonFormatError, base_name, check_rate, length_scale, parse_row, read_lines

__all__ = ["UIPRMD_JOINTS", "UIPRMD_PARENTS", "read_uiprmd", "uiprmd_global_positions"]

# UI-PRMD Kinect joint order -> canonical names, and each joint's parent (index) in that order.
UIPRMD_JOINTS = (
    "spine_base", "spine_mid", "spine_shoulder", "neck", "head", "head_tip",
    "collar_left", "shoulder_left", "elbow_left", "wrist_left",
    "collar_right", "shoulder_right", "elbow_right", "wrist_right",
    "hip_left", "knee_left", "ankle_left", "foot_left",
    "hip_right", "knee_right", "ankle_right", "foot_right",
)  # fmt: skip
UIPRMD_PARENTS = (-1, 0, 1, 2, 3, 4, 3, 6, 7, 8, 3, 10, 11, 12, 0, 14, 15, 16, 0, 18, 19, 20)


def _uiprmd_angles_path(path: Path) -> Path:
    name = base_name(path)
    angles_name = re.sub(r"_positions(\.txt)$", r"_angles\1", name)
    if angles_name == name:
        raise ValueError(f"{path}: UI-PRMD positions file name must end in _positions.txt; pass angles_path=")
    folder = path.parent.parent / "Angles" if path.parent.name.lower() == "positions" else path.parent
    for candidate in (folder / (angles_name + ".gz"), folder / angles_name):
        if candidate.exists():
            return candidate
    raise FileNotFoundError(
        f"{path}: matching UI-PRMD angles file not found (looked for {folder / angles_name}[.gz])"
    )


def _read_table(path: Path, width: int, field_names: list[str]) -> np.ndarray:
    rows = []
    for number, line in enumerate(read_lines(path), start=1):
        if not line.strip():
            continue
        tokens = [t for t in line.strip().rstrip(",").split(",")]
        if len(tokens) != width:
            raise SkeletonFormatError(
                path, number, "columns", f"expected {width} comma-separated values, got {len(tokens)}"
            )
        rows.append(parse_row(tokens, path, number, field_names))
    if not rows:
        raise SkeletonFormatError(path, None, "content", "file is empty")
    return np.array(rows)


def _euler_matrices(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Local rotations (..., 3, 3) from Euler angles (..., 3) given as x, y, z columns in degrees.

    ``order`` is a scipy-style sequence: upper case = intrinsic (rotating axes), lower case =
    extrinsic (fixed axes), e.g. ``"YXZ"``; the columns are picked in the order of its letters.
    """
    from scipy.spatial.transform import Rotation

    column = {"x": 0, "y": 1, "z": 2}
    picked = angles_deg[..., [column[c.lower()] for c in order]]
    flat = Rotation.from_euler(order, picked.reshape(-1, 3), degrees=True).as_matrix()
    return flat.reshape(*angles_deg.shape[:-1], 3, 3)


def uiprmd_global_positions(
    offsets: np.ndarray, angles_deg: np.ndarray, euler_order: str = "ZXY"
) -> np.ndarray:
    """Global joint positions (T, 22, 3) from UI-PRMD rows: offsets (T, 22, 3) and local Euler angles (T, 22, 3).

    The waist row of ``offsets`` is its absolute position; every other row is the joint's
    offset in its parent's frame. ``global_pos = parent_pos + parent_rot @ offset`` and
    ``global_rot = parent_rot @ local_rot`` (units unchanged).
    """
    local = _euler_matrices(angles_deg, euler_order)
    rot = np.empty_like(local)
    pos = np.empty_like(offsets)
    for j, parent in enumerate(UIPRMD_PARENTS):
        if parent < 0:
            rot[:, j], pos[:, j] = local[:, j], offsets[:, j]
        else:
            rot[:, j] = rot[:, parent] @ local[:, j]
            pos[:, j] = pos[:, parent] + np.einsum("tij,tj->ti", rot[:, parent], offsets[:, j])
    return pos


def read_uiprmd(
    path: Path,
    *,
    rate: float = 30.0,
    euler_order: str = "ZXY",
    angles_path: str | os.PathLike | None = None,
    units: str | None = None,
) -> Skeleton:
    """A UI-PRMD Kinect recording at ``rate`` Hz -> :class:`Skeleton` (m, 22 canonical joints, y up).

    ``units`` is the unit of the positions file (m, cm, mm; ``None``/``"auto"``: centimetres, as
    UI-PRMD publishes it). ``angles_path`` overrides the sibling angles file.

    Raises:
        FileNotFoundError: no angles file. SkeletonFormatError: rows of the wrong width, a non-number,
        the two files' frame counts differ. ValueError: a bad ``rate``, ``euler_order`` or ``units``.
    """
    rate = check_rate(rate, path)
    scale = length_scale(units, "cm", path)
    if not (
        isinstance(euler_order, str)
        and len(euler_order) == 3
        and (euler_order.isupper() or euler_order.islower())
        and set(euler_order.lower()) <= set("xyz")
        and euler_order[0] != euler_order[1] != euler_order[2]
    ):
        raise ValueError(
            f"euler_order must be a 3-letter sequence like 'YXZ' (intrinsic) or 'yxz' (extrinsic), got {euler_order!r}"
        )
    angles_file = Path(angles_path) if angles_path is not None else _uiprmd_angles_path(path)
    names = [f"{j}.{c}" for j in UIPRMD_JOINTS for c in "xyz"]
    offsets = _read_table(path, 66, names).reshape(-1, 22, 3)
    angles = _read_table(angles_file, 66, names).reshape(-1, 22, 3)
    if len(angles) != len(offsets):
        raise SkeletonFormatError(
            angles_file,
            None,
            "rows",
            f"has {len(angles)} frames but the positions file {path} has {len(offsets)}",
        )
    positions = uiprmd_global_positions(offsets, angles, euler_order) * scale
    return Skeleton(
        t=np.arange(len(offsets)) / rate,
        names=UIPRMD_JOINTS,
        positions=positions,
        source=f"{path} (uiprmd, {euler_order})",
        up=np.array([0.0, 1.0, 0.0]),
    )
