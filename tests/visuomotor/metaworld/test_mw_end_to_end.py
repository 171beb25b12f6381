"""Meta-World end to end through the entry points, tiny: ``train.py experiment=metaworld task=reach-v3
model=cnn_dmp`` generates the demonstrations, trains and saves a checkpoint; ``evaluate.py
experiment=metaworld task=reach-v3 ckpt=...`` follows the checkpoint's data settings and writes
metrics.json, episodes.csv and a rollout GIF, its episodes spread over two spawned workers."""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
import torch
from PIL import Image

import evaluate  # the repository's entry points (pytest's pythonpath holds the root)
import train
from lfd.metaworld.env import placement_seed
from lfd.visuomotor.metaworld.evaluator import EPISODE_COLUMNS
from lfd.visuomotor.policies.base import TRAINING_RUN_KEY

#: ``train.py``'s tiny overrides: 3 + 1 reach-v3 demonstrations of 80 steps at 32 px, a tiny network,
#: 5 optimiser steps with one validation at the end (the checkpoint callback saves last.ckpt then).
TINY_TRAIN = (
    "experiment=metaworld",
    "task=reach-v3",
    "model=cnn_dmp",
    "data.n_train=3",
    "data.n_val=1",
    "data.image_size=32",
    "data.n_steps=80",
    "data.progress=false",
    "model.channels=[4,4,8]",
    "model.hidden=[16,16]",
    "trainer.max_steps=5",
    "trainer.val_check_interval=5",
)
#: ``evaluate.py``'s: no data key, so the data settings are the checkpoint's.
TINY_EVAL = (
    "experiment=metaworld",
    "task=reach-v3",
    "eval.n_episodes=2",
    "eval.horizon=60",
    "eval.n_gifs=1",
    "eval.workers=2",
)


def _script(name: str):
    """A script of ``scripts/`` as a module."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        name, Path(__file__).resolve().parents[3] / "scripts" / f"{name}.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_train_then_evaluate_through_the_entry_points(compose, tmp_path, capsys):
    from hydra import initialize_config_dir

    run = tmp_path / "outputs" / "train" / "reach"
    cfg = compose("train", *TINY_TRAIN, f"paths.root_dir={tmp_path}", f"paths.output_dir={run}")
    ckpt = Path(train.main(cfg))
    assert ckpt == run / "checkpoints" / "last.ckpt" and ckpt.is_file()
    saved = torch.load(ckpt, map_location="cpu", weights_only=False)
    assert saved["global_step"] == 5 and saved["hyper_parameters"]["kind"] == "cnn_dmp"
    hp = saved["hyper_parameters"]
    assert (hp["n_joints"], hp["robot"], hp["image_size"], hp["n_steps"], hp["loss"]) == (
        4,
        None,
        32,
        80,
        "params",
    )
    recorded = saved[TRAINING_RUN_KEY]
    assert recorded["experiment"] == "metaworld" and recorded["data"]["task"] == "reach-v3"
    data = tmp_path / "data" / recorded["data"]["name"]
    assert (data / "manifest.json").is_file() and len(list((data / "episodes").glob("*.npz"))) == 4
    assert json.loads((run / "timing.json").read_text())["global_step"] == 5
    capsys.readouterr()

    # scripts/metaworld_plan_error.py on the same checkpoint and dataset: errors along the plan per split;
    # the demonstrations' own fitted DMPs are the floor (millimetres), a 5-step policy is far from them;
    # the default policy goes through the placement, so the map's plan from the true placement is a row too
    plan_error = _script("metaworld_plan_error")
    assert plan_error.main([str(ckpt), str(data), "--every", "20"]) == 0
    rows = {tuple(line.split()[:2]): line.split()[2:] for line in capsys.readouterr().out.splitlines()[1:]}
    assert set(rows) == {(split, row) for split in ("train", "val") for row in ("plan", "map", "fitted")}
    assert all(len(v) == 4 for v in rows.values())  # steps 0, 20, 40, 60 of 80
    assert max(float(v) for v in rows[("train", "fitted")]) < 1.0  # cm
    assert max(float(v) for v in rows[("train", "plan")]) > max(float(v) for v in rows[("train", "fitted")])
    # --rollouts: the plan from the image and the one from the true placement, closed loop on validation placements
    assert plan_error.main([str(ckpt), str(data), "--rollouts", "2", "--horizon", "20"]) == 0
    last = capsys.readouterr().out.splitlines()[-1]
    assert re.fullmatch(
        r"reach-v3: closed-loop successes on 2 validation placements \(planned once\): "
        r"image [0-2] / 2, true placement [0-2] / 2, true pixels [0-2] / 2",
        last,
    )
    assert plan_error.main([str(tmp_path / "absent.ckpt"), str(data)]) == 2
    assert "metaworld_plan_error:" in capsys.readouterr().err

    out = tmp_path / "evaluation"
    cfg = compose(
        "evaluate", *TINY_EVAL, f"ckpt={ckpt}", f"paths.root_dir={tmp_path}", f"paths.output_dir={out}"
    )
    assert cfg.data.image_size == 96  # the config's: the checkpoint's (32 px) replace it in evaluate.main
    # evaluate.main re-composes with the checkpoint's data config: Hydra initialised, as in the app
    with initialize_config_dir(config_dir=str(evaluate.CONFIGS), version_base="1.3"):
        assert evaluate.main(cfg) == str(out)
    assert f"[lfd] evaluation written to: {out}" in capsys.readouterr().out

    metrics = json.loads((out / "metrics.json").read_text())
    assert set(metrics) == {"cnn_dmp"}
    m = metrics["cnn_dmp"]
    assert m["episodes"] == 2 and 0 <= m["successes"] <= 2
    assert 0.0 <= m["success_rate"] <= 1.0 and m["success_rate"] == m["successes"] / 2
    low, high = m["success_ci95"]
    assert 0.0 <= low <= m["success_rate"] <= high <= 1.0
    assert (m["task"], m["split"], m["horizon"], m["checkpoint"]) == ("reach-v3", "test", 60, str(ckpt))
    assert m["latency_ms"] > 0

    with open(out / "episodes.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [tuple(r) for r in rows] == [EPISODE_COLUMNS] * 2
    assert [(r["kind"], r["episode"]) for r in rows] == [("cnn_dmp", "0"), ("cnn_dmp", "1")]
    # the test stream of the checkpoint's seed (data.seed = seed = 42), followed from the checkpoint
    assert [int(r["reset_seed"]) for r in rows] == [placement_seed(42, "test", i) for i in (0, 1)]
    for r in rows:
        assert r["success"] in ("True", "False") and float(r["latency_ms"]) > 0
        steps = r["steps_to_success"]
        assert (r["success"] == "True") == (steps != "") and (steps == "" or 1 <= int(steps) <= 60)
        assert len(r["placement"].split()) == 6

    gifs = sorted((out / "rollouts").iterdir())
    assert [p.name for p in gifs] == ["cnn_dmp_ep0.gif"]
    with Image.open(gifs[0]) as gif:
        assert gif.format == "GIF" and gif.n_frames > 1


def test_pixel_regression_fixes_points_on_the_table_and_leaves_a_goal_in_the_air_open():
    """``metaworld_plan_error.pixel_regression``: from 40 training placements, a puck on the table is
    recovered from its pixel within millimetres on new placements (a plane seen by a pinhole: one
    position per pixel); a goal anywhere in a 3-D box is not (its depth along the line of sight)."""
    from types import SimpleNamespace

    from lfd.visuomotor.metaworld.datamodule import placement_pixels
    from lfd.visuomotor.metaworld.demos import MetaWorldDataConfig

    config = MetaWorldDataConfig(task="reach-v3", image_size=96, camera_fovy=25)
    rng = np.random.default_rng(0)

    def episodes(n: int) -> list:
        puck = np.c_[rng.uniform(-0.1, 0.1, n), rng.uniform(0.6, 0.7, n), np.full(n, 0.02)]
        goal = np.c_[rng.uniform(-0.1, 0.1, n), rng.uniform(0.8, 0.9, n), rng.uniform(0.05, 0.3, n)]
        return [
            SimpleNamespace(index=i, arrays={"placement": np.r_[a, b]})
            for i, (a, b) in enumerate(zip(puck, goal))
        ]

    estimate = _script("metaworld_plan_error").pixel_regression(config, episodes(40))
    new = episodes(20)
    pixels = placement_pixels(config, new)
    errors = np.array(
        [estimate(e.arrays["placement"], p) - e.arrays["placement"] for e, p in zip(new, pixels)]
    )
    puck, goal = np.linalg.norm(errors[:, :3], axis=1), np.linalg.norm(errors[:, 3:], axis=1)
    assert puck.max() < 0.003, puck.max()
    assert np.median(goal) > 0.01, np.median(goal)
