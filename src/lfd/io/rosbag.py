"""Robot recordings in ROS bags, read and written with the pure-Python ``rosbags`` library (no ROS install).

- :func:`read_joint_states`: ``sensor_msgs/JointState`` messages of a ROS 1 ``.bag`` file, a ROS 2 bag folder
  (sqlite3 or MCAP storage, with its ``metadata.yaml``) or a lone ``.mcap`` file, as one joint trajectory in a
  given joint order (matched by name; joints not asked for are ignored), timed by the message header stamps.
- :func:`write_joint_trajectory`: one ``trajectory_msgs/JointTrajectory`` message (positions, velocities,
  ``time_from_start``) in a ROS 1 bag, a ROS 2 bag (sqlite3) or a ROS 2 bag with MCAP storage, which a ROS user
  can play to a real arm's trajectory controller.
- :func:`write_joint_states`: a recording as ``sensor_msgs/JointState`` messages (what a robot driver
  publishes on ``/joint_states``; :func:`read_joint_states` reads it back), in the same three bag kinds.

Example::

    from lfd.io.rosbag import read_joint_states, write_joint_trajectory
    rec = read_joint_states("arm.bag", joint_names=["j0", "j1", "j2", "j3"])
    rec.t, rec.q          # (T,) s from the first stamp, (T, 4) rad
    write_joint_trajectory("out.bag", rec.t, rec.q, rec.names)
"""

from __future__ import annotations

import contextlib
import itertools
import os
import shutil
import sqlite3
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lfd.checks import one_line

__all__ = [
    "BAG_FORMATS",
    "JointRecording",
    "is_bag",
    "read_joint_states",
    "write_joint_states",
    "write_joint_trajectory",
]

JOINT_STATE = "sensor_msgs/msg/JointState"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"
#: Output kinds of :func:`write_joint_trajectory`.
BAG_FORMATS = ("ros1", "ros2", "mcap")


def _rosbags():
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:  # a core dependency: only a broken install gets here
        raise ImportError("reading ROS bags needs the rosbags package: pip install rosbags") from exc
    return AnyReader, Stores, get_typestore


def is_bag(path: str | os.PathLike) -> bool:
    """Whether ``path`` looks like a ROS bag: a ``.bag`` or ``.mcap`` file, or a folder holding a ROS 2
    ``metadata.yaml``."""
    p = Path(path)
    if p.is_dir():
        return (p / "metadata.yaml").is_file()
    return p.suffix.lower() in (".bag", ".mcap")


@dataclass(frozen=True)
class JointRecording:
    """Joint positions of a robot recording.

    Attributes:
        t: ``(T,)`` s, strictly increasing, 0 at the first kept message.
        names: the ``n`` joint names, in the order of ``q``'s columns.
        q: ``(T, n)`` joint positions (rad, or m for prismatic joints) as recorded.
        topic: the topic read.
        source: the file or folder read.
        time_source: ``"header"`` (message header stamps) or ``"receive"`` (bag receive times, used when
            the header stamps are all zero).
    """

    t: np.ndarray
    names: tuple[str, ...]
    q: np.ndarray
    topic: str
    source: str
    time_source: str = "header"


def read_joint_states(
    path: str | os.PathLike,
    topic: str | None = None,
    joint_names: Sequence[str] | None = None,
) -> JointRecording:
    """The ``sensor_msgs/JointState`` messages of ``topic`` in the bag at ``path``.

    Args:
        path: ROS 1 ``.bag`` file, ROS 2 bag folder, or ``.mcap`` file.
        topic: the JointState topic; None picks the only one (an error when there are several).
        joint_names: the joints to read, in this order (e.g. the robot's); names a message has beyond
            these are ignored, and messages lacking one of them are skipped. None: the names of the first
            message, in its order.

    Returns:
        :class:`JointRecording`; duplicate stamps are dropped (the first message of a stamp is kept).

    Raises:
        FileNotFoundError: nothing at ``path``.
        ValueError: not a readable bag; ``topic`` absent or not a JointState topic (the message lists the
            topics the bag has); several JointState topics and no ``topic``; none of ``joint_names`` in the
            messages (the message lists the names found); fewer than 2 messages with every joint; a message
            that is no readable JointState (random bytes); a clock that goes back (a header stamp below the
            one before; or, where the bag interleaves two stretches because the recorder's clock jumped too,
            a ROS 1 sequence number below the one before, or a ROS 2 sqlite3 bag whose stored order has a
            receive time going back), naming the message's number and time. Each is one line naming the bag
            and the topic.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no ROS bag at {path}")
    AnyReader, Stores, get_typestore = _rosbags()
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # rosbags raises its own error types for every malformed file
        raise ValueError(f"{path}: not a readable ROS bag ({one_line(exc)})") from None
    try:
        return _read(reader, path, topic, joint_names)
    finally:
        reader.close()


def _read(reader, path: Path, topic: str | None, joint_names: Sequence[str] | None) -> JointRecording:
    topics = {c.topic: c.msgtype for c in reader.connections}
    listing = ", ".join(f"{k} ({v})" for k, v in sorted(topics.items())) or "none"
    states = sorted(k for k, v in topics.items() if v == JOINT_STATE)
    if topic is None:
        if len(states) != 1:
            why = "no sensor_msgs/JointState topic" if not states else f"several JointState topics {states}"
            raise ValueError(
                f"{path}: {why}; pass the topic (e.g. topic={states[0] if states else '/joint_states'}); "
                f"the bag has: {listing}"
            )
        topic = states[0]
    if topics.get(topic) != JOINT_STATE:
        what = (
            "not in the bag"
            if topic not in topics
            else f"a {topics[topic]} topic, not sensor_msgs/JointState"
        )
        raise ValueError(f"{path}: topic {topic!r} is {what}; the bag has: {listing}")
    connections = [c for c in reader.connections if c.topic == topic]
    want = None if joint_names is None else [str(n) for n in joint_names]
    stamps, receive, seqs, numbers, rows, seen = [], [], [], [], [], set()
    messages = reader.messages(connections=connections)
    for number in itertools.count():
        try:
            item = next(messages, None)
        except Exception as exc:  # rosbags' own errors for a corrupt chunk or index
            raise ValueError(
                f"{path}: topic {topic}: unreadable after message {number} ({one_line(exc, 240)})"
            ) from None
        if item is None:
            break
        connection, timestamp, raw = item
        try:
            msg = reader.deserialize(raw, connection.msgtype)
            names = [str(n) for n in msg.name]
            position = [float(p) for p in msg.position]
            stamp = int(msg.header.stamp.sec) + 1e-9 * int(msg.header.stamp.nanosec)
            seq = getattr(msg.header, "seq", None)
        except Exception as exc:  # bytes that are no JointState message: rosbags' or numpy's error
            raise ValueError(
                f"{path}: topic {topic}: message {number} (received at {1e-9 * timestamp:.9f} s) is not a "
                f"readable sensor_msgs/JointState ({one_line(exc, 240)})"
            ) from None
        seen.update(names)
        if want is None:
            want = names
        index = {n: i for i, n in enumerate(names)}
        if not all(n in index for n in want) or len(position) < len(names):
            continue
        rows.append([position[index[n]] for n in want])
        stamps.append(stamp)
        receive.append(1e-9 * timestamp)
        seqs.append(seq)
        numbers.append(number)
    if want is not None and not set(want) & seen:
        raise ValueError(
            f"{path}: topic {topic}: joint names {list(want)} match none of the recorded joints {sorted(seen)}; "
            "pass the robot's names for them (joint_names=)"
        )
    if len(rows) < 2:
        missing = sorted(set(want or ()) - seen)
        detail = f"joints {missing} never recorded" if missing else "fewer than 2 messages"
        raise ValueError(f"{path}: topic {topic}: {detail}; need at least 2 messages holding every joint")
    time_source = "header" if any(stamps) else "receive"
    t = np.asarray(stamps if time_source == "header" else receive, dtype=np.float64)
    _check_clock(path, topic, t, seqs, numbers, time_source)
    _check_stored_order(path, topic)
    q = np.asarray(rows, dtype=np.float64)
    keep = np.concatenate([[True], np.diff(np.maximum.accumulate(t)) > 0]) & (t >= np.maximum.accumulate(t))
    t, q = t[keep], q[keep]
    if not np.isfinite(q).all():
        raise ValueError(f"{path}: topic {topic}: positions hold NaN or inf")
    return JointRecording(t - t[0], tuple(want), q, topic, str(path), time_source)


def _check_clock(path: Path, topic: str, t: np.ndarray, seqs: list, numbers: list[int], source: str) -> None:
    """Refuse a recording whose clock went back (messages in the bag's time order): a header stamp
    below the one before, or (ROS 1) a header sequence number below the one before, which is what a
    clock that jumped back leaves when the bag itself is ordered by the jumped receive times (two
    stretches of the motion interleaved). One line naming the bag, the topic, the message and its time."""
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise ValueError(
            f"{path}: topic {topic}: the {source} clock goes back {t[i - 1] - t[i]:.6f} s at message {numbers[i]} "
            f"({t[i]:.9f} s after {t[i - 1]:.9f} s); lfd reads recordings whose stamps never decrease: "
            "split the bag at the jump"
        )
    known = [(k, s) for k, s in enumerate(seqs) if s is not None]
    if len({s for _, s in known}) > 1:  # ROS 1 headers number the messages as published
        for (_, a), (k, b) in zip(known, known[1:]):
            if b < a:
                raise ValueError(
                    f"{path}: topic {topic}: message {numbers[k]} (at {t[k]:.9f} s) has sequence number {b} "
                    f"after {a}: the recording's clock went back and the bag interleaves two stretches of it; "
                    "split the bag at the jump"
                )


def _check_stored_order(path: Path, topic: str) -> None:
    """Refuse a ROS 2 sqlite3 bag whose ``topic`` messages, in the order they were stored, have receive
    times that go back: the recorder's clock jumped back, and a reader (which orders by time) would
    interleave two stretches of the motion. One line naming the bag, the topic and the stored message."""
    for db in sorted(path.glob("*.db3")) if path.is_dir() else ():
        try:
            with contextlib.closing(sqlite3.connect(f"{db.resolve().as_uri()}?mode=ro", uri=True)) as conn:
                rows = conn.execute(
                    "SELECT messages.timestamp FROM messages JOIN topics ON messages.topic_id = topics.id "
                    "WHERE topics.name = ? ORDER BY messages.id",
                    (topic,),
                )
                previous = None
                for number, (stamp,) in enumerate(rows):
                    if previous is not None and stamp < previous:
                        raise ValueError(
                            f"{path}: topic {topic}: stored message {number} of {db.name} was received at "
                            f"{1e-9 * stamp:.9f} s, {1e-9 * (previous - stamp):.6f} s before the one stored before "
                            "it: the recording's clock went back and the bag interleaves two stretches of it; "
                            "split the bag at the jump"
                        )
                    previous = stamp
        except sqlite3.Error as exc:
            raise ValueError(
                f"{path}: {db.name}: not a readable ROS 2 sqlite3 bag ({one_line(exc, 240)})"
            ) from None


def write_joint_trajectory(
    path: str | os.PathLike,
    t: np.ndarray,
    q: np.ndarray,
    joint_names: Sequence[str],
    *,
    format: str = "ros1",
    topic: str = "/joint_trajectory",
    frame_id: str = "base",
) -> Path:
    """Write ``q (T, n)`` at times ``t (T,)`` s as one ``trajectory_msgs/JointTrajectory`` message.

    The points carry positions, velocities (central differences, zero at both ends) and
    ``time_from_start = t - t[0]``. The bag appears at ``path`` only when complete (written under a
    temporary sibling name, then renamed).

    Args:
        path: a ``.bag`` file (``format="ros1"``) or a ROS 2 bag folder (``"ros2"``: sqlite3 storage;
            ``"mcap"``: MCAP storage). It must not exist.
        format: one of :data:`BAG_FORMATS`.

    Raises:
        ValueError: bad shapes, non-finite values, times not increasing, names not matching ``n``, unknown
            ``format``.
        FileExistsError: ``path`` exists.
    """
    t, q, names, path = _checked_recording(path, t, q, joint_names, format)
    velocity = np.zeros_like(q)
    velocity[1:-1] = (q[2:] - q[:-2]) / (t[2:] - t[:-2])[:, None]
    store = _store(format)
    message = _trajectory_message(store, t, q, velocity, names, frame_id)
    stamp_ns = int(round(1e9 * t[0])) if t[0] > 0 else 0
    return _write_bag(path, format, topic, JOINT_TRAJECTORY, store, [(stamp_ns, message)])


def write_joint_states(
    path: str | os.PathLike,
    t: np.ndarray,
    q: np.ndarray,
    joint_names: Sequence[str],
    *,
    format: str = "ros1",
    topic: str = "/joint_states",
    t0: float = 0.0,
) -> Path:
    """Write ``q (T, n)`` at times ``t (T,)`` s as ``T`` ``sensor_msgs/JointState`` messages (positions only),
    stamped ``t0 + t`` in their headers and in the bag: a recording as a robot driver publishes it, which
    :func:`read_joint_states` reads back. The bag appears at ``path`` only when complete.

    Args:
        path: a ``.bag`` file (``format="ros1"``) or a ROS 2 bag folder (``"ros2"``, ``"mcap"``). It must
            not exist.
        t0: s added to every stamp (a recording's clock rarely starts at 0).

    Raises:
        ValueError: bad shapes, non-finite values, times not increasing, names not matching ``n``, unknown
            ``format``, a negative first stamp.
        FileExistsError: ``path`` exists.
    """
    t, q, names, path = _checked_recording(path, t, q, joint_names, format)
    if t0 + t[0] < 0:
        raise ValueError(f"t0: stamps must be >= 0 s, got a first stamp of {t0 + t[0]} s")
    store = _store(format)
    types = store.types
    header = types["std_msgs/msg/Header"]
    empty = np.zeros(0, dtype=np.float64)
    messages = []
    for k in range(len(t)):
        stamp_ns = int(round(1e9 * (t0 + t[k])))
        fields = dict(stamp=types["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000,
                                                                   nanosec=stamp_ns % 1_000_000_000),
                      frame_id="")  # fmt: skip
        if "seq" in header.__dataclass_fields__:  # ROS 1 headers carry a sequence number
            fields["seq"] = k
        message = types[JOINT_STATE](
            header=header(**fields), name=list(names), position=q[k].copy(), velocity=empty, effort=empty
        )
        messages.append((stamp_ns, message))
    return _write_bag(path, format, topic, JOINT_STATE, store, messages)


def _checked_recording(path, t, q, joint_names, format):
    t = np.asarray(t, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    names = [str(n) for n in joint_names]
    if format not in BAG_FORMATS:
        raise ValueError(f"format: expected one of {BAG_FORMATS}, got {format!r}")
    if q.ndim != 2 or t.shape != (q.shape[0],) or q.shape[0] < 2:
        raise ValueError(f"t, q: expected shapes (T,) and (T, n) with T >= 2, got {t.shape} and {q.shape}")
    if len(names) != q.shape[1]:
        raise ValueError(f"joint_names: {len(names)} names for {q.shape[1]} joints")
    if not (np.isfinite(t).all() and np.isfinite(q).all()) or np.any(np.diff(t) <= 0):
        raise ValueError("t, q: expected finite values and strictly increasing times")
    path = Path(path)
    if path.exists() or path.is_symlink():
        raise FileExistsError(f"{path} exists; lfd writes a new bag only")
    return t, q, names, path


def _store(format: str):
    _, Stores, get_typestore = _rosbags()
    return get_typestore(Stores.ROS1_NOETIC if format == "ros1" else Stores.ROS2_HUMBLE)


def _write_bag(path: Path, format: str, topic: str, msgtype: str, store, messages) -> Path:
    """``messages`` (``(stamp_ns, message)``) of ``msgtype`` on ``topic`` in a new bag at ``path``, written
    under a temporary sibling name and renamed into place when complete."""
    path.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.lfd-partial-"))
    try:
        tmp = scratch / path.name
        if format == "ros1":
            from rosbags.rosbag1 import Writer

            with Writer(tmp) as writer:
                conn = writer.add_connection(topic, msgtype, typestore=store)
                for stamp_ns, message in messages:
                    writer.write(conn, stamp_ns, store.serialize_ros1(message, msgtype))
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            plugin = StoragePlugin.MCAP if format == "mcap" else StoragePlugin.SQLITE3
            with Writer(tmp, version=9, storage_plugin=plugin) as writer:
                conn = writer.add_connection(topic, msgtype, typestore=store)
                for stamp_ns, message in messages:
                    writer.write(conn, stamp_ns, store.serialize_cdr(message, msgtype))
        os.rename(tmp, path)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return path


def _trajectory_message(store, t, q, velocity, names, frame_id):
    types = store.types
    Time = types["builtin_interfaces/msg/Time"]
    Duration = types["builtin_interfaces/msg/Duration"]
    Header = types["std_msgs/msg/Header"]
    Point = types["trajectory_msgs/msg/JointTrajectoryPoint"]
    Trajectory = types[JOINT_TRAJECTORY]

    def duration(seconds: float):
        sec = int(np.floor(seconds))
        return Duration(sec=sec, nanosec=int(round((seconds - sec) * 1e9)) % 1_000_000_000)

    empty = np.zeros(0, dtype=np.float64)
    points = [
        Point(
            positions=q[i].copy(),
            velocities=velocity[i].copy(),
            accelerations=empty,
            effort=empty,
            time_from_start=duration(t[i] - t[0]),
        )
        for i in range(len(t))
    ]
    header_kwargs = dict(stamp=Time(sec=0, nanosec=0), frame_id=frame_id)
    if "seq" in Header.__dataclass_fields__:  # ROS 1 headers carry a sequence number
        header_kwargs["seq"] = 0
    return Trajectory(header=Header(**header_kwargs), joint_names=list(names), points=points)
