"""Demonstration sources of the imitation pipeline, detected from the path (or named with ``source_type=``).

- ``video``: a video of one person (``.mp4``, ``.avi``, ``.mov``, ``.mkv``, ``.webm``): MediaPipe keypoints,
  then the person's arm;
- ``multiview``: a list of synchronised videos of one person with ``calibration=`` (the source is a list):
  keypoints per view, triangulated (:mod:`lfd.imitation.multiview`), then the arm;
- ``skeleton``: any file :func:`lfd.human.read_skeleton` reads (Kinect CSV, NTU, UI-PRMD, TRC, CSV): the arm;
- ``teach``: a teach export folder (``demo.json`` of format ``lfd-teach-demonstration``): robot joints;
- ``bag``: a ROS 1 ``.bag``, a ROS 2 bag folder or an ``.mcap`` file with ``sensor_msgs/JointState``: robot
  joints;
- ``joint_csv``: a CSV with a ``time`` column and one column per joint (the robot's names, or
  ``j0..j{n-1}``): robot joints; blank lines and ``#`` comment lines are skipped.

A robot source must carry the chosen robot's joints (matched by name; ``j0..`` columns by position);
it then skips retargeting. Units: s, rad.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "HUMAN_SOURCES",
    "ROBOT_SOURCES",
    "SOURCE_TYPES",
    "RobotDemonstration",
    "detect_source_type",
    "is_path_list",
    "load_robot_source",
]

HUMAN_SOURCES = ("video", "multiview", "skeleton")
ROBOT_SOURCES = ("teach", "bag", "joint_csv")
SOURCE_TYPES = HUMAN_SOURCES + ROBOT_SOURCES
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v")
TIME_COLUMNS = ("time", "time_s", "t")


def _is_comment(line: str) -> bool:
    """Whether a line of a joint CSV is skipped: blank, or a ``#`` comment (as in ``data/fixtures/``)."""
    stripped = line.strip()
    return not stripped or stripped.startswith("#")


def _joint_csv_header(path: Path) -> list[str] | None:
    """The header of ``path`` when it reads as a joint CSV (a time column, no ``_x``/``joint`` columns);
    blank and ``#`` comment lines before it are skipped."""
    try:
        with path.open(encoding="utf-8-sig") as f:
            line = next((line for line in f if not _is_comment(line)), None)
    except (OSError, UnicodeDecodeError):
        return None
    header = next(csv.reader([line]), None) if line is not None else None
    if not header or header[0].strip().lower() not in TIME_COLUMNS:
        return None
    rest = [h.strip().lower() for h in header[1:]]
    if not rest or "joint" in rest or any(h.endswith(("_x", "_y", "_z")) for h in rest):
        return None
    return [h.strip() for h in header]


def is_path_list(source: Any) -> bool:
    """Whether ``source`` is a list of paths (a list, tuple or OmegaConf ``ListConfig``), not one path."""
    return isinstance(source, Sequence) and not isinstance(source, str | bytes | os.PathLike)


def detect_source_type(source: Any) -> str:
    """The source type (:data:`SOURCE_TYPES`) of ``source``: ``multiview`` for a list of videos; else from
    the path's name, and for folders and ``.csv`` files from their content.

    Raises:
        FileNotFoundError: nothing at ``source`` (or at one of the listed videos).
        ValueError: a path of no known type (the message lists the types and ``source_type=``); a list
            holding something other than videos.
    """
    if is_path_list(source):
        for item in source:
            path = Path(str(item))
            if not path.is_file():
                raise FileNotFoundError(f"source: no video at {path}")
            if path.suffix.lower() not in VIDEO_SUFFIXES:
                raise ValueError(
                    f"source: a list of sources is a multiview source and must hold videos "
                    f"({' '.join(VIDEO_SUFFIXES)}), got {path}"
                )
        return "multiview"
    path = Path(str(source))
    if not (path.exists() or path.is_symlink()):
        raise FileNotFoundError(f"source: nothing at {path}")
    from lfd.io.rosbag import is_bag

    if path.is_dir():
        if (path / "demo.json").is_file():
            return "teach"
        if is_bag(path):
            return "bag"
    elif is_bag(path):
        return "bag"
    elif path.suffix.lower() in VIDEO_SUFFIXES:
        return "video"
    elif path.suffix.lower() == ".csv" and _joint_csv_header(path) is not None:
        return "joint_csv"
    else:
        from lfd.human.readers.dispatch import _infer_format

        try:
            _infer_format(path)
            return "skeleton"
        except ValueError:
            pass
    raise ValueError(
        f"source: cannot tell what {path} is; pass source_type= one of {', '.join(SOURCE_TYPES)} "
        "(a teach export folder holds demo.json, a ROS 2 bag folder metadata.yaml)"
    )


@dataclass(frozen=True)
class RobotDemonstration:
    """Joint positions recorded on a robot.

    Attributes:
        source_type: ``"teach"``, ``"bag"`` or ``"joint_csv"``. source: the path read.
        t: ``(T,)`` s from 0, strictly increasing. q: ``(T, n)`` rad, in the robot's joint order.
        joint_names: the robot's ``n`` names. detail: what was matched or ignored (for the summary).
    """

    source_type: str
    source: str
    t: np.ndarray
    q: np.ndarray
    joint_names: tuple[str, ...]
    detail: dict


def _match_columns(names: Sequence[str], robot_names: Sequence[str], where: str) -> list[int]:
    """Indices into ``names`` of the robot's joints: by name, else ``j0..j{n-1}`` by position."""
    index = {n: i for i, n in enumerate(names)}
    if all(n in index for n in robot_names):
        return [index[n] for n in robot_names]
    positional = [f"j{k}" for k in range(len(robot_names))]
    if all(n in index for n in positional):
        return [index[n] for n in positional]
    raise ValueError(
        f"{where}: joint names {list(names)} do not include the robot's joints {list(robot_names)} "
        f"(or j0..j{len(robot_names) - 1}); joints the robot lacks are ignored, missing ones cannot be"
    )


def _checked(t: np.ndarray, q: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray]:
    if t.ndim != 1 or q.ndim != 2 or len(t) != len(q) or len(t) < 4:
        got = f"times of shape {t.shape} and joints of shape {q.shape}"
        raise ValueError(
            f"{where}: need at least 4 samples of every joint (times (T,), joints (T, J)), got {got}"
        )
    if not (np.isfinite(t).all() and np.isfinite(q).all()):
        raise ValueError(f"{where}: times or joint positions hold NaN or inf")
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"{where}: times must increase strictly")
    return t - t[0], q


def _read_joint_csv(path: Path, robot_names: Sequence[str]) -> tuple[np.ndarray, np.ndarray, dict]:
    from lfd.io.files import read_text

    header = _joint_csv_header(path)
    if header is None:
        raise ValueError(f"{path}: not a joint CSV: expected a header 'time,<joint>,...'")
    rows = [line for line in read_text(path).splitlines() if not _is_comment(line)][1:]
    if not rows:
        raise ValueError(f"{path}: no rows after the header 'time,<joint>,...'; expected one row per sample")
    try:
        data = np.loadtxt(io.StringIO("\n".join(rows)), delimiter=",", ndmin=2, comments=None)
    except ValueError as exc:
        raise ValueError(f"{path}: not a numeric joint CSV ({exc})") from None
    if data.shape[1] != len(header):
        raise ValueError(f"{path}: {data.shape[1]} columns per row, header has {len(header)}")
    columns = _match_columns(header[1:], robot_names, str(path))
    ignored = sorted(set(header[1:]) - {header[1 + c] for c in columns})
    return data[:, 0], data[:, [1 + c for c in columns]], {"ignored_joints": ignored}


def _read_teach(path: Path, robot_name: str, robot_names: Sequence[str]):
    from lfd.io.files import read_json

    info = read_json(path / "demo.json")
    if not isinstance(info, dict) or info.get("format") != "lfd-teach-demonstration":
        raise ValueError(
            f"{path / 'demo.json'}: not a teach export (format is not 'lfd-teach-demonstration')"
        )
    if info.get("robot") != robot_name:
        raise ValueError(
            f"{path}: recorded on {info.get('robot')!r}, not on robot={robot_name!r}; "
            f"pass robot={info.get('robot')} (robot sources are not retargeted across robots)"
        )
    where = path / "demo.json"
    rec = info.get("recording")
    names = info.get("joint_names")
    if not isinstance(rec, dict) or not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise ValueError(f"{where}: expected a 'recording' mapping and 'joint_names' as a list of names")
    try:
        t = np.asarray(rec.get("t", []), dtype=np.float64)
        q = np.asarray(rec.get("q", []), dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"{where}: recording 't' and 'q' must be a list of numbers and a table of numbers"
        ) from None
    columns = _match_columns(names, robot_names, str(where))
    if q.ndim == 2 and q.shape[1] != len(names):
        raise ValueError(f"{where}: recording 'q' has {q.shape[1]} columns for {len(names)} joint_names")
    return t, q[:, columns] if q.ndim == 2 else q, {}


def load_robot_source(
    source: str | os.PathLike, source_type: str, robot, *, topic: str | None = None, joint_names=None
) -> RobotDemonstration:
    """Read a robot source (:data:`ROBOT_SOURCES`) for ``robot`` (:class:`lfd.robots.Robot`).

    Args:
        topic: bag only: the JointState topic (None: the only one).
        joint_names: bag and joint CSV: the names the recording uses for the robot's joints, in the robot's
            order (None: the robot's own names).

    Raises:
        FileNotFoundError: nothing at ``source``.
        ValueError: an unknown type, a recording without the robot's joints (named), too few samples,
            non-finite values, times not increasing, a teach export of another robot.
    """
    path = Path(str(source))
    robot_names = list(robot.joint_names)
    names = robot_names if joint_names is None else [str(n) for n in joint_names]
    if len(names) != len(robot_names):
        raise ValueError(f"joint_names: {len(names)} names for the {len(robot_names)} joints of {robot.name}")
    if source_type == "bag":
        from lfd.io.rosbag import read_joint_states

        rec = read_joint_states(path, topic=topic, joint_names=names)
        t, q, detail = rec.t, rec.q, {"topic": rec.topic, "time_source": rec.time_source}
    elif source_type == "joint_csv":
        t, q, detail = _read_joint_csv(path, names)
    elif source_type == "teach":
        t, q, detail = _read_teach(path, robot.name, robot_names)
    else:
        raise ValueError(f"source_type: {source_type!r} is not a robot source ({', '.join(ROBOT_SOURCES)})")
    t, q = _checked(np.asarray(t, dtype=np.float64), np.asarray(q, dtype=np.float64), str(path))
    return RobotDemonstration(source_type, str(path), t, q, tuple(robot_names), detail)
