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

from ..skeleton import KINECT_V2_JOINTS, Skeleton
from .common import SkeletonFormatError, base_name, read_lines
from .generic_csv import read_csv
from .kinect_csv import read_kinect_csv
from .ntu import read_ntu
from .trc import read_trc
from .uiprmd import read_uiprmd

__all__ = ["FORMATS", "SkeletonFormatError", "iter_skeleton_files", "read_skeleton"]

#: Format names accepted by :func:`read_skeleton`.
FORMATS = ("kinect_csv", "ntu", "uiprmd", "trc", "csv")


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


def read_skeleton(path: str | os.PathLike, format: str | None = None, **options) -> Skeleton:
    """Read a skeleton recording.

    Args:
        path: the file (``.gz`` accepted). For ``uiprmd`` the positions file; its angles file
            is found in the sibling ``Angles`` folder (or pass ``angles_path=``).
        format: one of :data:`FORMATS`; inferred from the name (and first line for ``.csv``)
            when omitted.
        **options: per format: ``rate`` (Hz, files without a time column: kinect_csv, ntu,
            uiprmd; default 30), ``body`` (ntu: body index in order of appearance or body id),
            ``euler_order`` and ``angles_path`` (uiprmd), ``units`` and ``up`` (csv), ``up`` (trc;
            OpenSim's y-up by default, e.g. ``(0, 0, 1)`` for a z-up lab).

    Returns:
        :class:`Skeleton` in metres, canonical joint names, ``source = "<path> (<format>)"``.

    Raises:
        FileNotFoundError: missing file. SkeletonFormatError (ValueError): malformed content,
        naming file, line and field. ValueError: unknown format or option.
    """
    path = Path(path)
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
    return reader(path, **options)


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
