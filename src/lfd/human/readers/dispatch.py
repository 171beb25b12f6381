"""Choosing the reader: :func:`read_skeleton` sniffs the format from the file name (and the first
line of a ``.csv``), checks the options against that reader's keywords and calls it;
:func:`iter_skeleton_files` lists the recordings of a folder.
"""

from __future__ import annotations

import inspect
import os
import re
from collections.abc import Iterator
from pathlib import Path

from ..plausibility import check_frame_rate, check_upper_arm
from ..skeleton import KINECT_V2_JOINTS, Skeleton
from .common import UNITS, SkeletonFormatError, base_name, check_units, read_lines
from .generic_csv import read_csv
from .kinect_csv import read_kinect_csv
from .ntu import read_ntu
from .trc import read_trc, trc_units
from .uiprmd import read_uiprmd

__all__ = ["FORMATS", "SkeletonFormatError", "iter_skeleton_files", "read_skeleton"]

#: Format names accepted by :func:`read_skeleton`.
FORMATS = ("kinect_csv", "ntu", "uiprmd", "trc", "csv")
#: Each format's own length unit (``units=None`` or ``"auto"``); ``trc``: its header's ``Units``.
NATIVE_UNITS = {"kinect_csv": "m", "ntu": "m", "uiprmd": "cm", "trc": "header", "csv": "m"}
#: Formats whose times come from ``rate=`` rather than a time column.
_RATE_FORMATS = ("kinect_csv", "ntu", "uiprmd")


def _infer_format(path: Path) -> str:
    """The format of ``path`` from its name (and first non-blank line for ``.csv``); ValueError if unknown."""
    name = base_name(path).lower()
    if name.endswith(".skeleton"):
        return "ntu"
    if name.endswith(".trc"):
        return "trc"
    if re.search(r"_positions\.txt$", name) or (
        name.endswith(".txt") and path.parent.name.lower() == "positions"
    ):
        return "uiprmd"
    if name.endswith(".csv"):
        for line in read_lines(path):
            if line.strip():
                fields = line.rstrip().rstrip(",").split(",")
                numeric = all(re.fullmatch(r"\s*-?[\d.eE+-]+\s*", f) for f in fields)
                if numeric and len(fields) == 4 * len(KINECT_V2_JOINTS):
                    return "kinect_csv"
                return "csv"
        raise SkeletonFormatError(path, None, "content", "file is empty")
    raise ValueError(
        f"{path}: cannot infer the skeleton format from the name; pass format= one of {', '.join(FORMATS)}"
    )


def read_skeleton(
    path: str | os.PathLike, format: str | None = None, units: str | None = None, **options
) -> Skeleton:
    """Read a skeleton recording and check that its scale is a person's.

    Args:
        path: the file (``.gz`` accepted). For ``uiprmd`` the positions file; its angles file
            is found in the sibling ``Angles`` folder (or pass ``angles_path=``).
        format: one of :data:`FORMATS`; inferred from the name (and first line for ``.csv``)
            when omitted.
        units: the length unit of the file's coordinates, ``"m"``, ``"cm"`` or ``"mm"``; ``None``
            or ``"auto"``: the format's own unit (:data:`NATIVE_UNITS`: metres, UI-PRMD
            centimetres, a ``.trc`` file's ``Units`` header).
        **options: per format: ``rate`` (Hz, files without a time column: kinect_csv, ntu,
            uiprmd; default 30), ``body`` (ntu: body index in order of appearance or body id),
            ``euler_order`` and ``angles_path`` (uiprmd), ``up`` (csv and trc;
            OpenSim's y-up by default, e.g. ``(0, 0, 1)`` for a z-up lab).

    Returns:
        :class:`Skeleton` in metres, canonical joint names, ``source = "<path> (<format>)"``.

    Raises:
        FileNotFoundError: missing file.
        SkeletonFormatError: (a ValueError) malformed content, naming file, line and field.
        ValueError: unknown format, option or ``units``; an implausible scale: an upper arm
            (median shoulder-elbow length) outside 0.15-0.6 m (the message suggests the
            ``units=`` that fits) or a frame rate outside 1-1000 Hz (:mod:`lfd.human.plausibility`).
    """
    path = Path(path)
    units = check_units(units)
    if not path.exists():
        raise FileNotFoundError(f"skeleton file not found: {path}")
    fmt = format or _infer_format(path)
    readers = {
        "kinect_csv": read_kinect_csv,
        "ntu": read_ntu,
        "uiprmd": read_uiprmd,
        "trc": read_trc,
        "csv": read_csv,
    }
    if fmt not in readers:
        raise ValueError(f"unknown skeleton format {fmt!r}; valid formats: {', '.join(FORMATS)}")
    reader = readers[fmt]
    accepted = set(list(inspect.signature(reader).parameters)[1:])
    unknown = sorted(set(options) - accepted)
    if unknown:
        raise ValueError(f"format {fmt!r} has no option(s) {unknown}; accepted: {sorted(accepted)}")
    skeleton = reader(path, units=units, **options)
    where = str(path) + (f" (read with units={units})" if units else "")
    if fmt in _RATE_FORMATS:
        time_source = f"rate={options.get('rate', 30.0)!r}"
    else:
        time_source = "Time column" if fmt == "trc" else "time column"
    check_frame_rate(skeleton, str(path), time_source)
    check_upper_arm(skeleton, where, lambda: _applied_scale(path, fmt, units))
    return skeleton


def _applied_scale(path: Path, fmt: str, units: str | None) -> float:
    """Metres per file unit that the reader applied (``units`` or the format's own unit)."""
    return UNITS[units or (trc_units(path) if fmt == "trc" else NATIVE_UNITS[fmt])]


def iter_skeleton_files(folder: Path) -> Iterator[Path]:
    """Skeleton files in a folder (sorted), skipping UI-PRMD angles files."""
    patterns = (
        "*.csv",
        "*.skeleton",
        "*.trc",
        "*_positions.txt",
        "*.csv.gz",
        "*.skeleton.gz",
        "*.trc.gz",
        "*_positions.txt.gz",
    )
    found = sorted({p for pattern in patterns for p in folder.rglob(pattern)})
    yield from found
