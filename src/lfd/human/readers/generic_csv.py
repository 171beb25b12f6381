"""Generic skeleton CSV with a header and a time column (``t``, ``time`` or ``timestamp``, s).

Long layout: columns ``t, joint, x, y, z`` and optionally ``tracked`` (or ``state``,
``tracking_state``; > 0 = tracked), one row per joint and frame. Wide layout: ``t,
<joint>_x, <joint>_y, <joint>_z, ...`` (separator ``_``, ``.``, ``-``, ``:``, space or none),
one row per frame. An empty cell is a missing coordinate.

:func:`write_csv` writes a :class:`Skeleton` in the long layout (with ``tracked``), which :func:`read_csv`
reads back (to 1 µm).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ...io.files import write_text_atomic
from ..skeleton import Skeleton
from .common import SkeletonFormatError, canonical_names, check_time, length_scale, parse_float, read_lines


def read_csv(
    path: Path, *, units: str | None = None, up: tuple[float, float, float] = (0.0, 1.0, 0.0)
) -> Skeleton:
    """A generic CSV (long or wide, chosen by a ``joint`` column) in ``units`` -> :class:`Skeleton` (m).

    ``units``: m, cm or mm; ``None``/``"auto"``: metres. The time column is in seconds.

    Raises:
        ValueError: unknown ``units``. SkeletonFormatError: no time column, rows of the wrong width,
        a non-number, time decreasing, a missing coordinate column, two names meaning the same joint.
    """
    scale = length_scale(units, "m", path)
    numbered = [(n, line) for n, line in enumerate(read_lines(path), start=1) if line.strip()]
    if not numbered:
        raise SkeletonFormatError(path, None, "content", "file is empty")
    header_line, header = numbered[0][0], [h.strip() for h in numbered[0][1].split(",")]
    lower = [h.lower() for h in header]
    time_key = next((k for k in ("t", "time", "timestamp") if k in lower), None)
    if time_key is None:
        raise SkeletonFormatError(
            path, header_line, "t", f"header needs a time column 't' or 'time', got {header}"
        )
    it = lower.index(time_key)
    body = numbered[1:]
    if not body:
        raise SkeletonFormatError(path, None, "data", "no data rows after the header")
    for number, line in body:
        if len(line.split(",")) != len(header):
            raise SkeletonFormatError(
                path,
                number,
                "columns",
                f"expected {len(header)} values as in the header, got {len(line.split(','))}",
            )
    if "joint" in lower:  # long format
        return _read_csv_long(path, header_line, lower, it, body, scale, up)
    return _read_csv_wide(path, header_line, header, it, body, scale, up)


def _read_csv_long(path, header_line, lower, it, body, scale, up) -> Skeleton:
    for key in ("x", "y", "z"):
        if key not in lower:
            raise SkeletonFormatError(
                path, header_line, key, f"long-format CSV needs columns t, joint, x, y, z; got {lower}"
            )
    ij, ix = lower.index("joint"), [lower.index(k) for k in ("x", "y", "z")]
    itr = next((lower.index(k) for k in ("tracked", "state", "tracking_state") if k in lower), None)
    times: list[float] = []
    index_of_time: dict[float, int] = {}
    names: list[str] = []
    records = []
    last_t = -np.inf
    for number, line in body:
        tok = line.split(",")
        t = parse_float(tok[it], path, number, "t")
        if t not in index_of_time:
            if t <= last_t:
                raise SkeletonFormatError(path, number, "t", f"time must not decrease; {t} follows {last_t}")
            index_of_time[t] = len(times)
            times.append(t)
            last_t = t
        joint = tok[ij].strip()
        if not joint:
            raise SkeletonFormatError(path, number, "joint", "empty joint name")
        if joint not in names:
            names.append(joint)
        xyz = [
            np.nan if tok[i].strip() == "" else parse_float(tok[i], path, number, "xyz"[k])
            for k, i in enumerate(ix)
        ]
        tracked = True if itr is None else parse_float(tok[itr], path, number, lower[itr]) > 0
        records.append((index_of_time[t], names.index(joint), xyz, tracked))
    positions = np.full((len(times), len(names), 3), np.nan)
    tracked = np.zeros((len(times), len(names)), bool)
    for ti, ji, xyz, tr in records:
        positions[ti, ji] = xyz
        tracked[ti, ji] = tr
    return Skeleton(
        np.array(times),
        canonical_names(names, path, header_line),
        positions * scale,
        tracked,
        source=f"{path} (csv long)",
        up=np.asarray(up, float),
    )


def _read_csv_wide(path, header_line, header, it, body, scale, up) -> Skeleton:
    joints: dict[str, list[int | None]] = {}
    for i, col in enumerate(header):
        if i == it:
            continue
        match = re.fullmatch(r"(.+?)[ _.\-:]?([xyzXYZ])", col)
        if not match:
            raise SkeletonFormatError(
                path, header_line, col, "wide CSV columns must be <joint>_x, <joint>_y, <joint>_z"
            )
        joints.setdefault(match.group(1), [None, None, None])["xyz".index(match.group(2).lower())] = i
    for joint, cols in joints.items():
        for axis, col in zip("xyz", cols):
            if col is None:
                raise SkeletonFormatError(path, header_line, f"{joint}_{axis}", "missing column")
    names = list(joints)
    t = np.empty(len(body))
    positions = np.full((len(body), len(names), 3), np.nan)
    for r, (number, line) in enumerate(body):
        tok = line.split(",")
        t[r] = parse_float(tok[it], path, number, header[it])
        for j, name in enumerate(names):
            for k, col in enumerate(joints[name]):
                if tok[col].strip():
                    positions[r, j, k] = parse_float(tok[col], path, number, header[col])
    check_time(t, path, [n for n, _ in body], header[it])
    return Skeleton(
        t,
        canonical_names(names, path, header_line),
        positions * scale,
        source=f"{path} (csv wide)",
        up=np.asarray(up, float),
    )


def write_csv(skeleton: Skeleton, path: str | Path) -> Path:
    """Write ``skeleton`` as a long generic CSV, atomically; returns the path. :func:`read_csv` reads it.

    Columns ``t,joint,x,y,z,tracked``: s and m to 1 µm, an empty cell for a missing coordinate, ``tracked``
    1 or 0 (0 wherever a coordinate is missing).
    """
    lines = ["t,joint,x,y,z,tracked"]
    for f, t in enumerate(skeleton.t):
        for j, name in enumerate(skeleton.names):
            p = skeleton.positions[f, j]
            xyz = ",".join("" if not np.isfinite(v) else f"{v:.6f}" for v in p)
            lines.append(f"{t:.6f},{name},{xyz},{int(skeleton.tracked[f, j] and np.isfinite(p).all())}")
    return write_text_atomic(Path(path), "\n".join(lines) + "\n")
