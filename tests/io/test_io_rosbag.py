"""lfd.io.rosbag: JointState bags written here with rosbags' own writers (ROS 1, ROS 2 sqlite3, ROS 2 MCAP)
read back in the robot's joint order; JointTrajectory bags read back with rosbags' reader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from lfd.io.rosbag import is_bag, read_joint_states, write_joint_trajectory

NAMES = ["j0", "j1", "j2", "j3"]
STATE = "sensor_msgs/msg/JointState"


def _trajectory():
    t = np.linspace(0.0, 2.0, 40)
    return t, np.stack([np.sin(t), np.cos(t), 0.3 * t, -0.2 * t**2], axis=1)


def _joint_state(store, stamp: float, q_row, order):
    """A message holding the robot's joints in another order, plus a head pan and a gripper."""
    types = store.types
    header = types["std_msgs/msg/Header"]
    sec = int(stamp)
    kwargs = dict(
        stamp=types["builtin_interfaces/msg/Time"](sec=sec, nanosec=int(round((stamp - sec) * 1e9)))
    )
    kwargs["frame_id"] = ""
    if "seq" in header.__dataclass_fields__:
        kwargs["seq"] = 0
    names = [NAMES[i] if isinstance(i, int) else i for i in order]
    position = np.array([q_row[i] if isinstance(i, int) else 0.25 for i in order])
    return types[STATE](
        header=header(**kwargs), name=names, position=position, velocity=np.zeros(0), effort=np.zeros(0)
    )


def write_joint_state_bag(path: Path, kind: str, t, q, topic="/joint_states", t0=100.0) -> Path:
    """A JointState bag of ``q (T, 4)`` stamped ``t0 + t``, joints in the order 3, head_pan, 0, 2, gripper, 1."""
    order = [3, "head_pan", 0, 2, "gripper", 1]
    if kind == "ros1":
        store = get_typestore(Stores.ROS1_NOETIC)
        with Writer1(path) as writer:
            conn = writer.add_connection(topic, STATE, typestore=store)
            for k in range(len(t)):
                msg = _joint_state(store, t0 + t[k], q[k], order)
                writer.write(conn, int((t0 + t[k]) * 1e9), store.serialize_ros1(msg, STATE))
        return path
    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection(topic, STATE, typestore=store)
        for k in range(len(t)):
            writer.write(
                conn,
                int((t0 + t[k]) * 1e9),
                store.serialize_cdr(_joint_state(store, t0 + t[k], q[k], order), STATE),
            )
    return path


@pytest.mark.parametrize("kind", ["ros1", "ros2", "mcap"])
def test_joint_states_are_read_in_the_robots_order_timed_by_header_stamps(tmp_path, kind):
    t, q = _trajectory()
    bag = write_joint_state_bag(tmp_path / ("arm.bag" if kind == "ros1" else "arm"), kind, t, q)
    assert is_bag(bag)
    rec = read_joint_states(bag, joint_names=NAMES)
    np.testing.assert_array_equal(rec.q, q)  # head pan and gripper ignored, order matched by name
    np.testing.assert_allclose(rec.t, t, atol=1e-8)
    assert rec.names == tuple(NAMES) and rec.topic == "/joint_states" and rec.time_source == "header"
    if kind == "mcap":  # the lone .mcap file reads the same
        (mcap,) = bag.glob("*.mcap")
        np.testing.assert_array_equal(read_joint_states(mcap, joint_names=NAMES).q, q)


def test_bad_topics_and_names_are_one_line_listing_what_the_bag_has(tmp_path):
    t, q = _trajectory()
    bag = write_joint_state_bag(tmp_path / "arm.bag", "ros1", t, q, topic="/robot/joint_states")
    with pytest.raises(
        ValueError, match=r"topic '/joint_states' is not in the bag; the bag has: /robot/joint_states"
    ):
        read_joint_states(bag, topic="/joint_states")
    with pytest.raises(ValueError, match=r"match none of the recorded joints \['gripper', 'head_pan', 'j0'"):
        read_joint_states(bag, joint_names=["shoulder", "elbow"])
    with pytest.raises(ValueError, match=r"joints \['j9'\] never recorded"):
        read_joint_states(bag, joint_names=["j0", "j9"])
    (tmp_path / "not.bag").write_bytes(b"\x00garbage" * 10)
    with pytest.raises(ValueError, match="not a readable ROS bag"):
        read_joint_states(tmp_path / "not.bag")
    with pytest.raises(FileNotFoundError):
        read_joint_states(tmp_path / "missing.bag")


@pytest.mark.parametrize("fmt", ["ros1", "ros2", "mcap"])
def test_joint_trajectory_bag_reads_back_with_rosbags(tmp_path, fmt):
    t, q = _trajectory()
    out = write_joint_trajectory(tmp_path / ("out.bag" if fmt == "ros1" else "out"), t, q, NAMES, format=fmt)
    with AnyReader([out], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        (msg,) = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    assert list(msg.joint_names) == NAMES
    np.testing.assert_array_equal(np.array([p.positions for p in msg.points]), q)
    start = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points])
    np.testing.assert_allclose(start, t, atol=1e-9)
    velocity = np.array([p.velocities for p in msg.points])
    np.testing.assert_allclose(velocity[1:-1], np.gradient(q, t, axis=0)[1:-1], atol=1e-12)
    assert not list(tmp_path.glob(".*lfd-partial*"))
    with pytest.raises(FileExistsError):
        write_joint_trajectory(out, t, q, NAMES, format=fmt)
    with pytest.raises(ValueError, match="joint_names"):
        write_joint_trajectory(tmp_path / "x.bag", t, q, NAMES[:3])
