"""Scene files: the shipped scene loads, bad scenes fail with errors naming the field."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from teach_helpers import BOXES, ROOT

from lfd.teach import TeachSession, load_scene


def test_shipped_scene_loads():
    scene = load_scene(BOXES)
    assert scene.name == "boxes" and len(scene.obstacles) == 2 and scene.goal.radius == 0.05
    assert np.isclose(np.degrees(scene.obstacles[1].yaw), 20.0)
    assert load_scene(scene.to_dict()).to_dict() == scene.to_dict()  # the dict form round-trips


@pytest.mark.parametrize(
    ("scene", "match"),
    [
        ({"obstacles": [{"center": [0.5, 0.0], "size": [0.1, 0.1, 0.1]}]}, r"obstacles\[0\]\.center"),
        ({"obstacles": [{"center": [0.5, 0.0, 0.1], "size": [0.1, -0.1, 0.1]}]}, r"obstacles\[0\]\.size"),
        ({"obstacles": [{"center": [0.5, 0.0, 0.1]}]}, r"obstacles\[0\]\.size' is missing"),
        ({"obstacles": [{"center": [0.5, 0.0, 0.1], "size": [0.1, 0.1, 0.1], "colour": 1}]}, "unknown key"),
        ({"goal": {"center": [0.5, 0.0, 0.1], "radius": 0}}, "goal.radius"),
        ({"goal": {"center": [0.5, "x", 0.1], "radius": 0.1}}, "goal.center"),
        ({"table_z": float("nan")}, "table_z"),
        ({"start": [0.0, 0.0, 0.0, np.inf]}, "start"),
        ({"goals": {}}, "unknown key"),
    ],
)
def test_bad_fields_are_named(scene, match):
    with pytest.raises(ValueError, match=match):
        load_scene(scene)


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="scene file not found"):
        load_scene(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("obstacles: [ {center: [1, 2\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_scene(bad)


def test_unknown_robot():
    with pytest.raises(ValueError, match="unknown robot 'ur5'.*pr2_right_arm, sawyer, wam4"):
        TeachSession(robot="ur5")
    with pytest.raises(ValueError, match="not a teachable arm"):
        TeachSession(robot="human_arm")


def test_obstacle_overlapping_the_base():
    scene = {"obstacles": [{"center": [0.05, 0.0, 0.0], "size": [0.1, 0.1, 0.1]}]}
    with pytest.raises(ValueError, match=r"obstacles\[0\]' overlaps the robot base"):
        TeachSession(robot="wam4", scene=scene)


def test_goal_out_of_reach():
    with pytest.raises(ValueError, match="'goal': unreachable for wam4"):
        TeachSession(robot="wam4", scene={"goal": {"center": [1.5, 0.0, 0.3], "radius": 0.05}})


def test_start_pose_checked():
    with pytest.raises(ValueError, match="'start' must have 4"):
        TeachSession(robot="wam4", scene={"start": [0.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match="joint 1 = 2.500 rad is outside"):
        TeachSession(robot="wam4", scene={"start": [0.0, 2.5, 0.0, 1.0]})
    with pytest.raises(ValueError, match="start pose is in collision"):
        TeachSession(robot="wam4", scene={"start": [0.0, 1.5, 0.0, 1.5], "table_z": 0.0})


def _script(*overrides: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "teach.py"), *overrides],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_entry_point_prints_the_url():
    out = _script("robot=wam4", "scene=configs/teach/boxes.yaml", "port=0", "duration_s=0")
    assert out.returncode == 0, out.stderr
    assert "teach: wam4 ready at http://127.0.0.1:" in out.stdout
    assert "this machine only, no token" in out.stdout and "token=" not in out.stdout


@pytest.mark.slow
def test_entry_point_reports_a_bad_scene(tmp_path):
    scene = tmp_path / "s.yaml"
    scene.write_text("goal: {center: [0.4, 0, 0.3], radius: -1}\n")
    out = _script("robot=wam4", f"scene={scene}", "port=0", "duration_s=0")
    assert out.returncode == 2 and "goal.radius" in out.stderr


def test_entry_point_refuses_a_busy_port_in_one_line():
    """On every interface a busy port is refused (viser alone would move to the next port silently)."""
    import socket

    with socket.socket() as blocker:
        blocker.bind(("0.0.0.0", 0))
        blocker.listen()
        port = blocker.getsockname()[1]
        out = _script("robot=wam4", "scene=null", "host=0.0.0.0", f"port={port}", "duration_s=0")
    assert out.returncode == 2, out.stdout + out.stderr
    assert (
        out.stderr.strip()
        == f"teach: port {port} on 0.0.0.0 is in use: choose another port (port=0 picks a free one)"
    )
    assert "ready at" not in out.stdout and "Traceback" not in out.stderr


@pytest.mark.parametrize(
    ("text", "fragment"),
    [
        (
            "goal: {center: [0.4, 0.2, 0.1], radius: 0/05}\n",
            "scene field 'goal.radius' must be a finite number",
        ),
        (
            "obstacles: [{center: [0, 0, 0], size: [1, 1, 1]}, null]\n",
            "scene field 'obstacles[1]' must be a mapping",
        ),
        ("- just a list\n", "a scene must be a mapping"),
        ("start: [1, .nan, 2, 3]\n", "scene field 'start' contains NaN or inf"),
        ("obstacles: " + "x" * 5000 + "\n", "scene field 'obstacles' must be a list, got 'xxx"),
    ],
    ids=["goal-radius", "null-obstacle", "a-list", "nan-start", "long-value"],
)
def test_a_bad_field_in_a_scene_file_is_one_line_naming_the_file(tmp_path, text, fragment):
    """Field errors of a scene read from a file name the file (found by the fuzz harness), and quote at most
    a short piece of the value."""
    from lfd.teach import TeachSession

    path = tmp_path / "scene.yaml"
    path.write_text(text)
    with pytest.raises(ValueError) as info:
        TeachSession(robot="wam4", scene=path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and fragment in message and "\n" not in message
    assert len(message) < len(str(path)) + 250


def test_every_teach_robot_starts_in_the_shipped_scene():
    """configs/teach/boxes.yaml gives the WAM's start; every other arm starts at its home pose, clear of
    the wall (``python scripts/teach.py robot=<any>`` runs with the default scene)."""
    from lfd.teach.settings import teach_robots

    scene = load_scene(BOXES)
    assert set(scene.start) == {"wam4"}
    for robot in teach_robots():
        with TeachSession(robot=robot, scene=BOXES) as s:
            expected = scene.start["wam4"] if robot == "wam4" else s.robot.home.numpy()
            np.testing.assert_allclose(s.q, expected)
            assert not s.checker.check(s.q).in_collision


def test_a_start_per_robot_round_trips_and_a_wrong_length_says_how_to_fix_it(tmp_path):
    scene = load_scene({"start": {"wam4": [0.0, 0.6, 0.0, 1.6], "sawyer": [0, -0.8, 0, 2.1, 0, 0.3, 0]}})
    assert load_scene(scene.to_dict()).to_dict() == scene.to_dict()
    np.testing.assert_allclose(scene.start_for("sawyer"), [0, -0.8, 0, 2.1, 0, 0.3, 0])
    assert scene.start_for("panda") is None
    with pytest.raises(ValueError, match=r"start: \{sawyer: \[\.\.\.\], \.\.\.\}"):
        TeachSession(robot="sawyer", scene={"start": [0.0, 0.6, 0.0, 1.6]})
    with pytest.raises(ValueError, match="scene field 'start.wam4' must be a flat list of numbers"):
        load_scene({"start": {"wam4": [[0.0]]}})
