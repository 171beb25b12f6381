"""The imitation pipeline from every kind of demonstration to an executed robot skill: ROS 1 and ROS 2 bags
(written with rosbags, extra joints in another order), a joint CSV, a teach export, real skeleton recordings
(UI-PRMD, KIMORE) to the WAM and the Sawyer; refinement to a new target; the output JointTrajectory bag read
back with rosbags; one-line errors for bad sources."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

import lfd.imitation
from lfd.imitation import ImitationSettings
from lfd.imitation.sources import detect_source_type
from lfd.robots import load_robot

ROOT = Path(__file__).resolve().parents[2]
HUMAN = ROOT / "tests" / "fixtures" / "human"
QUIET = ["outputs.video=false", "outputs.gif=false"]


def _cfg(*overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return ImitationSettings.from_mapping(compose(config_name="imitate", overrides=[*QUIET, *overrides]))


def _run(tmp_path, *overrides):
    out = tmp_path / "run"
    return lfd.imitation.run(_cfg(*overrides), out), out


def _wam_motion():
    """A scripted 2 s WAM reach (minimum-jerk from home), sampled at 50 Hz."""
    robot = load_robot("wam4")
    t = np.linspace(0.0, 2.0, 101)
    s = t / t[-1]
    q = robot.home.numpy() + np.outer(10 * s**3 - 15 * s**4 + 6 * s**5, [0.5, 0.4, -0.3, 0.9])
    return robot, t, q


def _csv_columns(path: Path, suffix: str, names) -> np.ndarray:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return np.array([[float(r[f"{n}_{suffix}"]) for n in names] for r in rows])


def _trajectory_bag(path: Path) -> tuple[list[str], np.ndarray]:
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        (msg,) = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()]
    return list(msg.joint_names), np.array([p.positions for p in msg.points])


@pytest.mark.parametrize("kind", ["ros1", "ros2"])
def test_robot_bag_to_executed_skill_and_a_bag_back(tmp_path, kind, write_joint_state_bag):
    robot, t, q = _wam_motion()
    bag = write_joint_state_bag(
        tmp_path / ("arm.bag" if kind == "ros1" else "arm"), kind, t, q, robot.joint_names
    )
    assert detect_source_type(bag) == "bag"
    summary, out = _run(tmp_path, f"source={bag}", "robot=wam4")
    assert summary["source_type"] == "bag" and summary["frames"] == len(t)
    assert summary["dmp_vs_reference_rmse_rad"] <= 0.01
    assert summary["limit_violations"] == 0 and summary["executed_vs_dmp_rmse_rad"] <= 0.1
    recorded = _csv_columns(out / "robot_trajectory.csv", "reference", robot.joint_names)
    np.testing.assert_allclose(recorded, q, atol=1e-8)  # head pan and gripper dropped, order by name
    names, positions = _trajectory_bag(out / "robot_trajectory.bag")
    executed = _csv_columns(out / "robot_trajectory.csv", "executed", robot.joint_names)
    assert names == list(robot.joint_names)
    np.testing.assert_allclose(positions, executed, atol=1e-8)  # the CSV's 9 significant digits
    end = robot.fk(torch.from_numpy(executed[-1:]))[0, :3, 3].numpy()
    np.testing.assert_allclose(summary["end_tool_position_m"], end, atol=1e-6)
    assert (out / "dmp.json").is_file() and summary["refine"] is None


def test_joint_csv_and_teach_export_sources(tmp_path):
    robot, t, q = _wam_motion()
    table = tmp_path / "arm.csv"
    table.write_text(
        "time,j0,j1,j2,j3\n"
        + "".join(f"{a:.9f}," + ",".join(f"{v:.12f}" for v in row) + "\n" for a, row in zip(t, q))
    )
    teach = tmp_path / "demo-20261205-120000"
    teach.mkdir()
    (teach / "demo.json").write_text(
        json.dumps(
            {
                "format": "lfd-teach-demonstration",
                "robot": "wam4",
                "joint_names": list(robot.joint_names),
                "recording": {"t": (t + 5.0).tolist(), "q": q.tolist()},
            }
        )
    )
    for source, kind in ((table, "joint_csv"), (teach, "teach")):
        assert detect_source_type(source) == kind
        summary, _ = _run(tmp_path / kind, f"source={source}", "robot=wam4")
        assert summary["source_type"] == kind and summary["dmp_vs_reference_rmse_rad"] <= 0.01
        assert summary["limit_violations"] == 0
    with pytest.raises(ValueError, match=r"recorded on 'wam4', not on robot='sawyer'"):
        _run(tmp_path / "other", f"source={teach}", "robot=sawyer")


def test_joint_csv_skips_comment_lines(tmp_path):
    """data/fixtures/sawyer_demo.csv starts with '#' lines: read as a joint CSV (detected and named), its
    rows equal to the file's numbers; a comment between rows is skipped too; a header alone is refused."""
    from lfd.imitation.sources import load_robot_source

    fixture = ROOT / "data" / "fixtures" / "sawyer_demo.csv"
    assert fixture.read_text().startswith("#") and detect_source_type(fixture) == "joint_csv"
    robot = load_robot("sawyer")
    demo = load_robot_source(fixture, "joint_csv", robot)
    rows = [r for r in fixture.read_text().splitlines() if r and not r.startswith("#")][1:]
    expected = np.array([[float(v) for v in r.split(",")] for r in rows])
    assert demo.q.shape == (len(rows), 7)
    np.testing.assert_array_equal(demo.q, expected[:, 1:])
    np.testing.assert_allclose(demo.t, expected[:, 0] - expected[0, 0])
    table = tmp_path / "arm.csv"
    table.write_text(
        "# made by hand\n\ntime,j0,j1,j2,j3\n"
        + "".join(f"{k * 0.1},0,0.{k},0,1\n" + ("  # a note\n" if k == 2 else "") for k in range(5))
    )
    wam = load_robot("wam4")
    assert load_robot_source(table, "joint_csv", wam).q.shape == (5, 4)
    (tmp_path / "empty.csv").write_text("# nothing\ntime,j0,j1,j2,j3\n")
    with pytest.raises(ValueError, match=r"empty.csv: no rows after the header"):
        load_robot_source(tmp_path / "empty.csv", "joint_csv", wam)


def test_shipped_sawyer_csv_runs_through_the_entry_point(tmp_path):
    """The issue's case: scripts/imitate.py refused data/fixtures/sawyer_demo.csv (its '#' header)."""
    fixture = ROOT / "data" / "fixtures" / "sawyer_demo.csv"
    summary, _ = _run(tmp_path, f"source={fixture}", "source_type=joint_csv", "robot=sawyer", *QUIET)
    assert summary["source_type"] == "joint_csv" and summary["limit_violations"] == 0


@pytest.mark.parametrize(
    ("recording", "robot"),
    [
        ("ui_prmd/Kinect/Positions/m07_s02_e01_positions.txt.gz", "wam4"),
        ("ui_prmd/Kinect/Positions/m07_s02_e01_positions.txt.gz", "sawyer"),
        ("kimore_ex1_excerpt.csv.gz", "wam4"),
        ("kimore_ex1_excerpt.csv.gz", "sawyer"),  # an IK restart once jumped branches here (3.7 rad)
    ],
)
def test_real_skeleton_recordings_to_robots(tmp_path, recording, robot):
    summary, out = _run(tmp_path, f"source={HUMAN / recording}", f"robot={robot}", "side=right")
    assert summary["source_type"] == "skeleton" and summary["robot"] == robot
    assert summary["limit_violations"] == 0
    assert summary["dmp_vs_reference_rmse_rad"] <= 0.05
    assert summary["executed_vs_dmp_rmse_rad"] <= 0.1
    assert (out / "arm.mot").is_file() and (out / "robot_trajectory.bag").is_file()


def test_refining_the_imitated_skill_to_a_target_10_cm_away(tmp_path, write_joint_state_bag):
    robot, t, q = _wam_motion()
    bag = write_joint_state_bag(tmp_path / "arm.bag", "ros1", t, q, robot.joint_names)
    end = robot.fk(torch.from_numpy(q[-1:]))[0, :3, 3].numpy()
    target = end + 0.1 * np.array([0.6, 0.6, -0.5]) / np.linalg.norm([0.6, 0.6, -0.5])
    summary, out = _run(
        tmp_path,
        f"source={bag}",
        "robot=wam4",
        "refine.task=reach",
        f"refine.target=[{','.join(map(str, target))}]",
    )
    refine = summary["refine"]
    assert refine["converged"] and refine["task_error_m"] <= 0.01 and refine["rollouts"] > 1
    assert refine["shape_rmse_rad"] > 0 and (out / "refinement.png").stat().st_size > 0
    refined = _csv_columns(out / "robot_trajectory.csv", "refined", robot.joint_names)
    reached = robot.fk(torch.from_numpy(refined[-1:]))[0, :3, 3].numpy()
    assert np.linalg.norm(reached - target) <= 0.0101
    assert np.linalg.norm(np.asarray(summary["end_tool_position_m"]) - target) <= 0.02  # executed in PyBullet


def test_bad_sources_are_one_line(tmp_path, write_joint_state_bag):
    robot, t, q = _wam_motion()
    odd = tmp_path / "notes.xyz"
    odd.write_text("hello")
    with pytest.raises(
        ValueError, match="cannot tell what .* is; pass source_type= one of video, multiview, skeleton"
    ):
        _run(tmp_path, f"source={odd}")
    with pytest.raises(ValueError, match="source_type must be one of"):
        _run(tmp_path, f"source={odd}", "source_type=pdf")
    bag = write_joint_state_bag(
        tmp_path / "arm.bag", "ros1", t, q, robot.joint_names, topic="/robot/joint_states"
    )
    with pytest.raises(
        ValueError, match="topic '/joint_states' is not in the bag; the bag has: /robot/joint_states"
    ):
        _run(tmp_path, f"source={bag}", "topic=/joint_states")
    with pytest.raises(ValueError, match="match none of the recorded joints"):
        _run(tmp_path, f"source={bag}", "joint_names=[a,b,c,d]")
    with pytest.raises(ValueError, match="refine.target .* is out of reach of wam4"):
        _run(tmp_path, f"source={bag}", "refine.task=reach", "refine.target=[3.0,0.0,0.0]")
    with pytest.raises(ValueError, match="refine.target must be a tool position"):
        _run(tmp_path, f"source={bag}", "refine.task=reach")
    head_only = tmp_path / "head.csv"
    head_only.write_text(
        "t,joint,x,y,z\n" + "".join(f"{k / 30},head,0,1.6,0\n{k / 30},neck,0,1.5,0\n" for k in range(30))
    )
    with pytest.raises(ValueError, match="shoulder|elbow|wrist|arm"):
        _run(tmp_path, f"source={head_only}")


@pytest.mark.parametrize(
    ("recording", "names", "expected"),
    [
        (
            {"t": float("nan"), "q": [[0.0] * 4] * 5},
            None,
            r"need at least 4 samples .* got times of shape \(\)",
        ),
        ({"t": [0, 1, 2, 3, 4], "q": [[0.0] * 4, []] * 2 + [[0.0] * 4]}, None, "a table of numbers"),
        ({"t": [0, 1, 2, 3, 4], "q": [[0.0] * 3] * 5}, None, "3 columns for 4 joint_names"),
        ("not a mapping", None, "a 'recording' mapping"),
        ({"t": [0, 1, 2, 3, 4], "q": [[0.0] * 4] * 5}, [1, 2, 3, 4], "a list of names"),
    ],
)
def test_a_damaged_teach_export_is_one_line_naming_it(tmp_path, recording, names, expected):
    """Shapes and types of demo.json are checked before any array is built (found by the fuzz harness:
    a NaN for the times, a ragged table or numbers as joint names ended in a TypeError or numpy's message)."""
    from lfd.imitation.sources import load_robot_source

    robot = load_robot("wam4")
    (tmp_path / "demo.json").write_text(
        json.dumps(
            {
                "format": "lfd-teach-demonstration",
                "robot": "wam4",
                "joint_names": list(robot.joint_names) if names is None else names,
                "recording": recording,
            }
        )
    )
    with pytest.raises(ValueError, match=expected) as info:
        load_robot_source(tmp_path, "teach", robot)
    assert str(tmp_path) in str(info.value) and "\n" not in str(info.value)
