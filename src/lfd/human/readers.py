"""Skeleton file readers: Kinect v2 CSV (KIMORE), NTU RGB+D ``.skeleton``, UI-PRMD, OpenSim ``.trc``, generic CSV.

:func:`read_skeleton` infers the format from the name and first line where that is
unambiguous; ``.gz`` files are read transparently. Every reader returns a
:class:`~lfd.human.skeleton.Skeleton` in metres with canonical joint names, and raises
:class:`SkeletonFormatError` (a ``ValueError``) naming the file, the 1-based line and the
field when the content is malformed; a missing file raises ``FileNotFoundError``.

==============  ===========================================================================
format          layout
==============  ===========================================================================
``kinect_csv``  one row per frame, no header, 25 Kinect joints x (x, y, z, tracking state),
                metres, camera frame (y up); blank row = no body; ``rate`` Hz (default 30)
``ntu``         NTU RGB+D ``.skeleton``: frame count, then per frame bodies x 25 joints x 12
                values; the body with the most frames is taken (or ``body=``: index or id)
``uiprmd``      UI-PRMD Kinect: ``.../Positions/<name>_positions.txt`` and its sibling
                ``.../Angles/<name>_angles.txt``; 22 joints, cm, local offsets and Euler
                angles (``euler_order``, default ``"ZXY"``), 30 Hz
``trc``         OpenSim marker file (tab-separated, ``Units`` mm/cm/m, y up unless ``up=``)
``csv``         generic CSV with a header: long (``t, joint, x, y, z[, tracked]``) or wide
                (``t, <joint>_x, <joint>_y, <joint>_z, ...``); ``units`` and ``up`` options
==============  ===========================================================================

Example::

    >>> from lfd.human import read_skeleton
    >>> sk = read_skeleton("tests/fixtures/human/kimore_ex1_excerpt.csv")   # doctest: +SKIP
    >>> sk.joint("elbow_right").shape                                       # doctest: +SKIP
    (120, 3)
"""

from __future__ import annotations

import gzip
import inspect
import io
import os
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .skeleton import KINECT_V2_JOINTS, Skeleton, canonical_joint_name

__all__ = ["FORMATS", "UIPRMD_JOINTS", "SkeletonFormatError", "read_skeleton"]

FORMATS = ("kinect_csv", "ntu", "uiprmd", "trc", "csv")

# UI-PRMD Kinect joint order -> canonical names, and each joint's parent (index) in that order.
UIPRMD_JOINTS = (
    "spine_base", "spine_mid", "spine_shoulder", "neck", "head", "head_tip",
    "collar_left", "shoulder_left", "elbow_left", "wrist_left",
    "collar_right", "shoulder_right", "elbow_right", "wrist_right",
    "hip_left", "knee_left", "ankle_left", "foot_left",
    "hip_right", "knee_right", "ankle_right", "foot_right",
)  # fmt: skip
UIPRMD_PARENTS = (-1, 0, 1, 2, 3, 4, 3, 6, 7, 8, 3, 10, 11, 12, 0, 14, 15, 16, 0, 18, 19, 20)
_KINECT_STATE_TRACKED = 2
_UNITS = {"m": 1.0, "meters": 1.0, "metres": 1.0, "cm": 0.01, "mm": 0.001}


class SkeletonFormatError(ValueError):
    """Malformed skeleton file; the message names the file, line (1-based) and field."""

    def __init__(self, path: str | os.PathLike, line: int | None, field: str, problem: str) -> None:
        where = f"{path}" + (f", line {line}" if line is not None else "")
        super().__init__(f"{where}, field {field}: {problem}")
        self.path, self.line, self.field = str(path), line, field


def _open_text(path: Path) -> io.TextIOBase:
    if not path.exists():
        raise FileNotFoundError(f"skeleton file not found: {path}")
    if path.is_dir():
        raise FileNotFoundError(f"skeleton path is a directory, not a file: {path}")
    raw = path.read_bytes()
    if path.suffix == ".gz":
        try:
            raw = gzip.decompress(raw)
        except (OSError, EOFError) as exc:
            raise SkeletonFormatError(path, None, "gzip", f"not a valid gzip file ({exc})") from exc
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SkeletonFormatError(path, None, "encoding", f"not UTF-8 text ({exc})") from exc
    return io.StringIO(text)


def _lines(path: Path) -> list[str]:
    with _open_text(path) as f:
        return f.read().splitlines()


def _float(token: str, path: Path, line: int, field: str) -> float:
    try:
        value = float(token)
    except ValueError:
        raise SkeletonFormatError(path, line, field, f"expected a number, got {token!r}") from None
    if not np.isfinite(value):
        raise SkeletonFormatError(path, line, field, f"expected a finite number, got {token!r}")
    return value


def _parse_row(tokens: list[str], path: Path, line: int, field_names: list[str]) -> np.ndarray:
    """Fast path with numpy; on failure find the offending token for the message."""
    try:
        values = np.array(tokens, dtype=float)
        if np.all(np.isfinite(values)):
            return values
    except ValueError:
        pass
    return np.array([_float(tok, path, line, field_names[i]) for i, tok in enumerate(tokens)])


def _base_name(path: Path) -> str:
    name = path.name
    return name[:-3] if name.endswith(".gz") else name


def _infer_format(path: Path) -> str:
    name = _base_name(path).lower()
    if name.endswith(".skeleton"):
        return "ntu"
    if name.endswith(".trc"):
        return "trc"
    if re.search(r"_positions\.txt$", name) or (
        name.endswith(".txt") and path.parent.name.lower() == "positions"
    ):
        return "uiprmd"
    if name.endswith(".csv"):
        for line in _lines(path):
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
        "kinect_csv": _read_kinect_csv,
        "ntu": _read_ntu,
        "uiprmd": _read_uiprmd,
        "trc": _read_trc,
        "csv": _read_csv,
    }
    if fmt not in readers:
        raise ValueError(f"unknown skeleton format {fmt!r}; valid formats: {', '.join(FORMATS)}")
    reader = readers[fmt]
    accepted = set(list(inspect.signature(reader).parameters)[1:])
    unknown = sorted(set(options) - accepted)
    if unknown:
        raise ValueError(f"format {fmt!r} has no option(s) {unknown}; accepted: {sorted(accepted)}")
    return reader(path, **options)


def _check_rate(rate: float, path: Path) -> float:
    if not (isinstance(rate, (int, float)) and np.isfinite(rate) and rate > 0):
        raise ValueError(f"{path}: rate must be a positive number of Hz, got {rate!r}")
    return float(rate)


# ---------------------------------------------------------------------------- Kinect CSV
def _read_kinect_csv(path: Path, *, rate: float = 30.0) -> Skeleton:
    rate = _check_rate(rate, path)
    n_joints = len(KINECT_V2_JOINTS)
    width = 4 * n_joints
    field_names = [f"{j}.{c}" for j in KINECT_V2_JOINTS for c in ("x", "y", "z", "tracking_state")]
    rows = []
    for number, line in enumerate(_lines(path), start=1):
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
        rows.append(_parse_row(tokens, path, number, field_names))
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
        positions=data[..., :3],
        tracked=state == _KINECT_STATE_TRACKED,
        source=f"{path} (kinect_csv)",
        up=np.array([0.0, 1.0, 0.0]),
    )


# ---------------------------------------------------------------------------- NTU RGB+D
class _Tokens:
    """Line reader for the NTU format that remembers line numbers for messages."""

    def __init__(self, path: Path) -> None:
        self.path, self.lines, self.i = path, _lines(path), 0

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


def _read_ntu(path: Path, *, rate: float = 30.0, body: int | str | None = None) -> Skeleton:
    rate = _check_rate(rate, path)
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
                values = _parse_row(tokens, path, number, names)
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
        positions=data[..., :3],
        tracked=data[..., 3] == _KINECT_STATE_TRACKED,
        source=f"{path} (ntu, body {chosen})",
        up=np.array([0.0, 1.0, 0.0]),
    )


# ---------------------------------------------------------------------------- UI-PRMD
def _uiprmd_angles_path(path: Path) -> Path:
    name = _base_name(path)
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
    for number, line in enumerate(_lines(path), start=1):
        if not line.strip():
            continue
        tokens = [t for t in line.strip().rstrip(",").split(",")]
        if len(tokens) != width:
            raise SkeletonFormatError(
                path, number, "columns", f"expected {width} comma-separated values, got {len(tokens)}"
            )
        rows.append(_parse_row(tokens, path, number, field_names))
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


def _read_uiprmd(
    path: Path, *, rate: float = 30.0, euler_order: str = "ZXY", angles_path: str | os.PathLike | None = None
) -> Skeleton:
    rate = _check_rate(rate, path)
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
    positions = uiprmd_global_positions(offsets, angles, euler_order) * _UNITS["cm"]
    return Skeleton(
        t=np.arange(len(offsets)) / rate,
        names=UIPRMD_JOINTS,
        positions=positions,
        source=f"{path} (uiprmd, {euler_order})",
        up=np.array([0.0, 1.0, 0.0]),
    )


# ---------------------------------------------------------------------------- OpenSim TRC
def _read_trc(path: Path, *, up: tuple[float, float, float] = (0.0, 1.0, 0.0)) -> Skeleton:
    lines = _lines(path)
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise SkeletonFormatError(
            path, 1, "PathFileType", "not an OpenSim .trc file (first line must start with PathFileType)"
        )
    keys, values = lines[1].split("\t"), lines[2].split("\t")
    header = {k.strip(): v.strip() for k, v in zip(keys, values)}
    for key in ("DataRate", "NumFrames", "NumMarkers", "Units"):
        if key not in header:
            raise SkeletonFormatError(path, 2, key, "missing from the header")
    units = header["Units"].lower()
    if units not in _UNITS:
        raise SkeletonFormatError(
            path, 3, "Units", f"expected one of {sorted(_UNITS)}, got {header['Units']!r}"
        )
    n_markers = int(_float(header["NumMarkers"], path, 3, "NumMarkers"))
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
                np.nan if tok.strip() == "" and i >= 2 else _float(tok, path, number, field_names[i])
                for i, tok in enumerate(tokens)
            ]
        )
    if not rows:
        raise SkeletonFormatError(path, None, "data", "no data rows")
    data = np.array(rows)
    t = data[:, 1]
    _check_time(t, path, [n for n, line in enumerate(lines[5:], start=6) if line.strip()], "Time")
    return Skeleton(
        t=t,
        names=_canonical_names(markers, path, 4),
        positions=data[:, 2:].reshape(len(data), n_markers, 3) * _UNITS[units],
        source=f"{path} (trc)",
        up=np.asarray(up, float),
    )


def _check_time(t: np.ndarray, path: Path, line_numbers: list[int], field: str) -> None:
    steps = np.diff(t)
    if np.any(steps <= 0):
        bad = int(np.argmax(steps <= 0)) + 1
        raise SkeletonFormatError(
            path, line_numbers[bad], field, f"time must increase strictly; {t[bad]} follows {t[bad - 1]}"
        )


def _canonical_names(names: list[str], path: Path, line: int | None) -> tuple[str, ...]:
    canonical = [canonical_joint_name(n) for n in names]
    seen: dict[str, str] = {}
    for raw, can in zip(names, canonical):
        if can in seen:
            raise SkeletonFormatError(
                path, line, "joint names", f"{raw!r} and {seen[can]!r} both mean joint {can!r}"
            )
        seen[can] = raw
    return tuple(canonical)


# ---------------------------------------------------------------------------- generic CSV
def _read_csv(path: Path, *, units: str = "m", up: tuple[float, float, float] = (0.0, 1.0, 0.0)) -> Skeleton:
    if units not in _UNITS:
        raise ValueError(f"{path}: units must be one of {sorted(_UNITS)}, got {units!r}")
    scale = _UNITS[units]
    numbered = [(n, line) for n, line in enumerate(_lines(path), start=1) if line.strip()]
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
        t = _float(tok[it], path, number, "t")
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
            np.nan if tok[i].strip() == "" else _float(tok[i], path, number, "xyz"[k])
            for k, i in enumerate(ix)
        ]
        tracked = True if itr is None else _float(tok[itr], path, number, lower[itr]) > 0
        records.append((index_of_time[t], names.index(joint), xyz, tracked))
    positions = np.full((len(times), len(names), 3), np.nan)
    tracked = np.zeros((len(times), len(names)), bool)
    for ti, ji, xyz, tr in records:
        positions[ti, ji] = xyz
        tracked[ti, ji] = tr
    return Skeleton(np.array(times), _canonical_names(names, path, header_line), positions * scale, tracked,
                    source=f"{path} (csv long)", up=np.asarray(up, float))  # fmt: skip


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
        t[r] = _float(tok[it], path, number, header[it])
        for j, name in enumerate(names):
            for k, col in enumerate(joints[name]):
                if tok[col].strip():
                    positions[r, j, k] = _float(tok[col], path, number, header[col])
    _check_time(t, path, [n for n, _ in body], header[it])
    return Skeleton(t, _canonical_names(names, path, header_line), positions * scale,
                    source=f"{path} (csv wide)", up=np.asarray(up, float))  # fmt: skip


def _iter_files(folder: Path) -> Iterator[Path]:
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
