"""End to end on a tiny generated dataset, with the real Hydra configs:

fast_dev_run of both policies through ``train.py``'s main; a short run that saves
checkpoints; the checkpoints load alone; closed-loop evaluation in PyBullet writes every
output with valid contents; the policy never receives the object pose; missing or
mismatched checkpoints give clear errors.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import hydra
import numpy as np
import pytest
import torch
from PIL import Image

import evaluate  # the repository's entry points (pytest's pythonpath holds the root)
import lfd.visuomotor.eval.evaluator as evaluator_module
import train
from lfd.visuomotor.eval import ReachEvaluator
from lfd.visuomotor.policies import POLICIES, KeypointPolicy, load_policy

TINY_MODEL = ["model.channels=[4,4,4,8]", "model.hidden=[16,16]", "model.plot_every_n_val=1"]


@pytest.fixture(scope="module")
def tiny(compose, workspace, tiny_data):
    """``compose`` rooted in this module's workspace, on the tiny dataset."""

    def _compose(name: str, *overrides: str):
        # the tiny checkpoints train without colour_augment: no colour averaging unless a test asks
        plain = ["eval.colour_tta=[]"] if name == "evaluate" else []
        return compose(name, f"paths.root_dir={workspace}", *tiny_data, *plain, *overrides)

    return _compose


def given(cfg) -> list:
    """The checkpoints named on the command line (``ckpt=...``), as ``evaluate.py`` passes them."""
    ckpt = cfg.get("ckpt")
    return [] if ckpt is None else [ckpt] if isinstance(ckpt, str) else list(ckpt)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("pipeline")


@pytest.mark.parametrize("model", sorted(POLICIES))
def test_fast_dev_run(tiny, model):
    """The composed config instantiates and fits one train + one val batch; both losses are finite."""
    keypoint = issubclass(POLICIES[model], KeypointPolicy)  # the chunking policies have no keypoint MLP
    shrink = [o for o in TINY_MODEL if keypoint or not o.startswith("model.hidden")]
    cfg = tiny("train", f"model={model}", "++trainer.fast_dev_run=true", *shrink)
    datamodule, policy = train.instantiate_data_and_model(cfg)  # the layout and settings the policy names
    assert datamodule.mode == POLICIES[model].item_mode and policy.hparams.image_size == cfg.data.image_size
    trainer = hydra.utils.instantiate(cfg.trainer, logger=False, enable_checkpointing=False)
    trainer.fit(policy, datamodule=datamodule)
    metrics = trainer.callback_metrics
    for key in ("train/loss", "val/loss"):
        assert torch.isfinite(metrics[key]), key
    assert type(policy) is POLICIES[model]
    torch.testing.assert_close(policy.joints_std, datamodule.stats["joints"]["std"])


@pytest.fixture(scope="module")
def checkpoints(tiny, workspace) -> dict[str, Path]:
    """Two optimiser steps of each policy, as ``train.py -m model=cnn_dmp,velocity`` would
    leave them under ``outputs/train/<run>/checkpoints/last.ckpt``."""
    out = {}
    # the chunking policies (act, diffusion): tests/visuomotor/policies/test_policy_chunk_train.py
    for model in ("cnn_dmp", "velocity"):
        run_dir = workspace / "outputs" / "train" / f"run-{model}"
        cfg = tiny(
            "train",
            f"model={model}",
            "++trainer.max_steps=2",
            "++trainer.limit_val_batches=1",
            f"paths.output_dir={run_dir}",
            *TINY_MODEL,
        )
        out[model] = Path(train.main(cfg))
        assert out[model] == run_dir / "checkpoints" / "last.ckpt" and out[model].is_file()
    return out


def test_checkpoint_runs_alone(checkpoints, workspace):
    from lfd.visuomotor.data.datasets import load_dataset

    stats = load_dataset(workspace / "data" / "tiny").stats
    frame = np.zeros((32, 32, 3), dtype=np.uint8)
    for kind, path in checkpoints.items():
        policy = load_policy(path)
        assert policy.kind == kind and type(policy) is POLICIES[kind] and not policy.training
        assert policy.hparams.image_size == 32 and policy.hparams.robot == "pr2_right_arm"
        torch.testing.assert_close(policy.joints_mean, stats["joints"]["mean"])
        out = policy.plan(frame, np.zeros(7)) if kind == "cnn_dmp" else policy.act(frame, np.zeros(7), 0.0)
        assert out.shape == ((30, 7) if kind == "cnn_dmp" else (7,)) and np.all(np.isfinite(out))
        again = POLICIES[kind].load_from_checkpoint(path, weights_only=True)
        torch.testing.assert_close(again.state_dict(), policy.state_dict())
    with pytest.raises(ValueError, match="holds 'velocity' policies"):
        POLICIES["velocity"].load_from_checkpoint(checkpoints["cnn_dmp"], weights_only=True)


class RecordingPolicy:
    """Wraps a policy and records every argument its closed-loop methods are called with."""

    def __init__(self, policy) -> None:
        self.policy, self.calls = policy, []

    def __getattr__(self, name):
        return getattr(self.policy, name)

    def _record(self, name, args, kwargs):
        self.calls.append((name, args, kwargs))

    def plan(self, *args, **kwargs):
        self._record("plan", args, kwargs)
        return self.policy.plan(*args, **kwargs)

    def act(self, *args, **kwargs):
        self._record("act", args, kwargs)
        return self.policy.act(*args, **kwargs)

    def controller(self, dt):
        """The wrapped policy's kind of controller, calling this wrapper."""
        return type(self.policy.controller(dt))(self, dt)


def test_closed_loop_evaluation_writes_every_output(checkpoints, tiny, workspace, monkeypatch):
    recorders = {}

    def recording_load(path):
        rec = RecordingPolicy(load_policy(path))
        recorders[rec.kind] = rec
        return rec

    monkeypatch.setattr(evaluator_module, "load_policy", recording_load)
    out_dir = workspace / "eval"
    cfg = tiny("evaluate", "eval.n_gifs=1", "eval.max_steps=12")
    metrics = evaluate.evaluate(cfg, out_dir)

    # metrics.json: both methods, every key, sane values
    saved = json.loads((out_dir / "metrics.json").read_text())
    assert saved == json.loads(json.dumps(metrics))
    assert set(saved) == {"cnn_dmp", "velocity"}
    for kind, m in saved.items():
        assert m["checkpoint"] == str(checkpoints[kind])
        assert m["episodes"] == 2
        assert (
            set(m["final_distance_m"]) == {"mean", "median", "p90", "ci"}
            and m["final_distance_m"]["mean"] > 0
        )  # ci: cluster bootstrap
        for key in ("success_5cm", "success_2cm", "approach_correct"):
            assert 0.0 <= m[key] <= 1.0
        for key in ("success_5cm_ci", "success_2cm_ci"):
            low, high = m[key]
            assert 0.0 <= low <= m[key.removesuffix("_ci")] <= high <= 1.0
        assert m["jerk_ratio"] > 0 and m["jerk_ratio_median"] > 0 and m["joint_limit_violations"] >= 0
        assert 0 < m["latency_ms"]["median"] <= m["latency_ms"]["p95"]

    # episodes.csv: one row per episode and method
    with open(out_dir / "episodes.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 4 and {r["method"] for r in rows} == {"cnn_dmp", "velocity"}
    for r in rows:
        assert float(r["final_distance_m"]) >= 0 and r["success_5cm"] in ("True", "False")
        # the object's distance and displacement, contacts, the ood mark
        assert float(r["object_distance_m"]) >= 0 and float(r["object_displacement_m"]) >= 0
        assert r["arm_table_contact"] in ("True", "False") and r["arm_object_contact"] in ("True", "False")
        assert r["ood"] == "False"  # the test split is drawn from the training ranges
        if r["approach_correct"] == "True":
            assert float(r["final_distance_m"]) < 0.05
    means = {k: np.mean([float(r["final_distance_m"]) for r in rows if r["method"] == k]) for k in saved}
    for k in saved:
        assert means[k] == pytest.approx(saved[k]["final_distance_m"]["mean"])

    # plots and GIFs
    objects = {r["object"] for r in rows}
    for name in objects:
        for prefix in ("distance", "paths3d"):
            with Image.open(out_dir / f"{prefix}_{name}.png") as im:
                assert im.size[0] > 200 and im.size[1] > 200
    gifs = sorted((out_dir / "rollouts").glob("*.gif"))
    assert {g.name.split("_")[0] for g in gifs} == {"cnn", "velocity"}
    for gif in gifs:
        with Image.open(gif) as im:
            assert im.format == "GIF" and im.size == (64, 64)

    # LeRobot's layout of the same episodes (configs/eval/reach.yaml's episode_reports)
    for kind in saved:
        assert (out_dir / kind / "eval_info.json").is_file()
        assert len(list((out_dir / kind / "videos").glob("eval_episode_*.mp4"))) == 1

    # the policies saw only camera frames, joint angles and (velocity) the clock
    assert [c[0] for c in recorders["cnn_dmp"].calls] == ["plan"] * 3  # warm-up + 2 episodes
    assert len(recorders["velocity"].calls) == 1 + 2 * 12
    for kind, rec in recorders.items():
        times = []
        for _, args, kwargs in rec.calls:
            # the DMP policy is asked for a plan covering the episode (start + 12 steps)
            assert kwargs == ({"n_steps": 13} if kind == "cnn_dmp" else {})
            assert len(args) == (2 if kind == "cnn_dmp" else 3)
            image, joints, *time = args
            assert isinstance(image, np.ndarray) and image.dtype == np.uint8 and image.shape == (32, 32, 3)
            assert isinstance(joints, np.ndarray) and joints.shape == (7,)
            times += time
        if kind == "velocity":  # warm-up at 0 s, then each episode's steps 0..11
            dt = 4.0 / 29
            np.testing.assert_allclose(times, [0.0] + 2 * [k * dt for k in range(12)])


def test_scenario_file_evaluation(checkpoints, tiny, workspace):
    """Every object x placement of a scenario, with the scripted expert's path as reference."""
    scenario = workspace / "scenario.yaml"
    scenario.write_text(
        "objects:\n"
        "  - {name: can, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1.0, 0.5, 0.0, 1.0]}\n"
        "  - {name: block, shape: box, size: [0.05, 0.07, 0.06], rgba: [0.5, 0.0, 0.5, 1.0]}\n"
        "placements:\n"
        "  - [0.55, 0.05, 0.3]\n"
    )
    cfg = tiny("evaluate", f"eval.scenario={scenario}", "eval.n_gifs=0", "eval.max_steps=6")
    out_dir = workspace / "eval-scenario"
    metrics = evaluate.evaluate(cfg, out_dir)
    assert {m["episodes"] for m in metrics.values()} == {2}
    assert all(m["cases"] == f"scenario {scenario}" for m in metrics.values())
    with open(out_dir / "episodes.csv") as f:
        rows = list(csv.DictReader(f))
    assert sorted((r["method"], r["object"], r["approach_mode"]) for r in rows) == [
        ("cnn_dmp", "block", "top"),
        ("cnn_dmp", "can", "side"),
        ("velocity", "block", "top"),
        ("velocity", "can", "side"),
    ]
    assert all(float(r["demo_jerk"]) > 0 for r in rows)  # the expert demonstrated both cases
    assert (out_dir / "distance_can.png").is_file() and (out_dir / "paths3d_block.png").is_file()
    assert not (out_dir / "rollouts").exists()


#: Per scene setting of the evaluation: the ReachScene setter, the random value, its stream key.
SCENE_SETTINGS = {
    "lighting": ("set_lighting", "random", evaluator_module.EVAL_LIGHTING_STREAM),
    "camera_pose": ("set_camera", "jitter", evaluator_module.EVAL_CAMERA_STREAM),
    "table_texture": ("set_table_texture", "random", evaluator_module.EVAL_TEXTURE_STREAM),
    "clutter": ("set_clutter", 3, evaluator_module.EVAL_CLUTTER_STREAM),
}


@pytest.mark.parametrize("setting", sorted(SCENE_SETTINGS))
def test_random_scene_settings_give_each_case_its_own_keyed_draw_the_same_for_every_kind(
    setting, checkpoints, tiny, workspace, monkeypatch
):
    """``eval.lighting=random`` / ``eval.camera_pose=jitter`` / ``eval.table_texture=random`` /
    ``eval.clutter=3``: case ``i`` under its own keyed light / through its own keyed camera / on its own
    keyed table / among its own keyed flat items, the same for every kind; ``dataset`` on a scenario: the
    default light / camera / plain, clear table. metrics.json records the setting; a bad value is refused
    in one line."""
    from lfd.sim.camera import Camera, jitter_camera, sample_lighting
    from lfd.sim.clutter import sample_clutter
    from lfd.sim.objects import ObjectSpec, Placement
    from lfd.sim.scene import ReachScene
    from lfd.sim.textures import sample_table_texture

    setter, random_value, stream = SCENE_SETTINGS[setting]
    scenario = workspace / f"scenario-{setting}.yaml"
    scenario.write_text(
        "objects:\n"
        "  - {name: can, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1.0, 0.5, 0.0, 1.0]}\n"
        "placements:\n"
        "  - [0.55, 0.05, 0.3]\n"
        "  - [0.60, -0.10, 0.0]\n"
    )
    seen = []
    original = getattr(ReachScene, setter)
    monkeypatch.setattr(ReachScene, setter, lambda self, value: (seen.append(value), original(self, value)))
    for value in (random_value, "dataset"):
        seen.clear()
        cfg = tiny(
            "evaluate",
            f"eval.scenario={scenario}",
            "eval.n_gifs=0",
            "eval.max_steps=4",
            f"eval.{setting}={value}",
        )
        metrics = evaluate.evaluate(cfg, workspace / f"eval-{setting}-{value}")
        assert {m[setting] for m in metrics.values()} == {value}
        per_kind = [seen[i : i + 3] for i in range(0, len(seen), 3)]  # warm-up, then the 2 cases
        assert len(per_kind) == len(metrics) == 2 and per_kind[0] == per_kind[1]
        size = cfg.data.image_size
        if value == "dataset":
            default = {"camera_pose": Camera(width=size, height=size), "clutter": ()}.get(setting)
            assert per_kind[0] == [default] * 3
            continue
        rngs = [np.random.default_rng([stream, i]) for i in (0, 0, 1)]
        if setting == "camera_pose":
            expected = [jitter_camera(Camera(width=size, height=size), rng) for rng in rngs]
        elif setting == "clutter":
            can = ObjectSpec("cylinder", (0.035, 0.14), (1.0, 0.5, 0.0, 1.0), 0.3)
            places = [Placement(0.55, 0.05, 0.3), Placement(0.55, 0.05, 0.3), Placement(0.60, -0.10, 0.0)]
            expected = [sample_clutter(rng, 3, can, pl) for rng, pl in zip(rngs, places)]
            assert all(len(items) == 3 for items in expected)
        else:
            draw = sample_lighting if setting == "lighting" else sample_table_texture
            expected = [draw(rng) for rng in rngs]
        assert per_kind[0] == expected and expected[0] != expected[2]
    with pytest.raises(ValueError, match=f"eval.{setting}: expected (one of|'dataset' or an int)"):
        evaluator_module.ReachEvalSettings(**{setting: "wobbly"})


def test_evaluator_interface_cannot_pass_the_object_pose():
    """The controllers only ever get an Observation: an image, joints and the clock."""
    from dataclasses import fields

    from lfd.visuomotor.protocols import Observation

    assert [f.name for f in fields(Observation)] == ["image", "joints", "time"]


def test_missing_checkpoint_says_which_and_how(tiny, tmp_path):
    cfg = tiny("evaluate", f"paths.output_root={tmp_path}")
    with pytest.raises(FileNotFoundError) as info:
        ReachEvaluator().resolve_checkpoints(cfg.paths.output_root, given(cfg))
    msg = str(info.value)
    assert "no 'cnn_dmp' checkpoint" in msg and "python train.py model=cnn_dmp" in msg and "ckpt=PATH" in msg
    assert "no 'velocity' checkpoint" in msg and "python train.py model=velocity" in msg
    cfg = tiny("evaluate", f"ckpt={tmp_path / 'nope.ckpt'}")
    with pytest.raises(FileNotFoundError, match="ckpt=.*nope.ckpt"):
        ReachEvaluator().resolve_checkpoints(cfg.paths.output_root, given(cfg))
    with pytest.raises(ValueError, match=r"eval.kinds: unknown \['cnn'\]"):
        ReachEvaluator(kinds=["cnn"])


def test_newest_checkpoint_of_each_kind_is_found(checkpoints, tiny, capsys):
    """`python evaluate.py` scores every kind by default; the kinds without a checkpoint (here
    ACT and Diffusion Policy) are skipped with one line saying how to train them."""
    cfg = tiny("evaluate")
    assert cfg.eval.kinds is None and tuple(POLICIES)[:4] == ("cnn_dmp", "velocity", "act", "diffusion")
    found = evaluate.instantiate_evaluator(cfg).resolve_checkpoints(cfg.paths.output_root, given(cfg))
    assert found == checkpoints  # every kind with a checkpoint, no note about the others
    assert "checkpoint" not in capsys.readouterr().out
    cfg = tiny("evaluate", "eval.kinds=[cnn_dmp,velocity,act,diffusion]")
    with pytest.warns(RuntimeWarning, match="no 'act' checkpoint.*python train.py model=act"):
        found = evaluate.instantiate_evaluator(cfg).resolve_checkpoints(cfg.paths.output_root, given(cfg))
    assert found == checkpoints
    assert "no 'diffusion' checkpoint" in capsys.readouterr().out


def test_mismatched_image_size_is_refused(checkpoints, tiny, workspace):
    cfg = tiny("evaluate", "data.image_size=48", "data.name=tiny48", "eval.limit=1")
    with pytest.raises(ValueError, match="built with image_size=32, the dataset has image_size=48"):
        evaluate.evaluate(cfg, workspace / "eval-mismatch")


def test_checkpoint_carries_fingerprint_and_own_training_items_are_refused(checkpoints, tiny, workspace):
    """The checkpoint knows its dataset; evaluating it on a training object is refused, naming both."""
    from lfd.io.files import sha256_file
    from lfd.visuomotor.data.datasets import load_dataset

    data = load_dataset(workspace / "data" / "tiny")
    for path in checkpoints.values():
        fp = load_policy(path).dataset_fingerprint
        assert fp["manifest_sha256"] == sha256_file(data.path / "manifest.json")
        assert set(fp["split_keys"]) == {"train", "val", "test"}
        assert len(fp["train_placements"]) == len(data.split("train"))
    obj = data.split("train")[0].obj
    assert obj.shape == "cylinder"
    scenario = workspace / "own.yaml"
    scenario.write_text(
        "objects:\n"
        "  - "
        f"{{name: mine, shape: cylinder, radius: {obj.dims[0]!r}, height: {obj.dims[1]!r}, rgba: {list(obj.rgba)!r}}}\n"
        "placements:\n  - [0.55, 0.05, 0.3]\n"
    )
    cfg = tiny("evaluate", f"eval.scenario={scenario}", "eval.n_gifs=0", "eval.max_steps=2")
    with pytest.raises(
        ValueError,
        match=rf"checkpoint .* was trained on items of the evaluation cases "
        rf".*object 'mine' is training object '{obj.name}'",
    ):
        evaluate.evaluate(cfg, workspace / "eval-own")


def test_colour_tta_is_set_per_method_and_refused_without_colour_augment(checkpoints, tiny, workspace):
    """`eval.colour_tta` switches the test-time colour averaging on for the methods it names,
    records it in metrics.json, and refuses a checkpoint that never saw permuted colours."""
    cfg = tiny("evaluate", "eval.colour_tta=[cnn_dmp]", "eval.n_gifs=0", "eval.max_steps=4", "eval.limit=1")
    with pytest.raises(ValueError, match=r"eval.colour_tta: cnn_dmp checkpoint .*colour_augment"):
        evaluate.evaluate(cfg, workspace / "eval-tta-refused")
    run_dir = workspace / "outputs" / "train-tta" / "run-cnn_dmp"
    train_cfg = tiny(
        "train",
        "model=cnn_dmp",
        "model.colour_augment=true",
        "++trainer.max_steps=2",
        "++trainer.limit_val_batches=1",
        f"paths.output_dir={run_dir}",
        *TINY_MODEL,
    )
    ckpt = Path(train.main(train_cfg))
    cfg = tiny(
        "evaluate",
        "eval.colour_tta=[cnn_dmp]",
        "eval.n_gifs=0",
        "eval.max_steps=4",
        "eval.limit=1",
        f"ckpt=[{ckpt},{checkpoints['velocity']}]",
    )
    metrics = evaluate.evaluate(cfg, workspace / "eval-tta")
    assert metrics["cnn_dmp"]["colour_tta"] is True and metrics["velocity"]["colour_tta"] is False
    from lfd.visuomotor.eval.evaluator import ReachEvaluator

    with pytest.raises(ValueError, match=r"eval.colour_tta: unknown \['cnn'\]"):
        ReachEvaluator(colour_tta=["cnn"])


def test_quick_evaluates_cnn_dmp_with_colour_averaging_and_nothing_else_does(compose):
    """experiment=quick (the main job's checkpoints record it) turns colour averaging on for CNN -> DMP only,
    as chosen on validation; the original scale and an explicit override leave it off."""
    assert list(compose("evaluate", "experiment=quick").eval.colour_tta) == ["cnn_dmp"]
    assert list(compose("evaluate", "experiment=quick", "eval.colour_tta=[]").eval.colour_tta) == []
    assert list(compose("evaluate", "experiment=original").eval.colour_tta) == []
