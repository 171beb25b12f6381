"""Shared parts of the skeleton readers: the error type, text loading (``.gz`` transparent),
number parsing that names the offending line and field, and the checks several formats share.

Every helper raises :class:`SkeletonFormatError` (a ``ValueError``) naming the file, the
1-based line and the field when content is malformed, and ``FileNotFoundError`` for a missing file.
"""

from __future__ import annotations

import gzip
import io
import os
import stat
import zlib
from pathlib import Path

import numpy as np

from ...checks import one_line
from ..skeleton import canonical_joint_name

#: Length units accepted by the readers -> metres.
UNITS = {"m": 1.0, "meters": 1.0, "metres": 1.0, "cm": 0.01, "mm": 0.001}
#: What ``units=`` accepts, as named in its error message (None = ``"auto"``).
UNITS_OPTION = ("m", "cm", "mm", "auto")
#: Kinect tracking state meaning "tracked" (0 = not tracked, 1 = inferred).
KINECT_STATE_TRACKED = 2


class SkeletonFormatError(ValueError):
    """Malformed skeleton file; the message names the file, line (1-based) and field, and the
    problem in one line of at most :data:`MAX_PROBLEM_CHARS` characters (a quoted row is cut)."""

    def __init__(self, path: str | os.PathLike, line: int | None, field: str, problem: str) -> None:
        where = f"{path}" + (f", line {line}" if line is not None else "")
        super().__init__(f"{where}, field {field}: {one_line(problem, MAX_PROBLEM_CHARS)}")
        self.path, self.line, self.field = str(path), line, field


#: Longest problem text of a :class:`SkeletonFormatError` (characters).
MAX_PROBLEM_CHARS = 200

#: Largest skeleton text read (bytes): the file, or a ``.gz`` file's decompressed content
#: (decompression stops there, so a small archive cannot expand to exhaust memory).
MAX_SKELETON_BYTES = 256 << 20


def read_bytes_bounded(path: Path, limit: int | None = None) -> bytes:
    """The bytes of the regular file ``path`` (``.gz``: decompressed), at most ``limit`` of them
    (default :data:`MAX_SKELETON_BYTES`).

    The file is opened without blocking and checked to be a regular file before anything is
    read (a FIFO or a device named like a recording would block or never end).

    Raises:
        FileNotFoundError: missing file or a directory. SkeletonFormatError: not a regular
            file, over ``limit`` bytes (decompressed), bad gzip, or unreadable.
    """
    limit = MAX_SKELETON_BYTES if limit is None else limit
    if not (path.exists() or path.is_symlink()):
        raise FileNotFoundError(f"skeleton file not found: {path}")
    if path.is_dir():
        raise FileNotFoundError(f"skeleton path is a directory, not a file: {path}")
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise SkeletonFormatError(path, None, "file", f"cannot be read ({exc.strerror or exc})") from None
    with os.fdopen(fd, "rb") as f:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise SkeletonFormatError(
                path, None, "file", "not a regular file (a pipe or device?); expected a recording"
            )
        if os.fstat(fd).st_size > limit and path.suffix != ".gz":
            raise SkeletonFormatError(
                path, None, "size", f"{os.fstat(fd).st_size} bytes; a skeleton file has at most {limit}"
            )
        try:
            if path.suffix == ".gz":
                with gzip.GzipFile(fileobj=f) as z:
                    raw = z.read(limit + 1)
                if len(raw) > limit:
                    raise SkeletonFormatError(
                        path,
                        None,
                        "gzip",
                        f"decompresses to more than {limit} bytes; a skeleton file has at most {limit}",
                    )
                return raw
            return f.read(limit + 1)
        except (OSError, EOFError, zlib.error) as exc:
            if path.suffix == ".gz":
                raise SkeletonFormatError(path, None, "gzip", f"not a valid gzip file ({exc})") from None
            raise SkeletonFormatError(path, None, "file", f"cannot be read ({exc})") from None


def open_text(path: Path) -> io.TextIOBase:
    """The file as text (UTF-8, BOM dropped; ``.gz`` decompressed), read by :func:`read_bytes_bounded`.

    Raises:
        FileNotFoundError: missing file or a directory. SkeletonFormatError: not a regular file,
            over :data:`MAX_SKELETON_BYTES`, bad gzip or not UTF-8.
    """
    raw = read_bytes_bounded(path)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SkeletonFormatError(path, None, "encoding", f"not UTF-8 text ({exc})") from exc
    return io.StringIO(text)


def read_lines(path: Path) -> list[str]:
    """The lines of :func:`open_text` (no line ends)."""
    with open_text(path) as f:
        return f.read().splitlines()


def parse_float(token: str, path: Path, line: int, field: str) -> float:
    """``token`` as a finite float, else :class:`SkeletonFormatError` naming ``line`` and ``field``."""
    try:
        value = float(token)
    except ValueError:
        raise SkeletonFormatError(path, line, field, f"expected a number, got {token!r}") from None
    if not np.isfinite(value):
        raise SkeletonFormatError(path, line, field, f"expected a finite number, got {token!r}")
    return value


def parse_row(tokens: list[str], path: Path, line: int, field_names: list[str]) -> np.ndarray:
    """``tokens`` as a float row; on a bad token, :class:`SkeletonFormatError` naming its field."""
    try:
        values = np.array(tokens, dtype=float)
        if np.all(np.isfinite(values)):
            return values
    except ValueError:
        pass
    return np.array([parse_float(tok, path, line, field_names[i]) for i, tok in enumerate(tokens)])


def base_name(path: Path) -> str:
    """The file name without a ``.gz`` suffix."""
    name = path.name
    return name[:-3] if name.endswith(".gz") else name


def check_units(units: object) -> str | None:
    """``units`` lower-cased (``None`` for ``None``/``"auto"``: the format's own unit); ``ValueError``
    naming ``units`` and the accepted values otherwise."""
    if units is None or (isinstance(units, str) and units.lower() == "auto"):
        return None
    if not (isinstance(units, str) and units.lower() in UNITS):
        raise ValueError(
            f"units must be one of {', '.join(UNITS_OPTION)} (auto: the format's own unit), got {units!r}"
        )
    return units.lower()


def length_scale(units: str | None, native: str, path: Path) -> float:
    """Metres per file unit: ``units`` (m, cm, mm), or the format's ``native`` unit for ``None``/``"auto"``.

    Raises:
        ValueError: an unknown ``units``, naming it and the accepted values.
    """
    try:
        return UNITS[check_units(units) or native]
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def check_rate(rate: float, path: Path) -> float:
    """``rate`` (Hz) as a float; ``ValueError`` unless positive and finite."""
    if not (isinstance(rate, (int, float)) and np.isfinite(rate) and rate > 0):
        raise ValueError(f"{path}: rate must be a positive number of Hz, got {rate!r}")
    return float(rate)


def check_time(t: np.ndarray, path: Path, line_numbers: list[int], field: str) -> None:
    """:class:`SkeletonFormatError` at the first sample of ``t`` (s) that does not increase strictly."""
    steps = np.diff(t)
    if np.any(steps <= 0):
        bad = int(np.argmax(steps <= 0)) + 1
        raise SkeletonFormatError(
            path, line_numbers[bad], field, f"time must increase strictly; {t[bad]} follows {t[bad - 1]}"
        )


def canonical_names(names: list[str], path: Path, line: int | None) -> tuple[str, ...]:
    """Canonical joint names of ``names``; :class:`SkeletonFormatError` when two mean the same joint."""
    canonical = [canonical_joint_name(n) for n in names]
    seen: dict[str, str] = {}
    for raw, can in zip(names, canonical):
        if can in seen:
            raise SkeletonFormatError(
                path, line, "joint names", f"{raw!r} and {seen[can]!r} both mean joint {can!r}"
            )
        seen[can] = raw
    return tuple(canonical)
