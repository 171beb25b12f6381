"""OpenSim ``.trc`` marker files: tab-separated; a header with ``DataRate``, ``NumFrames``,
``NumMarkers`` and ``Units`` (mm, cm or m), a marker-name line starting ``Frame#, Time``, then
one row per frame (an empty cell = a missing marker)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..skeleton import Skeleton
from .common import (
    UNITS,
    SkeletonFormatError,
    canonical_names,
    check_time,
    check_units,
    parse_float,
    read_lines,
)


def _header(lines: list[str], path: Path) -> dict[str, str]:
    """The header keys (line 2) and values (line 3) of a ``.trc`` file's ``lines``."""
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise SkeletonFormatError(
            path, 1, "PathFileType", "not an OpenSim .trc file (first line must start with PathFileType)"
        )
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    header = {k.strip(): v.strip() for k, v in zip(keys, values)}
    for key in ("DataRate", "NumFrames", "NumMarkers", "Units"):
        if key not in header:
            raise SkeletonFormatError(path, 2, key, "missing from the header")
    return header


def trc_units(path: Path) -> str:
    """The ``Units`` of a ``.trc`` file's header, lower case (e.g. ``"mm"``)."""
    return _header(read_lines(path), path)["Units"].lower()


def read_trc(
    path: Path, *, up: tuple[float, float, float] = (0.0, 1.0, 0.0), units: str | None = None
) -> Skeleton:
    """A ``.trc`` file -> :class:`Skeleton` (m, canonical marker names, the file's Time column, s).

    ``up`` is the lab's up axis (OpenSim's y by default). ``units`` (m, cm, mm) overrides the
    header's ``Units``; ``None``/``"auto"`` uses the header.

    Raises:
        SkeletonFormatError: a missing header key, unknown header units (without ``units=``), a row of
        the wrong width, a non-number, time not increasing, two markers meaning the same joint.
        ValueError: a bad ``units``.
    """
    try:
        override = check_units(units)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    lines = read_lines(path)
    header = _header(lines, path)
    units = override or header["Units"].lower()
    if units not in UNITS:
        raise SkeletonFormatError(
            path, 3, "Units", f"expected one of {sorted(UNITS)}, got {header['Units']!r}"
        )
    n_markers = int(parse_float(header["NumMarkers"], path, 3, "NumMarkers"))
    markers = [m.strip() for m in lines[3].split("\t")[2:] if m.strip()]
    if len(markers) != n_markers:
        raise SkeletonFormatError(
            path, 4, "marker names", f"header says NumMarkers={n_markers}, found {len(markers)} names"
        )
    if lines[3].split("\t")[:2] != ["Frame#", "Time"]:
        raise SkeletonFormatError(
            path, 4, "Frame#/Time", "the marker-name line must start with Frame# and Time"
        )
    width = 2 + 3 * n_markers
    field_names = ["Frame#", "Time"] + [f"{m}.{c}" for m in markers for c in "XYZ"]
    rows = []
    for number, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        tokens = line.rstrip("\r\n").split("\t")
        while len(tokens) > width and tokens[-1].strip() == "":
            tokens.pop()
        if len(tokens) != width:
            raise SkeletonFormatError(
                path,
                number,
                "columns",
                f"expected {width} tab-separated values (Frame#, Time, {n_markers} markers x 3), got {len(tokens)}",
            )
        rows.append(
            [
                np.nan if tok.strip() == "" and i >= 2 else parse_float(tok, path, number, field_names[i])
                for i, tok in enumerate(tokens)
            ]
        )
    if not rows:
        raise SkeletonFormatError(path, None, "data", "no data rows")
    data = np.array(rows)
    t = data[:, 1]
    check_time(t, path, [n for n, line in enumerate(lines[5:], start=6) if line.strip()], "Time")
    return Skeleton(
        t=t,
        names=canonical_names(markers, path, 4),
        positions=data[:, 2:].reshape(len(data), n_markers, 3) * UNITS[units],
        source=f"{path} (trc)",
        up=np.asarray(up, float),
    )
