"""lfd.io.rosbag: JointState bags (ROS 1, ROS 2 sqlite3, ROS 2 MCAP, written by ``write_joint_states``) read
back in the robot's joint order and, independently, with rosbags' reader; JointTrajectory bags read back with
rosbags' reader."""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from lfd.io.rosbag import is_bag, read_joint_states, write_joint_states, write_joint_trajectory

NAMES = ["j0", "j1", "j2", "j3"]


def _trajectory():
    t = np.linspace(0.0, 2.0, 40)
    return t, np.stack([np.sin(t), np.cos(t), 0.3 * t, -0.2 * t**2], axis=1)


@pytest.mark.parametrize("kind", ["ros1", "ros2", "mcap"])
def test_joint_states_are_read_in_the_robots_order_timed_by_header_stamps(
    tmp_path, kind, write_joint_state_bag
):
    t, q = _trajectory()
    bag = write_joint_state_bag(tmp_path / ("arm.bag" if kind == "ros1" else "arm"), kind, t, q, NAMES)
    assert is_bag(bag)
    rec = read_joint_states(bag, joint_names=NAMES)
    np.testing.assert_array_equal(rec.q, q)  # head pan and gripper ignored, order matched by name
    np.testing.assert_allclose(rec.t, t, atol=1e-8)
    assert rec.names == tuple(NAMES) and rec.topic == "/joint_states" and rec.time_source == "header"
    if kind == "mcap":  # the lone .mcap file reads the same
        (mcap,) = bag.glob("*.mcap")
        np.testing.assert_array_equal(read_joint_states(mcap, joint_names=NAMES).q, q)


def test_bad_topics_and_names_are_one_line_listing_what_the_bag_has(tmp_path, write_joint_state_bag):
    t, q = _trajectory()
    bag = write_joint_state_bag(tmp_path / "arm.bag", "ros1", t, q, NAMES, topic="/robot/joint_states")
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


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_joint_state_bag_reads_back_with_rosbags(tmp_path, fmt):
    t, q = _trajectory()
    out = write_joint_states(
        tmp_path / ("arm.bag" if fmt == "ros1" else "arm"), t, q, NAMES, format=fmt, t0=12.5
    )
    with AnyReader([out], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        (conn,) = reader.connections
        assert conn.topic == "/joint_states" and conn.msgtype == "sensor_msgs/msg/JointState"
        read = [(ns, reader.deserialize(raw, c.msgtype)) for c, ns, raw in reader.messages()]
    assert len(read) == len(t)
    for (ns, msg), tk, qk in zip(read, t, q):
        stamp = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
        assert abs(stamp - (12.5 + tk)) < 1e-8 and abs(1e-9 * ns - (12.5 + tk)) < 1e-8
        assert list(msg.name) == NAMES
        np.testing.assert_array_equal(msg.position, qk)
    with pytest.raises(FileExistsError, match="exists; lfd writes a new bag only"):
        write_joint_states(out, t, q, NAMES, format=fmt)
    with pytest.raises(ValueError, match="joint_names: 3 names for 4 joints"):
        write_joint_states(tmp_path / "b.bag", t, q, NAMES[:3])
    assert not (tmp_path / "b.bag").exists()


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
