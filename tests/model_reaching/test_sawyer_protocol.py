"""Sawyer protocol: reach test, PoWER refinement, arms, and the train -> evaluate commands."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from lfd.model_reaching import load_sawyer_models
from lfd.model_reaching.closed_loop import closed_loop_reach
from lfd.model_reaching.demonstrations import DEMO_GOAL, TASK_ORIENTATIONS_DEG, make_demonstration
from lfd.model_reaching.protocol import GOALS
from lfd.rl import refine
from lfd.robots import Workspace, load_robot, make_transform, solve_near
from lfd.sim.arms import KinematicArm, PyBulletArm

ROOT = Path(__file__).resolve().parents[2]
START = np.radians([0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0])
#: A small configuration of the experiment (the cube task only; about a minute of CPU time):
#: many small forward batches so that the inverse model gets enough steps.
SMALL_TRAIN = [
    "experiment=sawyer_models",
    "trainer.max_epochs=4",
    "trainer.enable_progress_bar=false",
    "~callbacks.progress_bar",
    "model.forward.width=128",
    "model.forward.n_blocks=2",
    "model.tasks=[cube]",
    "~data.inverse.tasks.cup",
    "data.forward.batch_size=256",
    "data.forward.batches_per_epoch=375",
    "data.forward.n_val=2000",
    "data.forward.n_test=2000",
    "data.inverse.config.n_goals=24",
    "data.inverse.batch_size=128",
]


@pytest.fixture(scope="module")
def robot():
    return load_robot("sawyer")


def run(script: str, *overrides: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {
        **os.environ,
        "PYTHONPATH": f"{ROOT / 'src'}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
        "OMP_NUM_THREADS": "1",
    }
    result = subprocess.run(
        [sys.executable, str(ROOT / script), *overrides],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    return result


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """``python train.py experiment=sawyer_models`` on a small configuration; its last checkpoint."""
    out = tmp_path_factory.mktemp("sawyer_runs")
    result = run(
        "train.py", *SMALL_TRAIN, f"paths.output_root={out}", f"hydra.run.dir={out}/train/small", cwd=out
    )
    assert "forward model error (mm)" in result.stdout
    ckpt = out / "train" / "small" / "checkpoints" / "last.ckpt"
    assert torch.load(ckpt, weights_only=True)["global_step"] == 4 * 375  # the final weights
    return ckpt


# ---------------------------------------------------------------------------- reach test
def test_goal_3_is_reported_unreachable(robot):
    workspace = Workspace(robot, n_samples=20_000, n_seeds=8)
    rotation = make_transform(GOALS[0], np.radians(TASK_ORIENTATIONS_DEG["cube"]))[:3, :3]
    far = workspace.test(GOALS[2], rotation)
    assert not far.reachable and not far.position_ik and not far.pose_ik
    assert far.shoulder_distance > far.max_reach > 1.0
    assert far.reason.startswith("unreachable")
    near = workspace.test(GOALS[0], rotation)
    assert near.reachable and near.pose_ik and near.reason == "reachable"


# ---------------------------------------------------------------------------- DMP + PoWER
def test_power_refines_a_nearby_trajectory_to_within_1_cm(robot):
    demo = make_demonstration(robot, TASK_ORIENTATIONS_DEG["cube"])
    goal = np.array(GOALS[0])
    solution = solve_near(
        robot,
        make_transform(goal + [0.03, 0.02, 0.0], np.radians(TASK_ORIENTATIONS_DEG["cube"]))[None],
        demo.q[-1],
    )
    assert solution.success[0]
    q_goal = solution.q.numpy()
    t = np.linspace(0.0, 4.0, 80)
    s = (t / 4.0)[:, None]
    trajectory = START + (10 * s**3 - 15 * s**4 + 6 * s**5) * (q_goal[0] - START)  # ends 3.6 cm from the goal
    result = refine(
        robot,
        t,
        trajectory,
        goal,
        n_rollouts=10,
        n_best=5,
        max_iter=150,
        sigma=0.02,
        sigma_goal=0.02,
        tol=0.01,
        seed=0,
    )
    final = robot.fk(torch.from_numpy(result.trajectory[-1:]))[0, :3, 3].numpy()
    assert result.history.error[0] > 0.03
    assert result.converged and np.linalg.norm(final - goal) <= 0.01
    assert 0 < result.iterations < 150


# ---------------------------------------------------------------------------- arms
def test_pybullet_arm_follows_the_kinematic_arm(robot):
    goals = np.array([DEMO_GOAL, GOALS[0]])

    def fk(q):
        return robot.fk(q.double())[:, :3, 3].float()

    def toward(errors):  # a fixed linear controller, the same for both arms
        return -errors @ torch.tensor(
            [
                [0.0, -1.0, 0.0, 0.5, 0.0, 0.2, 0.0],
                [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0],
            ]
        )

    kinematic = closed_loop_reach(
        fk, toward, robot, goals, START, KinematicArm(robot, 0.05), max_steps=40, threshold=1e-3
    )
    simulated = closed_loop_reach(
        fk, toward, robot, goals, START, PyBulletArm(robot, 0.05), max_steps=40, threshold=1e-3
    )
    for a, b in zip(kinematic, simulated):
        assert np.abs(a.q[-1] - a.q[0]).max() > 0.3  # the arm moved
        assert np.linalg.norm(a.x[-1] - b.x[-1]) < 0.01  # tracked within 1 cm over ~0.45 m


# ---------------------------------------------------------------------------- the commands
def test_experiment_config_composes(compose):
    cfg = compose("train", "experiment=sawyer_models", "+trainer.fast_dev_run=true")
    assert cfg.model._target_ == "lfd.model_reaching.SawyerModels"
    assert cfg.data._target_ == "lfd.model_reaching.data.SawyerModelsDataModule"
    assert list(cfg.model.tasks) == list(cfg.data.inverse.tasks) and cfg.test


@pytest.mark.slow
def test_fast_dev_run_smoke(tmp_path):
    run(
        "train.py",
        "experiment=sawyer_models",
        "+trainer.fast_dev_run=true",
        "data.inverse.config.n_goals=4",
        "data.forward.n_test=500",
        f"paths.output_root={tmp_path}",
        cwd=tmp_path,
    )


def test_pipeline_reaches_a_reachable_goal_within_1_cm(trained, robot):
    models = load_sawyer_models(trained)  # the checkpoint alone
    goal = np.array(GOALS[0])
    trace = closed_loop_reach(
        models.forward_model,
        models.inverse_models["cube"],
        robot,
        goal[None],
        START,
        KinematicArm(robot, 0.05),
        300,
        0.02,
    )[0]
    assert trace.reached and trace.final_error(goal) < 0.1  # the models bring the arm near the goal
    result = refine(
        robot, trace.t, trace.q, goal, max_iter=300, sigma=0.02, sigma_goal=0.05, tol=0.01, seed=0
    )
    final = robot.fk(torch.from_numpy(result.trajectory[-1:]))[0, :3, 3].numpy()
    assert result.converged and np.linalg.norm(final - goal) <= 0.01


def test_evaluate_writes_the_protocol(trained, tmp_path):
    overrides = [
        "data=sawyer_models",
        "eval=sawyer",
        f"eval.checkpoint={trained}",
        "eval.tasks=[cube]",
        "eval.n_seeds=1",
        "eval.power.max_iter=30",
        "eval.n_fk_test=1000",
        "eval.pybullet_replay=false",
        f"hydra.run.dir={tmp_path}/evaluation",
    ]
    run("evaluate.py", *overrides, cwd=tmp_path)
    out = tmp_path / "evaluation"
    assert {p.name for p in out.iterdir()} >= {
        "protocol.md",
        "protocol.csv",
        "reach.csv",
        "metrics.json",
        "paths_cube.png",
        "power_cube.png",
    }
    metrics = json.loads((out / "metrics.json").read_text())
    goals = metrics["tasks"]["cube"]["goals"]
    assert goals[2]["reach_test"]["reachable"] is False and "power" not in goals[2]
    assert all("power" in g for i, g in enumerate(goals) if i != 2)
    assert set(metrics["forward_error_mm"]) == {"mean", "median", "p99", "max", "n"}
    rows = list(csv.DictReader((out / "protocol.csv").open()))
    assert {r["scenario"] for r in rows} == {"models", "demo", ""} and len(rows) == 4 * 2 + 1
    table = (out / "protocol.md").read_text()
    assert "| 3 | (1.110, -0.551, -0.040) | unreachable" in table and "| total |" in table
