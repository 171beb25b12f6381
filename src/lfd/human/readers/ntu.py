"""NTU RGB+D ``.skeleton`` files: a frame count, then per frame a body count and per body its
info line, a joint count (25) and 25 lines of 12 values (x, y, z in m, depth and colour pixels,
orientation quaternion, tracking state)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..skeleton import KINECT_V2_JOINTS, Skeleton
from .common import KINECT_STATE_TRACKED, SkeletonFormatError, check_rate, length_scale, parse_row, read_lines


class _Tokens:
    """Line reader for the NTU format that remembers line numbers for messages."""

    def __init__(self, path: Path) -> None:
        self.path, self.lines, self.i = path, read_lines(path), 0

    def next(self, field: str, count: int | None = None) -> tuple[list[str], int]:
        while self.i < len(self.lines) and not self.lines[self.i].strip():
            self.i += 1
        if self.i >= len(self.lines):
            raise SkeletonFormatError(self.path, self.i + 1, field, "unexpected end of file")
        tokens, number = self.lines[self.i].split(), self.i + 1
        self.i += 1
        if count is not None and len(tokens) != count:
            raise SkeletonFormatError(self.path, number, field, f"expected {count} values, got {len(tokens)}")
        return tokens, number

    def integer(self, field: str, low: int = 0, high: int | None = None) -> int:
        tokens, number = self.next(field, 1)
        try:
            value = int(tokens[0])
        except ValueError:
            raise SkeletonFormatError(
                self.path, number, field, f"expected an integer, got {tokens[0]!r}"
            ) from None
        if value < low or (high is not None and value > high):
            raise SkeletonFormatError(
                self.path, number, field, f"expected an integer in [{low}, {high}], got {value}"
            )
        return value


_NTU_JOINT_FIELDS = [
    "x",
    "y",
    "z",
    "depth_x",
    "depth_y",
    "colour_x",
    "colour_y",
    "orient_w",
    "orient_x",
    "orient_y",
    "orient_z",
    "tracking_state",
]


def read_ntu(
    path: Path, *, rate: float = 30.0, body: int | str | None = None, units: str | None = None
) -> Skeleton:
    """One body of an NTU file at ``rate`` Hz -> :class:`Skeleton` (m, Kinect joint names).

    ``body`` is an index in order of appearance or a body id; by default the body present in
    the most frames. Frames without that body are NaN. ``units`` is the unit of the file's
    x, y, z (m, cm, mm; ``None``/``"auto"``: metres).

    Raises:
        SkeletonFormatError: malformed counts or joint lines, no body at all. ValueError: unknown
        ``body``, a bad ``rate`` or ``units``.
    """
    rate = check_rate(rate, path)
    scale = length_scale(units, "m", path)
    tok = _Tokens(path)
    n_frames = tok.integer("frame_count", 1)
    bodies: dict[str, np.ndarray] = {}  # body id -> (T, 25, 4)
    order: list[str] = []
    for frame in range(n_frames):
        n_bodies = tok.integer(f"frame {frame + 1} body_count", 0, 6)
        for _ in range(n_bodies):
            info, _number = tok.next(f"frame {frame + 1} body_info", 10)
            body_id = info[0]
            n_joints = tok.integer(f"frame {frame + 1} joint_count", 25, 25)
            if body_id not in bodies:
                bodies[body_id] = np.full((n_frames, n_joints, 4), np.nan)
                order.append(body_id)
            for j in range(n_joints):
                tokens, number = tok.next(f"{KINECT_V2_JOINTS[j]}", 12)
                names = [f"{KINECT_V2_JOINTS[j]}.{f}" for f in _NTU_JOINT_FIELDS]
                values = parse_row(tokens, path, number, names)
                bodies[body_id][frame, j] = values[[0, 1, 2, 11]]
    if not bodies:
        raise SkeletonFormatError(path, None, "bodies", "no body in any frame")
    if body is None:
        chosen = max(order, key=lambda b: int(np.isfinite(bodies[b][:, 0, 0]).sum()))
    elif isinstance(body, int) and not isinstance(body, bool):
        if not 0 <= body < len(order):
            raise ValueError(f"{path}: body={body} out of range; the file has {len(order)} bodies")
        chosen = order[body]
    elif str(body) in bodies:
        chosen = str(body)
    else:
        raise ValueError(f"{path}: body {body!r} not found; body ids: {order}")
    data = bodies[chosen]
    return Skeleton(
        t=np.arange(n_frames) / rate,
        names=KINECT_V2_JOINTS,
        positions=data[..., :3] * scale,
        tracked=data[..., 3] == KINECT_STATE_TRACKED,
        source=f"{path} (ntu, body {chosen})",
        up=np.array([0.0, 1.0, 0.0]),
    )
