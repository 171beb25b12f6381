"""Sawyer demonstrations (lfd.model_reaching.demonstrations): CSV files, the scripted
demonstration, path augmentation into inverse-model data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from lfd.model_reaching.demonstrations import (
    DEMO_GOAL,
    TASK_ORIENTATIONS_DEG,
    DemoFileError,
    InverseDataConfig,
    build_inverse_data,
    load_demo_csv,
    make_demonstration,
)
from lfd.robots import load_robot, make_transform
from lfd.sim.trajectory import follow_paths, warp_to_goals

ROOT = Path(__file__).resolve().parents[2]
FIXTURE = ROOT / "data" / "fixtures" / "sawyer_demo.csv"
HEADER = "time,j0,j1,j2,j3,j4,j5,j6"


@pytest.fixture(scope="module")
def robot():
    return load_robot("sawyer")


@pytest.fixture(scope="module")
def cube_demo(robot):
    return make_demonstration(robot, TASK_ORIENTATIONS_DEG["cube"])


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "demo.csv"
    path.write_text(text)
    return path


# ---------------------------------------------------------------------------- CSV demonstrations
def test_csv_irregular_rate_is_resampled_uniformly(tmp_path):
    # j0 = 2 t at irregular times, columns shuffled, one extra column, a comment line.
    rows = [f"{t},{2 * t},9,1,2,3,4,5,6,0.5" for t in (10.0, 10.1, 10.35, 10.5, 11.0)]
    path = write(
        tmp_path,
        "# recorded\nj6,time,j0,extra,j1,j2,j3,j4,j5\n"
        + "\n".join(",".join(r.split(",")[i] for i in (8, 0, 1, 2, 3, 4, 5, 6, 7)) for r in rows),
    )
    demo = load_demo_csv(path, n_steps=11)
    assert demo.t == pytest.approx(np.linspace(0.0, 1.0, 11))
    assert demo.q[:, 0] == pytest.approx(2 * (10.0 + demo.t))
    assert demo.q[:, 6] == pytest.approx(np.full(11, 6.0))
    assert demo.source == str(path)


def test_fixture_demo_loads_within_limits(robot):
    demo = make_demonstration(robot, demo_csv=FIXTURE)
    assert demo.q.shape == (100, 7)
    assert demo.duration == pytest.approx(3.96, abs=0.05)
    assert np.linalg.norm(robot.fk_positions(demo.q[-1]).numpy() - DEMO_GOAL) < 0.005


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("time,j0,j1,j2,j3,j4,j6\n0,0,0,0,0,0,0\n", r"demo\.csv:1: header is missing column\(s\) j5"),
        (
            f"{HEADER}\n0,0,0,0,0,0,0,0\n0.1,0,0,abc,0,0,0,0\n",
            r"demo\.csv:3: column 'j2': 'abc' is not a number",
        ),
        (
            f"{HEADER}\n0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,nan\n",
            r"demo\.csv:3: column 'j6': 'nan' is not finite",
        ),
        (
            f"{HEADER}\n0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,0\n",
            r"demo\.csv:4: column 'time': 0\.1 is not greater than the previous time 0\.1 \(line 3\)",
        ),
        (f"{HEADER}\n0,0,0,0,0,0,0,0\n0.1,0,0,0\n", r"demo\.csv:3: column 'j3': value missing"),
        (f"{HEADER}\n0,0,0,0,0,0,0,0\n0.1,0,0,0,0,0,0,0\n", r"need a header and at least 3 samples, got 2"),
    ],
    ids=["missing-column", "non-numeric", "nan", "non-increasing-time", "short-row", "too-few-samples"],
)
def test_csv_errors_name_file_line_and_column(tmp_path, text, expected):
    with pytest.raises(DemoFileError, match=expected):
        load_demo_csv(write(tmp_path, text))


def test_csv_missing_file_and_out_of_limits(tmp_path, robot):
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        load_demo_csv(tmp_path / "nope.csv")
    path = write(tmp_path, f"{HEADER}\n" + "\n".join(f"{t},0,-3.9,0,0,0,0,0" for t in range(3)))
    with pytest.raises(
        DemoFileError, match=r"demo\.csv: 100 resampled sample\(s\) outside the sawyer joint limits"
    ):
        make_demonstration(robot, demo_csv=path)


# ---------------------------------------------------------------------------- scripted demo + augmentation
def test_scripted_demo_reaches_the_goal_pose_at_rest(robot, cube_demo):
    assert cube_demo.q[0] == pytest.approx(np.radians([0, -50, 0, 120, 0, 0, 0]))
    pose = robot.fk(torch.from_numpy(cube_demo.q[-1:]))[0].numpy()
    target = make_transform(DEMO_GOAL, np.radians(TASK_ORIENTATIONS_DEG["cube"]))
    assert np.abs(pose - target).max() < 1e-3
    assert np.abs(cube_demo.q[1] - cube_demo.q[0]).max() < 1e-3  # quintic: starts at rest


def test_warp_keeps_start_and_shape_and_ends_at_goals():
    demo = np.linspace(0, 1, 50)[:, None] * np.array([1.0, -2.0]) + np.sin(np.linspace(0, np.pi, 50))[
        :, None
    ] * np.array([0.0, 0.3])
    goals = np.array([[1.5, -2.0], [0.5, -1.0]])
    paths = warp_to_goals(demo, goals, [3, 5])
    assert paths[:, 0] == pytest.approx(np.repeat(demo[:1], 2, axis=0))
    assert paths[:, -1] == pytest.approx(goals)
    # the bend is a rest-to-rest polynomial blend: zero offset slope at both ends
    offset = paths - demo
    assert (
        np.abs(offset[:, 1] - offset[:, 0]).max() < 0.01
        and np.abs(offset[:, -1] - offset[:, -2]).max() < 0.01
    )
    with pytest.raises(ValueError, match="order must be 3 or 5"):
        warp_to_goals(demo, goals, [3, 4])


def test_follow_paths_exponential_progress():
    path = np.linspace(0.0, 1.0, 101)[None, :, None] * np.array([3.0, -4.0])  # length 5
    t, q, qd = follow_paths(path, time_constant=2.0, dt=0.01, n_steps=600)
    remaining = np.linalg.norm(q[0] - path[0, -1], axis=1)
    assert remaining == pytest.approx(5.0 * np.exp(-t / 2.0), abs=1e-9)
    assert qd[0, 0] == pytest.approx(np.array([3.0, -4.0]) / 2.0)  # full speed at the start
    central = (q[0, 2:] - q[0, :-2]) / 0.02
    assert central == pytest.approx(qd[0, 1:-1], rel=1e-3, abs=1e-6)
    with pytest.raises(ValueError, match="zero length"):
        follow_paths(np.zeros((1, 5, 2)), 1.0, 0.1, 10)


def test_inverse_data_pairs_are_fk_errors_and_velocities(robot, cube_demo):
    config = InverseDataConfig(n_goals=6, n_seeds=4, dt=0.2, n_steps=40, cross_paths=1)  # 5.3 time constants
    data = build_inverse_data(robot, cube_demo, config)
    n_goals = 1 + 6 - data.n_failed
    assert data.q.shape == (2 * n_goals, 40, 7) and data.errors.shape == (2 * n_goals, 40, 3)
    assert data.errors == pytest.approx(robot.fk_positions(data.q).numpy() - data.goals[:, None], abs=1e-12)
    assert data.goals[0] == pytest.approx(np.array(DEMO_GOAL), abs=1e-3)
    # warped paths start at the start pose, cross paths at another goal; all end near their goal
    assert data.q[:n_goals, 0] == pytest.approx(np.repeat(cube_demo.q[:1], n_goals, axis=0))
    assert np.linalg.norm(data.errors[:, -1], axis=-1).max() < 0.02
    assert np.linalg.norm(data.errors[n_goals:, 0], axis=-1).min() > 1e-3
    assert np.all(np.linalg.norm(data.goals - DEMO_GOAL, axis=1) < np.linalg.norm([0.25, 0.15, 0.05]) + 1e-3)


def test_inverse_data_config_names_bad_fields():
    with pytest.raises(ValueError, match="orders"):
        InverseDataConfig(orders=(3, 4))
    with pytest.raises(ValueError, match="time_constant"):
        InverseDataConfig(time_constant=0.0)
    with pytest.raises(ValueError, match=r"unknown field\(s\) \['n_goal'\]"):
        InverseDataConfig.from_mapping({"n_goal": 3})
    assert InverseDataConfig.from_mapping({"goal_spread": [0.1, 0.1, 0.0]}).goal_spread == (0.1, 0.1, 0.0)
