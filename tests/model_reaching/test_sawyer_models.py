"""Sawyer forward and inverse models: error metric, tiny training runs, checkpoints."""

from __future__ import annotations

import lightning as L
import numpy as np
import pytest
import torch

from lfd.model_reaching import SawyerModels, load_sawyer_models
from lfd.model_reaching.closed_loop import closed_loop_reach
from lfd.model_reaching.data import SawyerFKDataModule, SawyerInverseDataModule, sample_fk
from lfd.model_reaching.demonstrations import TASK_ORIENTATIONS_DEG, InverseDataConfig
from lfd.model_reaching.forward import ForwardModel, error_summary, position_errors_mm
from lfd.model_reaching.inverse import InverseModel
from lfd.robots import load_robot
from lfd.sim.arms import KinematicArm

START = np.radians([0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0])


def trainer(**kwargs) -> L.Trainer:
    options = {
        "logger": False,
        "enable_checkpointing": False,
        "enable_progress_bar": False,
        "enable_model_summary": False,
    }
    return L.Trainer(accelerator="cpu", **(options | kwargs))


@pytest.fixture(scope="module")
def robot():
    return load_robot("sawyer")


@pytest.fixture(scope="module")
def cube_data():
    """Small inverse-model data of the cube task (shared by the inverse-model tests)."""
    tasks = {"cube": {"orientation_deg": TASK_ORIENTATIONS_DEG["cube"]}}
    dm = SawyerInverseDataModule(tasks=tasks, config=InverseDataConfig(n_goals=24, seed=3), batch_size=128)
    dm.prepare()
    return dm


# ---------------------------------------------------------------------------- error metric
def test_error_metric_on_a_known_perturbation(robot):
    q, x = sample_fk(robot, 100, torch.Generator().manual_seed(0))
    shifted = x + torch.tensor([0.003, 0.004, 0.0])
    assert position_errors_mm(shifted, x) == pytest.approx(torch.full((100,), 5.0), abs=1e-3)
    summary = error_summary(torch.arange(1.0, 101.0))
    assert summary == pytest.approx({"mean": 50.5, "median": 50.0, "p99": 99.01, "max": 100.0, "n": 100})
    with pytest.raises(ValueError, match=r"need two \(B, 3\)"):
        position_errors_mm(x[:, :2], x[:, :2])


def test_forward_model_error_is_measured_against_fk(robot):
    model = ForwardModel(width=16, n_blocks=1)
    q, x = sample_fk(robot, 64, torch.Generator().manual_seed(1))
    with torch.no_grad():
        _, errors = model.loss(q, x)
        expected = 1000 * (model(q) - robot.fk(q.double())[:, :3, 3].float()).norm(dim=1)
    assert errors == pytest.approx(expected, abs=1e-2)


# ---------------------------------------------------------------------------- forward model
def test_yaw_equivariant_forward_model_turns_with_joint_0(robot):
    """Any network output, turned by q0 about joint 0's axis: the prediction rotates rigidly
    with joint 0 exactly like the true FK does, and the MLP never sees q0."""
    torch.manual_seed(0)
    model = ForwardModel(width=16, n_blocks=1).eval()
    q, x = sample_fk(robot, 64, torch.Generator().manual_seed(2))
    # the model frame is the FK position with joint 0 undone: the same for every q0
    turned = q.clone()
    turned[:, 0] = torch.empty(64).uniform_(-3.0, 3.0)
    x_turned = robot.fk(turned.double())[:, :3, 3].float()
    assert torch.allclose(model.to_model_frame(turned, x_turned), model.to_model_frame(q, x), atol=1e-5)
    with torch.no_grad():
        p, p_turned = model(q), model(turned)
        assert torch.equal(model.features(q), model.features(turned))
        # |p - pivot| and the height along the axis are unchanged by turning joint 0
        a, c = model.axis, model.pivot
        assert torch.allclose((p - c) @ a, (p_turned - c) @ a, atol=1e-5)
        assert torch.allclose((p - c).norm(dim=1), (p_turned - c).norm(dim=1), atol=1e-5)
    plain = ForwardModel(width=16, n_blocks=1, yaw_equivariant=False)
    assert plain.features(q).shape == (64, 21) and model.features(q).shape == (64, 18)
    assert not torch.equal(plain.features(q), plain.features(turned))


def test_tiny_forward_model_beats_the_mean_position_baseline(tmp_path, robot):
    torch.manual_seed(0)
    dm = SawyerFKDataModule(
        batch_size=512, batches_per_epoch=80, n_val=512, n_test=4000, eval_batch_size=4000, seed=0
    )
    model = ForwardModel(width=64, n_blocks=1, lr=1e-2)
    run = trainer(max_epochs=2, default_root_dir=tmp_path)
    run.fit(model, datamodule=dm)
    metrics = run.test(model, datamodule=dm, verbose=False)[0]

    q, x = dm.fixed_set("test").tensors
    with torch.no_grad():
        errors = position_errors_mm(model(q), x)
    baseline = position_errors_mm(x.mean(0).expand_as(x), x)
    assert metrics["test/err_mm_mean"] == pytest.approx(float(errors.mean()), rel=1e-4)
    assert errors.mean() < 0.5 * baseline.mean()
    assert errors.median() < 0.5 * baseline.median()

    path = tmp_path / "forward.ckpt"
    run.save_checkpoint(path)
    loaded = ForwardModel.load_from_checkpoint(path).eval()
    assert loaded.hparams.width == 64
    with torch.no_grad():
        assert torch.equal(loaded(q[:10]), model(q[:10]))


# ---------------------------------------------------------------------------- inverse model
def test_inverse_model_drives_the_kinematic_arm_towards_goals(tmp_path, robot, cube_data):
    torch.manual_seed(0)
    model = InverseModel(task="cube")
    with pytest.raises(RuntimeError, match="adapt"):
        trainer(max_epochs=1, default_root_dir=tmp_path).fit(model, datamodule=cube_data)
    model.adapt(cube_data.adaptation_data())  # the data reach the model as plain objects, as in train.py
    trainer(max_epochs=12, default_root_dir=tmp_path).fit(model, datamodule=cube_data)
    goals = np.array([[0.035, -0.573, -0.04], [0.237, -0.466, -0.04], [-0.179, -0.678, -0.04]])
    initial = np.linalg.norm(robot.fk(torch.from_numpy(START[None]))[0, :3, 3].numpy() - goals, axis=1)

    def fk(q):
        return robot.fk(q.double())[:, :3, 3].float()

    traces = closed_loop_reach(
        fk, model, robot, goals, START, KinematicArm(robot, 0.05), max_steps=200, threshold=0.01
    )
    final = np.array([trace.final_error(g) for trace, g in zip(traces, goals)])
    assert np.all(final < 0.25 * initial), (final, initial)

    untrained = InverseModel(task="cube")
    untrained.adapt(cube_data.data["cube"])
    baseline = closed_loop_reach(
        fk, untrained, robot, goals, START, KinematicArm(robot, 0.05), max_steps=200, threshold=0.01
    )
    assert final.mean() < 0.5 * np.mean([trace.final_error(g) for trace, g in zip(baseline, goals)])


def test_sawyer_models_checkpoint_carries_demos_and_normalisation(tmp_path, cube_data):
    models = SawyerModels(forward={"width": 16, "n_blocks": 1}, tasks=["cube"])
    models.inverse_models["cube"].adapt(cube_data.data["cube"])
    run = trainer(max_steps=0, default_root_dir=tmp_path)
    run.strategy.connect(models)
    path = tmp_path / "models.ckpt"
    run.save_checkpoint(path)

    loaded = load_sawyer_models(path)
    original, restored = models.inverse_models["cube"], loaded.inverse_models["cube"]
    assert restored.demo.q == pytest.approx(original.demo.q)
    assert restored.demo.source == "scripted"
    assert torch.equal(restored.v_std, original.v_std) and not torch.equal(restored.v_std, torch.ones(7))
    assert loaded.forward_model.hparams.width == 16
    assert "tasks" not in loaded.forward_model.hparams  # its own arguments only
    with pytest.raises(FileNotFoundError):
        load_sawyer_models(tmp_path / "missing.ckpt")


def test_sawyer_models_reject_mismatched_arguments():
    with pytest.raises(ValueError, match="'task' is set per task"):
        SawyerModels(inverse={"task": "cube"})
    with pytest.raises(ValueError, match="activation"):
        ForwardModel(activation="swish")
