"""The Meta-World evaluator: its settings refused in one line, checkpoints chosen by task, episodes
that give the same rows in one process or spread over two, success and its statistics, GIFs.

Policies are not trained here: a tiny random CNN -> DMP checkpoint (saved as ``train.py`` would,
with its recorded training run) for the process pool, and a fixed-point policy (a test loader) that
drives the hand to a given point for the success statistics.
"""

from __future__ import annotations

import csv
import functools
import json
import os
import time
from pathlib import Path
from types import SimpleNamespace

import lightning as L
import numpy as np
import pytest
import torch

pytest.importorskip("metaworld", reason="the [metaworld] extra is not installed")

from lfd.metaworld.env import MetaWorldTask, placement_seed
from lfd.visuomotor.eval.metrics import wilson_interval
from lfd.visuomotor.metaworld.evaluator import EPISODE_COLUMNS, MetaWorldEvaluator
from lfd.visuomotor.policies import CNNDMPPolicy
from lfd.visuomotor.policies.base import TRAINING_RUN_KEY

TASK = "reach-v3"
DT = 0.0125
#: The data config the tiny policy is built for (duck-typed as MetaWorldDataConfig).
CONFIG = SimpleNamespace(
    task=TASK,
    seed=3,
    image_size=32,
    camera="corner",
    n_steps=21,
    duration=20 * DT,
    control_dt=DT,
    robot=None,
    depth=False,
)
DATAMODULE = SimpleNamespace(config=CONFIG)


def _run(task: str = TASK) -> dict:
    return {"experiment": None, "data_config": "metaworld", "seed": 3, "data": {"task": task, "seed": 3}}


def _stub_checkpoint(path: Path, kind: str = "cnn_dmp", task: str | None = TASK, n_joints: int = 4) -> Path:
    """A checkpoint file with hyper-parameters and a recorded run (``task=None``: no run), no weights."""
    content = {"state_dict": {}, "hyper_parameters": {"kind": kind, "n_joints": n_joints}}
    if task is not None:
        content[TRAINING_RUN_KEY] = _run(task)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(content, path)
    return path


def _tiny_cnn_dmp(path: Path) -> Path:
    """A random CNN -> DMP checkpoint for the 4-D Meta-World state, saved as Lightning does."""
    torch.manual_seed(0)
    policy = CNNDMPPolicy(
        channels=[4, 4],
        hidden=[8],
        bias_dim=2,
        n_basis=4,
        rest_steps=0,
        n_joints=4,
        image_size=CONFIG.image_size,
        n_steps=CONFIG.n_steps,
        duration=CONFIG.duration,
        robot=None,
    )
    with torch.no_grad():  # plans towards a point in front of the robot, not the world origin
        policy.goal_mean.copy_(torch.tensor([0.0, 0.7, 0.15, -1.0]))
        policy.goal_std.fill_(0.05)
    content = {
        "state_dict": policy.state_dict(),
        "hyper_parameters": dict(policy.hparams),
        "pytorch-lightning_version": L.__version__,
        TRAINING_RUN_KEY: _run(),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save(content, path)
    return path


class FixedPointController:
    """Commands a fixed target ``(4,)`` every step, by position or by velocity."""

    input_channels = 3
    depth_encoding = "range"
    needs_image = False

    def __init__(self, point, dt: float, actuation: str) -> None:
        self.point, self.dt, self.actuation = np.asarray(point, dtype=np.float64), dt, actuation

    def start(self, steps: int | None = None) -> None:
        pass

    def command(self, obs, step: int, latencies: list[float]):
        latencies.append(0.25)
        qd = (self.point - obs.joints) / self.dt
        return (
            (self.point.copy(), np.zeros(4))
            if self.actuation == "position"
            else (obs.joints + qd * self.dt, qd)
        )


class FixedPointPolicy:
    """A stand-in policy: its controller drives the hand to ``point``."""

    kind = "cnn_dmp"
    item_mode = "dmp"

    def __init__(self, point, actuation: str = "position") -> None:
        self.point, self.actuation = point, actuation
        self.replan = []

    def controller(self, dt: float) -> FixedPointController:
        return FixedPointController(self.point, dt, self.actuation)


class ReplanningPolicy(FixedPointPolicy):
    """A stand-in policy whose controller takes ``replan_every``."""

    def controller(self, dt: float, replan_every: int | None = None) -> FixedPointController:
        self.replan.append(replan_every)
        return FixedPointController(self.point, dt, self.actuation)


def fixed_point_loader(path: Path, point, actuation: str = "position", cls=FixedPointPolicy):
    return cls(point, actuation)


@functools.cache
def _goals(seed: int, n: int) -> list[np.ndarray]:
    """The reach goals of the first ``n`` test placements."""
    with MetaWorldTask(TASK, image_size=16) as task:
        out = []
        for i in range(n):
            task.reset(placement_seed(seed, "test", i))
            out.append(task.placement[3:6].copy())
    return out


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# ---------------------------------------------------------------------------- settings
@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"split": "train"}, "eval.split must be one of test, val, got 'train'"),
        ({"n_episodes": 0}, "eval.n_episodes must be an integer >= 1, got 0"),
        ({"horizon": 2.5}, "eval.horizon must be an integer >= 1"),
        ({"workers": 0}, "eval.workers must be an integer >= 1"),
        ({"n_gifs": -1}, "eval.n_gifs must be an integer >= 0"),
        ({"gif_every": 0}, "eval.gif_every must be an integer >= 1"),
        ({"torch_threads": True}, "eval.torch_threads must be an integer >= 1"),
        ({"dmp_replan_every": 0}, "eval.dmp_replan_every must be an integer >= 1 \\(or None\\)"),
        ({"dmp_replan_weights": 1}, "eval.dmp_replan_weights must be true or false"),
        ({"dmp_replan_weights": True}, "eval.dmp_replan_weights=true needs eval.dmp_replan_every"),
        ({"kinds": ["nope"]}, "eval.kinds must be a subset of .*got unknown nope"),
        ({"kinds": []}, "eval.kinds must be a non-empty list"),
        ({"kinds": "cnn_dmp"}, "eval.kinds must be a list of policy kinds"),
        ({"colour_tta": "cnn_dmp"}, "eval.colour_tta must be a list of policy kinds"),
        ({"chunk_execution": {"cnn_dmp": {"replan_every": 2}}}, "eval.chunk_execution must map a chunking"),
        ({"chunk_execution": {"act": {"every": 2}}}, "eval.chunk_execution must map a chunking"),
        ({"task": "reach-v9"}, "eval.task: expected a Meta-World task name"),
    ],
)
def test_bad_settings_are_refused_in_one_line(fields, message):
    with pytest.raises(ValueError, match=message) as info:
        MetaWorldEvaluator(**fields)
    assert "\n" not in str(info.value)


def test_defaults():
    s = MetaWorldEvaluator().settings
    assert (s.task, s.split, s.n_episodes, s.horizon, s.workers, s.kinds) == (None, "test", 50, 200, 1, None)
    assert (s.colour_tta, s.chunk_execution, s.n_gifs, s.gif_every, s.torch_threads) == ((), {}, 2, 2, 1)
    assert s.dmp_replan_every is None and MetaWorldEvaluator.needs_datamodule
    s = MetaWorldEvaluator(
        kinds=["velocity", "cnn_dmp"], chunk_execution={"act": {"replan_every": 5}}
    ).settings
    assert s.kinds == ("velocity", "cnn_dmp") and s.chunk_execution == {"act": {"replan_every": 5}}


# ---------------------------------------------------------------------------- checkpoints
def test_resolve_checkpoints_takes_the_newest_of_this_task(tmp_path):
    root = tmp_path / "outputs"
    reach = _stub_checkpoint(root / "train" / "a" / "checkpoints" / "last.ckpt", task=TASK)
    push = _stub_checkpoint(root / "train" / "b" / "checkpoints" / "last.ckpt", task="push-v3")
    untold = _stub_checkpoint(root / "train" / "c" / "checkpoints" / "last.ckpt", task=None)
    for age, path in enumerate((untold, push, reach)):  # reach the oldest, the unrecorded one the newest
        os.utime(path, (time.time() - 10 * age, time.time() - 10 * age))
    assert MetaWorldEvaluator(task=TASK).resolve_checkpoints(root) == {"cnn_dmp": reach}
    assert MetaWorldEvaluator(task="push-v3").resolve_checkpoints(root) == {"cnn_dmp": push}
    assert MetaWorldEvaluator().resolve_checkpoints(root) == {"cnn_dmp": untold}  # any task
    with pytest.raises(FileNotFoundError, match="no 'cnn_dmp' checkpoint trained on window-open-v3"):
        MetaWorldEvaluator(task="window-open-v3").resolve_checkpoints(root)
    with pytest.warns(RuntimeWarning, match="no 'velocity' checkpoint trained on reach-v3"):
        found = MetaWorldEvaluator(task=TASK, kinds=["cnn_dmp", "velocity"]).resolve_checkpoints(root)
    assert found == {"cnn_dmp": reach}


def test_resolve_checkpoints_takes_given_files_of_this_task_only(tmp_path):
    push = _stub_checkpoint(tmp_path / "push.ckpt", task="push-v3")
    velocity = _stub_checkpoint(tmp_path / "v.ckpt", kind="velocity")
    evaluator = MetaWorldEvaluator(task=TASK)
    with pytest.raises(
        ValueError, match=r"ckpt=.*push.ckpt: trained on task 'push-v3', but eval.task='reach-v3'"
    ):
        evaluator.resolve_checkpoints(tmp_path / "none", [push])
    assert evaluator.resolve_checkpoints(tmp_path / "none", str(velocity)) == {"velocity": velocity}
    with pytest.raises(ValueError, match="a 'velocity' checkpoint, but eval.kinds"):
        MetaWorldEvaluator(kinds=["cnn_dmp"]).resolve_checkpoints(tmp_path, [velocity])
    with pytest.raises(FileNotFoundError, match="no such checkpoint file"):
        evaluator.resolve_checkpoints(tmp_path, [tmp_path / "missing.ckpt"])


@pytest.mark.parametrize(
    ("stub", "message"),
    [
        ({"task": "push-v3"}, "was trained on task 'push-v3', the data config is of task 'reach-v3'"),
        ({"n_joints": 7}, "n_joints=7; a Meta-World policy's state has 4 entries"),
        ({"kind": "velocity"}, "it holds a 'velocity' policy"),
    ],
)
def test_run_refuses_a_checkpoint_of_another_task_or_state(tmp_path, stub, message):
    ckpt = _stub_checkpoint(tmp_path / "x.ckpt", **stub)
    loader = functools.partial(fixed_point_loader, point=(0.0, 0.6, 0.2, -1.0))
    evaluator = MetaWorldEvaluator(n_episodes=1, horizon=2, policy_loader=loader)
    with pytest.raises(ValueError, match=message) as info:
        evaluator.run(DATAMODULE, {"cnn_dmp": ckpt}, tmp_path / "out")
    assert "\n" not in str(info.value)
    assert not (tmp_path / "out" / "metrics.json").exists()


def test_run_refuses_another_task_and_a_horizon_past_the_task(tmp_path):
    ckpt = _stub_checkpoint(tmp_path / "x.ckpt")
    loader = functools.partial(fixed_point_loader, point=(0.0, 0.6, 0.2, -1.0))
    with pytest.raises(ValueError, match="eval.task='push-v3', but the data config is of task 'reach-v3'"):
        MetaWorldEvaluator(task="push-v3", policy_loader=loader).run(DATAMODULE, {"cnn_dmp": ckpt}, tmp_path)
    with pytest.raises(
        ValueError, match="eval.horizon must be at most reach-v3's max_path_length 500, got 501"
    ):
        MetaWorldEvaluator(horizon=501, policy_loader=loader).run(DATAMODULE, {"cnn_dmp": ckpt}, tmp_path)


def test_dmp_replan_every_reaches_the_controller_or_is_refused(tmp_path):
    ckpt = _stub_checkpoint(tmp_path / "x.ckpt")
    plain = functools.partial(fixed_point_loader, point=(0.0, 0.6, 0.2, -1.0))
    with pytest.raises(ValueError, match="eval.dmp_replan_every=5: the cnn_dmp policy's controller") as info:
        MetaWorldEvaluator(dmp_replan_every=5, n_episodes=1, horizon=2, policy_loader=plain).run(
            DATAMODULE, {"cnn_dmp": ckpt}, tmp_path / "out"
        )
    assert "\n" not in str(info.value)
    seen = []

    def loader(path):
        policy = ReplanningPolicy((0.0, 0.6, 0.2, -1.0))
        seen.append(policy)
        return policy

    metrics = MetaWorldEvaluator(
        dmp_replan_every=5, n_episodes=1, horizon=2, n_gifs=0, policy_loader=loader
    ).run(DATAMODULE, {"cnn_dmp": ckpt}, tmp_path / "out")
    assert seen and set(seen[0].replan) == {5} and metrics["cnn_dmp"]["dmp_replan_every"] == 5


# ---------------------------------------------------------------------------- episodes
@pytest.mark.parametrize("actuation", ["position", "velocity"])
def test_success_statistics_and_outputs(tmp_path, actuation):
    goals = _goals(CONFIG.seed, 2)
    assert np.linalg.norm(goals[0] - goals[1]) > 0.1  # only episode 0's goal is reached
    loader = functools.partial(fixed_point_loader, point=(*goals[0], -1.0), actuation=actuation)
    evaluator = MetaWorldEvaluator(
        task=TASK, n_episodes=2, horizon=100, n_gifs=1, gif_every=5, policy_loader=loader
    )
    ckpt = _stub_checkpoint(tmp_path / "x.ckpt")
    metrics = evaluator.run(DATAMODULE, {"cnn_dmp": ckpt}, tmp_path / "out")
    m = metrics["cnn_dmp"]
    assert json.loads((tmp_path / "out" / "metrics.json").read_text()) == metrics
    assert set(m) >= {
        "success_rate",
        "success_ci95",
        "episodes",
        "successes",
        "mean_time_to_success_s",
        "median_steps_to_success",
        "latency_ms",
        "checkpoint",
        "task",
        "split",
        "horizon",
    }
    assert (m["episodes"], m["successes"], m["success_rate"]) == (2, 1, 0.5)
    assert m["success_ci95"] == pytest.approx(list(wilson_interval(1, 2)))
    assert (m["task"], m["split"], m["horizon"], m["checkpoint"]) == (TASK, "test", 100, str(ckpt))
    assert m["latency_ms"] == pytest.approx(0.25)
    rows = _rows(tmp_path / "out" / "episodes.csv")
    assert [list(r) for r in rows] == [list(EPISODE_COLUMNS)] * 2
    first, second = rows
    steps = int(first["steps_to_success"])
    assert first["success"] == "True" and 1 < steps < 100 and m["median_steps_to_success"] == steps
    assert float(first["time_to_success_s"]) == pytest.approx(steps * DT) == m["mean_time_to_success_s"]
    assert second["success"] == "False" and second["steps_to_success"] == second["time_to_success_s"] == ""
    assert [int(r["reset_seed"]) for r in rows] == [placement_seed(CONFIG.seed, "test", i) for i in (0, 1)]
    placement = np.array(first["placement"].split(), dtype=float)
    assert placement.shape == (6,) and np.allclose(placement[3:], goals[0])
    gifs = sorted(p.name for p in (tmp_path / "out" / "rollouts").iterdir())
    assert gifs == ["cnn_dmp_ep0.gif"]


def test_no_success_gives_null_times(tmp_path):
    loader = functools.partial(fixed_point_loader, point=(0.3, 0.4, 0.3, 1.0))
    evaluator = MetaWorldEvaluator(n_episodes=1, horizon=3, n_gifs=0, split="val", policy_loader=loader)
    m = evaluator.run(DATAMODULE, {"cnn_dmp": _stub_checkpoint(tmp_path / "x.ckpt")}, tmp_path)["cnn_dmp"]
    assert (m["successes"], m["mean_time_to_success_s"], m["median_steps_to_success"]) == (0, None, None)
    assert m["split"] == "val" and m["success_ci95"][0] == 0.0
    assert int(_rows(tmp_path / "episodes.csv")[0]["reset_seed"]) == placement_seed(CONFIG.seed, "val", 0)
    assert not (tmp_path / "rollouts").exists()


def test_one_and_two_workers_give_identical_episodes(tmp_path):
    """The required check: a real (tiny) CNN -> DMP checkpoint on two episodes, here and in two
    spawned processes, gives the same episodes.csv rows (but the measured latencies) and the same
    rollouts (their GIFs, byte for byte)."""
    ckpt = _tiny_cnn_dmp(tmp_path / "train" / "run" / "checkpoints" / "last.ckpt")
    rows, gifs = {}, {}
    for workers in (1, 2):
        evaluator = MetaWorldEvaluator(
            task=TASK, n_episodes=2, horizon=25, workers=workers, n_gifs=2, gif_every=6
        )
        assert evaluator.resolve_checkpoints(tmp_path) == {"cnn_dmp": ckpt}
        metrics = evaluator.run(DATAMODULE, {"cnn_dmp": ckpt}, tmp_path / f"w{workers}")
        assert metrics["cnn_dmp"]["episodes"] == 2 and metrics["cnn_dmp"]["latency_ms"] > 0
        rows[workers] = _rows(tmp_path / f"w{workers}" / "episodes.csv")
        for row in rows[workers]:
            assert float(row.pop("latency_ms")) > 0
        gifs[workers] = [
            (tmp_path / f"w{workers}" / "rollouts" / f"cnn_dmp_ep{i}.gif").read_bytes() for i in (0, 1)
        ]
    assert rows[1] == rows[2] and [r["episode"] for r in rows[1]] == ["0", "1"]
    assert rows[1][0]["placement"] != rows[1][1]["placement"]
    assert gifs[1] == gifs[2] and gifs[1][0] != gifs[1][1]
