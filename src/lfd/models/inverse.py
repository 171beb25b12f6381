"""Inverse model (Cartesian error -> joint velocities) and the Sawyer forward + inverse pair.

:class:`InverseModel` is the original's MLP ``3 -> 300 -> 200 -> 100 -> 7`` with sigmoid
hidden units (configurable) from the end-effector error ``x_e - goal`` (m) to a
joint-velocity command (rad/s), trained on one task's demonstration and its polynomial
augmentation (:class:`lfd.data.sawyer.SawyerInverseDataModule`). Input and output
normalisation statistics and the demonstration itself are copied from the training data
at ``setup("fit")`` and stored in the checkpoint.

:class:`SawyerModels` holds one :class:`~lfd.models.forward.ForwardModel` and one
:class:`InverseModel` per task and trains them together from
:class:`lfd.data.sawyer.SawyerModelsDataModule` batches, so that
``python train.py experiment=sawyer_models`` produces one checkpoint with everything the
closed-loop evaluation (:mod:`lfd.eval.sawyer`) needs.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import lightning as L
import numpy as np
import torch
from torch import Tensor, nn

from lfd.data.sawyer import InverseData, JointDemonstration
from lfd.models.forward import (
    ForwardModel,
    error_summary,
    format_error_table,
    make_activation,
    make_optimizer,
    report_test_errors,
    save_own_hyperparameters,
)

__all__ = ["InverseModel", "SawyerModels", "load_sawyer_models"]

#: Checkpoint key holding the demonstrations ``{task: {"t", "q", "source"}}``.
DEMOS_KEY = "sawyer_demonstrations"


def sigmoid_mlp(in_dim: int, hidden: Sequence[int], out_dim: int, act: str) -> nn.Sequential:
    """``in_dim -> hidden... -> out_dim`` with ``act`` after every hidden layer, linear output."""
    layers: list[nn.Module] = []
    for width in hidden:
        layers += [nn.Linear(in_dim, int(width)), make_activation(act)]
        in_dim = int(width)
    layers.append(nn.Linear(in_dim, out_dim))
    return nn.Sequential(*layers)


class InverseModel(L.LightningModule):
    """End-effector error ``(B, 3)`` (m) -> joint velocities ``(B, n)`` (rad/s) for one task.

    Args:
        task: name of the task (end-effector orientation) it is trained for; standalone
            training reads this task's batches.
        hidden: hidden layer widths.
        activation: hidden activation (default sigmoid, as in the original).
        n_joints: arm degrees of freedom.
        lr, weight_decay, scheduler, pct_start: optimisation (see
            :func:`lfd.models.forward.make_optimizer`).
    """

    def __init__(
        self,
        task: str = "cube",
        hidden: Sequence[int] = (300, 200, 100),
        activation: str = "sigmoid",
        n_joints: int = 7,
        lr: float = 3e-3,
        weight_decay: float = 0.0,
        scheduler: str = "onecycle",
        pct_start: float = 0.15,
    ) -> None:
        super().__init__()
        save_own_hyperparameters(self, locals())
        self.net = sigmoid_mlp(3, list(hidden), n_joints, activation)
        self.register_buffer("e_mean", torch.zeros(3))
        self.register_buffer("e_std", torch.ones(3))
        self.register_buffer("v_mean", torch.zeros(n_joints))
        self.register_buffer("v_std", torch.ones(n_joints))
        self.demo: JointDemonstration | None = None

    def adapt(self, data: InverseData) -> None:
        """Take the normalisation statistics and the demonstration from the training data."""
        e = torch.from_numpy(data.errors.reshape(-1, 3))
        v = torch.from_numpy(data.velocities.reshape(-1, data.velocities.shape[-1]))
        if v.shape[-1] != self.hparams.n_joints:
            raise ValueError(f"InverseModel({self.hparams.task}): data has {v.shape[-1]} joints, model {self.hparams.n_joints}")
        for name, value in (("e_mean", e.mean(0)), ("e_std", e.std(0)), ("v_mean", v.mean(0)), ("v_std", v.std(0).clamp_min(1e-6))):
            getattr(self, name).copy_(value)
        self.demo = data.demo

    def forward(self, errors: Tensor) -> Tensor:
        """Joint-velocity commands ``(B, n)`` (rad/s) for end-effector errors ``x_e - goal`` ``(B, 3)`` (m)."""
        errors = torch.as_tensor(errors, dtype=self.e_mean.dtype, device=self.e_mean.device)
        return self.net((errors - self.e_mean) / self.e_std) * self.v_std + self.v_mean

    def loss(self, errors: Tensor, velocities: Tensor) -> Tensor:
        """Mean squared error in normalised velocity units."""
        predicted = self.net((errors - self.e_mean) / self.e_std)
        return ((predicted - (velocities - self.v_mean) / self.v_std) ** 2).mean()

    def parameter_groups(self) -> list[dict[str, Any]]:
        hp = self.hparams
        return [{"params": list(self.parameters()), "lr": hp.lr, "weight_decay": hp.weight_decay}]

    # -- standalone training on SawyerInverseDataModule ({task: (e, v)} batches) ----------
    def setup(self, stage: str) -> None:
        if stage == "fit":
            self.adapt(self.trainer.datamodule.prepare()[self.hparams.task])

    def training_step(self, batch, batch_idx: int) -> Tensor:
        loss = self.loss(*batch[self.hparams.task])
        self.log("train/loss", loss, prog_bar=True)
        return loss

    def validation_step(self, batch, batch_idx: int) -> None:
        if batch.get(self.hparams.task) is not None:
            self.log("val/loss", self.loss(*batch[self.hparams.task]), prog_bar=True)

    def configure_optimizers(self) -> dict[str, Any]:
        return make_optimizer(self, self.parameter_groups(), self.hparams.scheduler, self.hparams.pct_start)

    # -- the demonstration travels in the checkpoint ----------------------------------------
    def demo_state(self) -> dict[str, Any] | None:
        """The demonstration as checkpoint content: tensors and a string (loadable with ``weights_only=True``)."""
        if self.demo is None:
            return None
        return {"t": torch.from_numpy(self.demo.t), "q": torch.from_numpy(self.demo.q), "source": self.demo.source}

    def load_demo_state(self, state: Mapping[str, Any] | None) -> None:
        if state is None:
            self.demo = None
            return
        t, q = (torch.as_tensor(state[k], dtype=torch.float64).numpy() for k in ("t", "q"))
        self.demo = JointDemonstration(t=t, q=q, source=str(state["source"]))

    def on_save_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        checkpoint[DEMOS_KEY] = {self.hparams.task: self.demo_state()}

    def on_load_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        self.load_demo_state(checkpoint.get(DEMOS_KEY, {}).get(self.hparams.task))


class SawyerModels(L.LightningModule):
    """The forward model and one inverse model per task, trained together.

    Batches come from :class:`lfd.data.sawyer.SawyerModelsDataModule`:
    ``{"forward": (q, x), "inverse": {task: (errors, velocities)}}``. The loss is the sum of
    the forward loss and every task's inverse loss (disjoint parameters, one AdamW with one
    parameter group per network). Logs ``train/forward_loss``, ``train/err_mm``,
    ``train/inverse_loss/<task>``, and per validation epoch ``val/forward_loss``,
    ``val/err_mm``, ``val/inverse_loss/<task>`` and their sum ``val/loss``. ``test`` runs
    the forward model's held-out set and prints the error table (mm).

    Args:
        forward: :class:`~lfd.models.forward.ForwardModel` arguments.
        inverse: :class:`InverseModel` arguments shared by all tasks (without ``task``).
        tasks: task names; must match the datamodule's tasks.
        kind: stored in the checkpoint's hyper-parameters so that evaluation can find
            Sawyer checkpoints (:func:`lfd.eval.evaluator.find_checkpoints`); any other
            value than :attr:`kind` is rejected.
    """

    kind = "sawyer_models"

    def __init__(
        self,
        forward: Mapping[str, Any] | None = None,
        inverse: Mapping[str, Any] | None = None,
        tasks: Sequence[str] = ("cube", "cup"),
        kind: str | None = None,
    ) -> None:
        super().__init__()
        if kind is not None and kind != self.kind:
            raise ValueError(f"SawyerModels holds '{self.kind}' checkpoints, got a '{kind}' one")
        forward, inverse = dict(forward or {}), dict(inverse or {})
        if "task" in inverse:
            raise ValueError("SawyerModels.inverse: 'task' is set per task, from `tasks`")
        self.save_hyperparameters({"forward": forward, "inverse": inverse, "tasks": list(tasks), "kind": self.kind})
        self.forward_model = ForwardModel(**forward)
        self.inverse_models = nn.ModuleDict({task: InverseModel(task=task, **inverse) for task in tasks})
        self._val: dict[str, list[float]] = {}
        self._test_errors: list[Tensor] = []

    @property
    def tasks(self) -> list[str]:
        return list(self.inverse_models)

    def setup(self, stage: str) -> None:
        if stage != "fit":
            return
        data = self.trainer.datamodule.inverse.prepare()
        if set(data) != set(self.tasks):
            raise ValueError(f"SawyerModels.tasks {sorted(self.tasks)} differ from the datamodule's tasks {sorted(data)}")
        for task, model in self.inverse_models.items():
            model.adapt(data[task])

    def _losses(self, batch) -> dict[str, Tensor]:
        out: dict[str, Tensor] = {}
        if batch.get("forward") is not None:
            out["forward_loss"], errors = self.forward_model.loss(*batch["forward"])
            out["err_mm"] = errors.mean()
        for task, pair in (batch.get("inverse") or {}).items():
            if pair is not None:
                out[f"inverse_loss/{task}"] = self.inverse_models[task].loss(*pair)
        return out

    def training_step(self, batch, batch_idx: int) -> Tensor:
        losses = self._losses(batch)
        self.log_dict({f"train/{k}": v for k, v in losses.items()}, prog_bar=True)
        return sum(v for k, v in losses.items() if k != "err_mm")

    def validation_step(self, batch, batch_idx: int) -> None:
        for key, value in self._losses(batch).items():
            self._val.setdefault(key, []).append(float(value))

    def on_validation_epoch_end(self) -> None:
        means = {k: float(np.mean(v)) for k, v in self._val.items()}
        self._val = {}
        if means:
            means["loss"] = sum(v for k, v in means.items() if k != "err_mm")
            self.log_dict({f"val/{k}": v for k, v in means.items()}, prog_bar=True)

    def test_step(self, batch, batch_idx: int) -> None:
        self._test_errors.append(self.forward_model.loss(*batch)[1])

    def on_test_epoch_end(self) -> None:
        summary = report_test_errors(self, self._test_errors, "test/err_mm")
        self._test_errors = []
        print(format_error_table(summary))

    def configure_optimizers(self) -> dict[str, Any]:
        groups = self.forward_model.parameter_groups() + [g for m in self.inverse_models.values() for g in m.parameter_groups()]
        hp = self.forward_model.hparams
        return make_optimizer(self, groups, hp.scheduler, hp.pct_start)

    def on_save_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        checkpoint[DEMOS_KEY] = {task: m.demo_state() for task, m in self.inverse_models.items()}

    def on_load_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        demos = checkpoint.get(DEMOS_KEY, {})
        for task, model in self.inverse_models.items():
            model.load_demo_state(demos.get(task))

    def forward_error_summary(self, q: Tensor, x: Tensor, batch_size: int = 20_000) -> dict[str, float]:
        """:func:`~lfd.models.forward.error_summary` (mm) of the forward model on ``(q, x)``."""
        with torch.no_grad():
            errors = [self.forward_model.loss(qb, xb)[1] for qb, xb in zip(q.split(batch_size), x.split(batch_size))]
        return error_summary(torch.cat(errors))


def load_sawyer_models(path, map_location: str | torch.device = "cpu") -> SawyerModels:
    """Load a :class:`SawyerModels` checkpoint in eval mode; every task must carry its demonstration.

    Raises:
        FileNotFoundError: no file at ``path``.
        ValueError: the checkpoint holds no demonstration for some task (it was saved
            before training started).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"Sawyer models checkpoint not found: {path}")
    models = SawyerModels.load_from_checkpoint(path, map_location=map_location, weights_only=True).eval()
    missing = [t for t, m in models.inverse_models.items() if m.demo is None]
    if missing:
        raise ValueError(f"{path}: no demonstration stored for task(s) {missing}")
    return models
