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


def _raw_joint_state_bag(path, kind, entries, topic="/joint_states"):
    """A JointState bag of ``entries`` ``(receive_s, stamp_s, positions or raw bytes)``, written with rosbags'
    writers in this order (a ROS 1 header's ``seq`` is the entry's number, as a publisher numbers them)."""
    store = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    types = store.types
    empty = np.zeros(0)

    def message(k, stamp, q):
        ns = int(round(1e9 * stamp))
        fields = dict(
            stamp=types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""
        )
        if kind == "ros1":
            fields["seq"] = k
        header = types["std_msgs/msg/Header"](**fields)
        msg = types["sensor_msgs/msg/JointState"](
            header=header, name=list(NAMES), position=np.asarray(q, float), velocity=empty, effort=empty
        )
        return (
            store.serialize_ros1(msg, msg.__msgtype__)
            if kind == "ros1"
            else store.serialize_cdr(msg, msg.__msgtype__)
        )

    if kind == "ros1":
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        writer = Writer(
            path, version=9, storage_plugin=StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        )
    with writer:
        conn = writer.add_connection(topic, "sensor_msgs/msg/JointState", typestore=store)
        for k, (receive, stamp, q) in enumerate(entries):
            raw = q if isinstance(q, bytes) else message(k, stamp, q)
            writer.write(conn, int(round(1e9 * receive)), raw)
    return path


def _jumping_clock(t, q, jump_at, both):
    """Entries of a recording whose clock jumps back 1 s at sample ``jump_at``: the header stamps (and the
    bag's receive times too when ``both``)."""
    clock = np.where(np.arange(len(t)) >= jump_at, t - 1.0, t) + 100.0
    return [(c if both else 100.0 + tk, c, qk) for tk, c, qk in zip(t, clock, q)]


@pytest.mark.parametrize(
    ("kind", "both"), [("ros1", False), ("ros1", True), ("ros2", False), ("ros2", True), ("mcap", False)]
)
def test_a_clock_that_jumps_back_is_refused_naming_the_message(tmp_path, kind, both):
    """A clock that jumps back 1 s mid-recording: the header stamps go back (the bag's receive times too
    for ``both``: the bag then interleaves two stretches of the motion, which ROS 1 sequence numbers
    reveal); refused in one line naming the bag, the topic and the message, never a zigzag trajectory."""
    t = np.linspace(0.0, 4.0, 81)
    q = np.stack([np.sin(t), np.cos(t), 0.3 * t, -0.2 * t], axis=1)
    bag = _raw_joint_state_bag(
        tmp_path / ("arm.bag" if kind == "ros1" else "arm"), kind, _jumping_clock(t, q, 40, both)
    )
    with pytest.raises(ValueError) as info:
        read_joint_states(bag, joint_names=NAMES)
    message = str(info.value)
    assert message.startswith(f"{bag}: topic /joint_states: ") and "\n" not in message, message
    if both and kind == "ros1":  # the sequence numbers go back
        assert "message 22 (at 101.050000000 s) has sequence number 21 after 40" in message, message
    elif both:  # the stored order goes back
        assert "stored message 40 of arm.db3 was received at 101.000000000 s, 0.950000 s before" in message, (
            message
        )
    else:
        assert (
            "the header clock goes back 0.950000 s at message 40 (101.000000000 s after 101.950000000 s)"
            in message
        ), message
    good = _raw_joint_state_bag(
        tmp_path / ("ok.bag" if kind == "ros1" else "ok"), kind, _jumping_clock(t, q, 81, both)
    )
    np.testing.assert_allclose(
        read_joint_states(good, joint_names=NAMES).q, q
    )  # the same bag without the jump


@pytest.mark.parametrize("kind", ["ros1", "ros2", "mcap"])
def test_random_bytes_as_a_joint_state_message_are_one_line(tmp_path, kind):
    t = np.linspace(0.0, 1.0, 10)
    q = np.zeros((10, 4))
    entries = [(100.0 + tk, 100.0 + tk, qk) for tk, qk in zip(t, q)]
    entries[5] = (entries[5][0], 0.0, np.random.default_rng(0).bytes(64))
    bag = _raw_joint_state_bag(tmp_path / ("arm.bag" if kind == "ros1" else "arm"), kind, entries)
    with pytest.raises(ValueError) as info:
        read_joint_states(bag, joint_names=NAMES)
    message = str(info.value)
    assert message.startswith(
        f"{bag}: topic /joint_states: message 5 (received at 100.555555556 s) is not a readable"
    )
    assert "\n" not in message


def test_a_bag_with_a_broken_message_definition_is_one_line(tmp_path):
    """rosbags' parse error quotes the definition over several lines: lfd folds it into its one line
    (found by the fuzz harness: one byte of 'float64[]' changed)."""
    path = write_joint_states(tmp_path / "arm.bag", np.arange(5) * 0.1, np.zeros((5, 2)), ["a", "b"])
    data = path.read_bytes()
    assert b"float64[] position" in data
    path.write_bytes(data.replace(b"float64[] position", b"float-1[] position"))
    with pytest.raises(ValueError) as info:
        read_joint_states(path, joint_names=["a", "b"])
    message = str(info.value)
    assert message.startswith(f"{path}: not a readable ROS bag (AnyReaderError: ") and "\n" not in message
    assert len(message) < len(str(path)) + 340
