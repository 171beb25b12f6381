"""ACT and Diffusion Policy through the entry points: ``train.py model=act|diffusion`` on a tiny
generated dataset, checkpoints that load with ``weights_only=True``, and ``evaluate.py`` scoring
them in the closed loop with the same keys as the other policies."""

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from _chunk_batches import TINY_MODELS

import evaluate
import train
from lfd.training import read_checkpoint
from lfd.visuomotor.policies import POLICIES, load_policy


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("chunking")


@pytest.fixture(scope="module")
def checkpoints(compose, workspace, tiny_data) -> dict[str, Path]:
    """Three optimiser steps of each chunking policy, as ``train.py model=...`` leaves them."""
    out = {}
    for model, overrides in TINY_MODELS.items():
        run_dir = workspace / "outputs" / "train" / f"run-{model}"
        cfg = compose(
            "train",
            f"paths.root_dir={workspace}",
            *tiny_data,
            f"model={model}",
            *overrides,
            "++trainer.max_steps=3",
            "++trainer.limit_val_batches=1",
            f"paths.output_dir={run_dir}",
        )
        out[model] = Path(train.main(cfg))
        assert out[model] == run_dir / "checkpoints" / "last.ckpt" and out[model].is_file()
    return out


def test_checkpoints_load_with_weights_only_and_run_alone(checkpoints, workspace):
    from lfd.visuomotor.data.datasets import load_dataset

    stats = load_dataset(workspace / "data" / "tiny").stats
    frame = np.zeros((32, 32, 3), dtype=np.uint8)
    for kind, path in checkpoints.items():
        hp = read_checkpoint(path, keys=("hyper_parameters",))["hyper_parameters"]  # plain types only
        assert hp["kind"] == kind and hp["backbone"] == "trunk"
        policy = load_policy(path)
        assert type(policy) is POLICIES[kind] and not policy.training
        torch.testing.assert_close(policy.joints_mean, stats["joints"]["mean"])
        assert policy._trajectories.numel() == 0  # the lookup table is not saved
        chunk = policy.act_chunk(frame, stats["joints"]["mean"].numpy())
        assert chunk.shape == (policy.hparams.chunk_size, 7) and np.all(np.isfinite(chunk))
        again = POLICIES[kind].load_from_checkpoint(path, weights_only=True)
        torch.testing.assert_close(again.state_dict(), policy.state_dict())
    with pytest.raises(ValueError, match="holds 'act' policies"):
        POLICIES["act"].load_from_checkpoint(checkpoints["diffusion"], weights_only=True)


def test_evaluate_scores_every_chunking_kind_with_the_usual_keys(checkpoints, compose, workspace, tiny_data):
    """``python evaluate.py eval.kinds=[act,diffusion]`` finds the newest checkpoint of each
    kind under outputs/train and writes one metrics.json entry per kind."""
    out_dir = workspace / "eval"
    cfg = compose(
        "evaluate",
        f"paths.root_dir={workspace}",
        *tiny_data,
        "eval.colour_tta=[]",
        "eval.kinds=[act,diffusion]",
        "eval.n_gifs=0",
        "eval.max_steps=8",
    )
    evaluate.evaluate(cfg, out_dir)
    saved = json.loads((out_dir / "metrics.json").read_text())
    assert set(saved) == {"act", "diffusion"}
    for kind, m in saved.items():
        assert m["checkpoint"] == str(checkpoints[kind]) and m["episodes"] == 2
        assert m["final_distance_m"]["mean"] > 0 and 0.0 <= m["success_5cm"] <= 1.0
        assert m["joint_limit_violations"] >= 0 and m["latency_ms"]["median"] > 0


def test_chunk_execution_ablation_is_applied_recorded_and_checked(checkpoints, compose, workspace, tiny_data):
    """``eval.chunk_execution`` runs ACT's chunks open-loop to their end (recorded per kind in
    metrics.json; other kinds None); a non-chunking kind or an unknown key is one clear error."""
    from lfd.visuomotor.eval import ReachEvaluator

    out_dir = workspace / "eval_execution"
    args = [
        f"paths.root_dir={workspace}",
        *tiny_data,
        "eval.colour_tta=[]",
        "eval.n_gifs=0",
        "eval.max_steps=8",
    ]
    cfg = compose(
        "evaluate",
        *args,
        "eval.kinds=[act,diffusion]",
        "eval.chunk_execution={act:{replan_every:null,ensemble_m:null}}",
    )
    evaluate.evaluate(cfg, out_dir)
    saved = json.loads((out_dir / "metrics.json").read_text())
    assert saved["act"]["chunk_execution"] == {"replan_every": None, "ensemble_m": None}
    assert saved["diffusion"]["chunk_execution"] is None and saved["act"]["episodes"] == 2
    for bad in ({"cnn_dmp": {"replan_every": 2}}, {"act": {"every": 2}}):
        with pytest.raises(ValueError, match="eval.chunk_execution: expected"):
            ReachEvaluator(chunk_execution=bad)
    cfg = compose(
        "evaluate", *args, "eval.kinds=[act]", "eval.limit=1", "eval.chunk_execution={act:{replan_every:3}}"
    )
    evaluate.evaluate(cfg, workspace / "eval_partial")  # ensemble_m left out: the trained 0.01 kept
    saved = json.loads((workspace / "eval_partial" / "metrics.json").read_text())
    assert saved["act"]["chunk_execution"] == {"replan_every": 3, "ensemble_m": 0.01}
    cfg = compose("evaluate", *args, "eval.kinds=[act]", "eval.chunk_execution={act:{replan_every:7}}")
    with pytest.raises(ValueError, match=r"eval.chunk_execution.act: .*chunk_size=6"):
        evaluate.evaluate(cfg, workspace / "eval_bad")


def test_probe_script_reports_errors_offsets_and_the_noise_model(checkpoints, workspace, capsys):
    """``scripts/probe_chunk_policy.py`` on both kinds: chunk errors on the validation episodes,
    the joint-offset sensitivity, and (Diffusion Policy) the error by diffusion step."""
    import importlib.util

    path = Path(__file__).resolve().parents[3] / "scripts" / "probe_chunk_policy.py"
    spec = importlib.util.spec_from_file_location("probe_chunk_policy", path)
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    data = str(workspace / "data" / "tiny")
    for kind, ckpt in checkpoints.items():
        assert probe.main([str(ckpt), "--data", data, "--episodes", "2"]) == 0
        out = capsys.readouterr().out
        assert f"{kind} {ckpt}: 2 validation episodes" in out
        assert "chunk error (rad) at steps 0, 5, 10, 20:" in out and "joints +0.05 rad moves the chunk" in out
        rows = [line for line in out.splitlines() if line.startswith("  val-")]
        assert len(rows) == 2 and all(len(r.split()) == 1 + 4 for r in rows)
        assert ("t= 90" in out and "sampled chunks (4 DDIM steps)" in out) == (kind == "diffusion")
    assert probe.main([str(workspace / "missing.ckpt"), "--data", data]) == 2
    assert "probe_chunk_policy:" in capsys.readouterr().err
