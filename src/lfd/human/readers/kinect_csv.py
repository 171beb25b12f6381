"""Kinect v2 skeleton CSV (as in KIMORE): one row per frame, no header, 25 joints x (x, y, z, state).

Coordinates are metres in the camera frame (y up); the tracking state is 0 (not tracked),
1 (inferred) or 2 (tracked); a blank row is a frame without a body. Frames are ``1 / rate`` s apart.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..skeleton import KINECT_V2_JOINTS, Skeleton
from .common import KINECT_STATE_TRACKED, SkeletonFormatError, check_rate, length_scale, parse_row, read_lines


def read_kinect_csv(path: Path, *, rate: float = 30.0, units: str | None = None) -> Skeleton:
    """A Kinect v2 CSV at ``rate`` Hz -> :class:`Skeleton` (m, Kinect joint names, only state 2 tracked).

    ``units`` is the unit of the file's coordinates (m, cm, mm; ``None``/``"auto"``: metres).

    Raises:
        SkeletonFormatError: a row without 100 values, a non-number, a state outside {0, 1, 2}, an empty file.
        ValueError: a bad ``rate`` or ``units``.
    """
    rate = check_rate(rate, path)
    scale = length_scale(units, "m", path)
    n_joints = len(KINECT_V2_JOINTS)
    width = 4 * n_joints
    field_names = [f"{j}.{c}" for j in KINECT_V2_JOINTS for c in ("x", "y", "z", "tracking_state")]
    rows = []
    for number, line in enumerate(read_lines(path), start=1):
        if not line.strip().strip(","):
            rows.append(np.full(width, np.nan))
            continue
        tokens = line.rstrip().split(",")
        if tokens and tokens[-1].strip() == "":
            tokens = tokens[:-1]  # trailing comma
        if len(tokens) != width:
            raise SkeletonFormatError(
                path,
                number,
                "columns",
                f"expected {width} values (25 joints x x,y,z,state), got {len(tokens)}",
            )
        rows.append(parse_row(tokens, path, number, field_names))
    if not rows:
        raise SkeletonFormatError(path, None, "content", "file is empty")
    data = np.array(rows).reshape(len(rows), n_joints, 4)
    state = data[..., 3]
    bad = np.isfinite(state) & ~np.isin(state, (0, 1, 2))
    if bad.any():
        frame, joint = np.argwhere(bad)[0]
        raise SkeletonFormatError(
            path,
            int(frame) + 1,
            f"{KINECT_V2_JOINTS[joint]}.tracking_state",
            f"expected 0, 1 or 2, got {state[frame, joint]}",
        )
    return Skeleton(
        t=np.arange(len(rows)) / rate,
        names=KINECT_V2_JOINTS,
        positions=data[..., :3] * scale,
        tracked=state == KINECT_STATE_TRACKED,
        source=f"{path} (kinect_csv)",
        up=np.array([0.0, 1.0, 0.0]),
    )
