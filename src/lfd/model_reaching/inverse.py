"""Inverse model of one task: Cartesian error -> joint velocities (thesis ch. 5).

:class:`InverseModel` is the original's MLP ``3 -> 300 -> 200 -> 100 -> 7`` with sigmoid
hidden units (configurable) from the end-effector error ``x_e - goal`` (m) to a
joint-velocity command (rad/s), trained on one task's demonstration and its polynomial
augmentation (:class:`lfd.model_reaching.data.SawyerInverseDataModule`). Input and output
normalisation statistics and the demonstration itself are copied from the training data
at ``setup("fit")`` and stored in the checkpoint.

:class:`lfd.model_reaching.models.SawyerModels` trains one per task together with the forward model.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import lightning as L
import torch
from torch import Tensor, nn

from lfd.model_reaching.demonstrations import InverseData, JointDemonstration
from lfd.training import make_activation, make_optimizer, save_own_hyperparameters

__all__ = ["DEMOS_KEY", "InverseModel"]

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
            :func:`lfd.training.make_optimizer`).
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

    def adapt(self, data: InverseData | Mapping[str, InverseData]) -> None:
        """Take the normalisation statistics and the demonstration from the training data:
        this task's :class:`~lfd.model_reaching.demonstrations.InverseData`, or ``{task: InverseData}``
        (``SawyerInverseDataModule.adaptation_data()``, which ``train.py`` hands over)."""
        if isinstance(data, Mapping):
            if self.hparams.task not in data:
                raise ValueError(
                    f"InverseModel.task {self.hparams.task!r} is not among the data's tasks {sorted(data)}"
                )
            data = data[self.hparams.task]
        e = torch.from_numpy(data.errors.reshape(-1, 3))
        v = torch.from_numpy(data.velocities.reshape(-1, data.velocities.shape[-1]))
        if v.shape[-1] != self.hparams.n_joints:
            raise ValueError(
                f"InverseModel({self.hparams.task}): data has {v.shape[-1]} joints, model {self.hparams.n_joints}"
            )
        for name, value in (
            ("e_mean", e.mean(0)),
            ("e_std", e.std(0)),
            ("v_mean", v.mean(0)),
            ("v_std", v.std(0).clamp_min(1e-6)),
        ):
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
        if stage == "fit" and self.demo is None:
            raise RuntimeError(
                f"InverseModel({self.hparams.task}): no training data yet; call "
                "model.adapt(datamodule.adaptation_data()) before fitting (train.py does)"
            )

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
        return {
            "t": torch.from_numpy(self.demo.t),
            "q": torch.from_numpy(self.demo.q),
            "source": self.demo.source,
        }

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
