"""eval_info.json in LeRobot's schema (lerobot_eval.py) and the rollout videos."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from lfd.interop.lerobot.report import episode_rewards, side_by_side, write_lerobot_eval
from lfd.robots import load_robot
from lfd.sim.approach import plan_approach
from lfd.sim.objects import ObjectSpec, Placement
from lfd.visuomotor.data import GeneratorConfig
from lfd.visuomotor.eval.evaluator import Case
from lfd.visuomotor.eval.rollout import EpisodeTrace

PER_EPISODE = {"episode_ix", "sum_reward", "max_reward", "success", "seed"}
AGGREGATED = {"avg_sum_reward", "avg_max_reward", "pc_success", "eval_s", "eval_ep_s"}


def test_rewards():
    path = np.array([[1.0, 0, 0], [0.5, 0, 0], [0.0, 0, 0], [2.0, 0, 0]])
    np.testing.assert_allclose(episode_rewards(path, np.zeros(3)), [0.5, 1.0, 0.0])
    with pytest.raises(ValueError, match="tool path"):
        episode_rewards(np.zeros((1, 3)), np.zeros(3))


def test_side_by_side():
    out = side_by_side(np.zeros((120, 160, 3), np.uint8), np.full((32, 32, 3), 200, np.uint8))
    assert out.shape == (120, 280, 3) and (out[:, 160:] == 200).sum() == 96 * 96 * 3


def _cases_and_traces():
    robot = load_robot("pr2_right_arm")
    objs = [
        ObjectSpec(
            shape="cylinder", dims=(0.03, 0.15), rgba=(0.9, 0.1, 0.1, 1), mass=0.2, name="test-00-cylinder"
        ),
        ObjectSpec(
            shape="box", dims=(0.05, 0.05, 0.05), rgba=(0.1, 0.2, 0.9, 1), mass=0.2, name="test-01-box"
        ),
    ]
    cases, traces, rows = [], {"cnn_dmp": [], "velocity": []}, []
    home = robot.home.numpy()
    import torch

    for i, (obj, p) in enumerate(
        [
            (objs[0], Placement(0.55, -0.1, 0.0)),
            (objs[0], Placement(0.6, 0.1, 0.3)),
            (objs[1], Placement(0.5, 0.0, 0.0)),
        ]
    ):
        plan = plan_approach(obj, p, table_z=-0.33)
        cases.append(Case(0 if obj is objs[0] else 1, i, obj, p, plan, None))
        joints = np.linspace(home, home + 0.2, 7)
        ee = robot.fk(torch.as_tensor(joints)).numpy()
        for method, shift in (("cnn_dmp", 0.0), ("velocity", 0.1)):
            ee2 = ee.copy()
            ee2[:, :3, 3] = np.linspace(ee[0, :3, 3], plan.target_point + shift, 7)
            traces[method].append(EpisodeTrace(joints, ee2, 0, [1.0]))
            d = float(np.linalg.norm(ee2[-1, :3, 3] - plan.target_point))
            rows.append({"method": method, "final_distance_m": d, "success_5cm": d < 0.05})
    return cases, traces, rows


def test_eval_info_schema_and_videos(tmp_path):
    import av

    cases, traces, rows = _cases_and_traces()
    gen = GeneratorConfig(image_size=32, n_steps=10)
    paths = write_lerobot_eval(
        tmp_path,
        rows,
        cases,
        traces,
        gen,
        seed=7,
        eval_s=12.0,
        n_videos=1,
        frame_every=2,
        video_size=(160, 120),
    )
    assert set(paths) == {"cnn_dmp", "velocity"}
    for method, path in paths.items():
        assert path == tmp_path / method / "eval_info.json"
        info = json.loads(path.read_text())
        assert set(info) == {"per_episode", "aggregated", "per_task", "per_group", "overall", "video_paths"}
        assert [set(e) for e in info["per_episode"]] == [PER_EPISODE] * 3
        assert [e["episode_ix"] for e in info["per_episode"]] == [0, 1, 2]
        assert all(e["seed"] == 7 and isinstance(e["success"], bool) for e in info["per_episode"])
        assert set(info["aggregated"]) == AGGREGATED
        succ = [r["success_5cm"] for r in rows if r["method"] == method]
        assert info["aggregated"]["pc_success"] == pytest.approx(100 * np.mean(succ))
        assert info["aggregated"]["eval_s"] == 12.0 and info["aggregated"]["eval_ep_s"] == pytest.approx(
            12.0 / 6
        )
        ep = info["per_episode"][0]
        if method == "cnn_dmp":  # the tool path ends on the target
            assert ep["max_reward"] == pytest.approx(1.0)
        else:  # ... 17 cm from it
            assert ep["max_reward"] < 1.0
        assert 0 <= ep["sum_reward"] <= 6
        assert [(t["task_group"], t["task_id"]) for t in info["per_task"]] == [("cylinder", 0), ("box", 1)]
        assert info["per_task"][0]["task"] == "reach the red cylinder from the side"
        assert info["per_task"][1]["task"] == "reach the blue box from above"
        assert set(info["per_task"][0]["metrics"]) == {
            "sum_rewards",
            "max_rewards",
            "successes",
            "video_paths",
        }
        assert info["per_group"]["cylinder"]["n_episodes"] == 2 and info["overall"]["n_episodes"] == 3
        assert {"avg_sum_reward", "avg_max_reward", "pc_success", "n_episodes", "video_paths"} <= set(
            info["per_group"]["box"]
        )
        assert AGGREGATED | {"n_episodes", "video_paths"} == set(info["overall"])
        assert not math.isnan(info["overall"]["avg_sum_reward"])
        video = tmp_path / method / "videos" / "eval_episode_0.mp4"
        assert (
            info["video_paths"] == [str(video)]
            and not (tmp_path / method / "videos" / "eval_episode_1.mp4").exists()
        )
        with av.open(str(video)) as c:
            frames = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
        assert len(frames) == 4 and frames[0].shape == (
            120,
            160 + 120,
            3,
        )  # 7 states, every 2nd; view + policy view
        assert frames[0][:, :160].std() > 5  # a rendered scene, not a blank frame


def test_eval_info_needs_matching_lengths(tmp_path):
    from lfd.interop.lerobot.report import eval_info

    cases, traces, rows = _cases_and_traces()
    with pytest.raises(ValueError, match="one row and trace per case"):
        eval_info(rows[:1], cases, traces["cnn_dmp"], seed=0, eval_s=1.0)
