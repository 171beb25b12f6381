"""The Sawyer forward model and one inverse model per task, trained together (thesis ch. 5).

:class:`SawyerModels` holds one :class:`~lfd.model_reaching.forward.ForwardModel` and one
:class:`~lfd.model_reaching.inverse.InverseModel` per task and trains them from
:class:`lfd.model_reaching.data.SawyerModelsDataModule` batches, so that
``python train.py experiment=sawyer_models`` produces one checkpoint with everything the
closed-loop protocol (:mod:`lfd.model_reaching.protocol`) needs; :func:`load_sawyer_models` reads it.

Example::

    from lfd.model_reaching.data import SawyerModelsDataModule
    from lfd.model_reaching import SawyerModels

    data = SawyerModelsDataModule()
    models = SawyerModels()
    models.adapt(data.adaptation_data())      # normalisation + demonstrations (train.py does this)
    L.Trainer(max_epochs=10).fit(models, datamodule=data)     # import lightning as L
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import lightning as L
import numpy as np
import torch
from torch import Tensor, nn

from lfd.model_reaching.demonstrations import InverseData
from lfd.model_reaching.forward import ForwardModel, error_summary, format_error_table, report_test_errors
from lfd.model_reaching.inverse import DEMOS_KEY, InverseModel
from lfd.training import CheckpointError, load_checkpoint_module, make_optimizer, read_checkpoint

__all__ = ["SawyerModels", "load_sawyer_models"]


class SawyerModels(L.LightningModule):
    """The forward model and one inverse model per task, trained together.

    Before fitting, :meth:`adapt` takes the inverse models' normalisation and
    demonstrations from the training data (plain objects, handed over by ``train.py``).
    Batches come from :class:`lfd.model_reaching.data.SawyerModelsDataModule`:
    ``{"forward": (q, x), "inverse": {task: (errors, velocities)}}``. The loss is the sum of
    the forward loss and every task's inverse loss (disjoint parameters, one AdamW with one
    parameter group per network). Logs ``train/forward_loss``, ``train/err_mm``,
    ``train/inverse_loss/<task>``, and per validation epoch ``val/forward_loss``,
    ``val/err_mm``, ``val/inverse_loss/<task>`` and their sum ``val/loss``. ``test`` runs
    the forward model's held-out set and prints the error table (mm).

    Args:
        forward: :class:`~lfd.model_reaching.forward.ForwardModel` arguments.
        inverse: :class:`InverseModel` arguments shared by all tasks (without ``task``).
        tasks: task names; must match the datamodule's tasks.
        kind: stored in the checkpoint's hyper-parameters so that evaluation can find
            Sawyer checkpoints (:func:`lfd.training.find_checkpoints`); any other
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
        self.save_hyperparameters(
            {"forward": forward, "inverse": inverse, "tasks": list(tasks), "kind": self.kind}
        )
        self.forward_model = ForwardModel(**forward)
        self.inverse_models = nn.ModuleDict({task: InverseModel(task=task, **inverse) for task in tasks})
        self._val: dict[str, list[float]] = {}
        self._test_errors: list[Tensor] = []

    @property
    def tasks(self) -> list[str]:
        return list(self.inverse_models)

    def adapt(self, data: Mapping[str, InverseData]) -> None:
        """Take each inverse model's normalisation statistics and demonstration from its
        task's training data ``{task: InverseData}`` (``SawyerModelsDataModule.adaptation_data()``)."""
        if set(data) != set(self.tasks):
            raise ValueError(
                f"SawyerModels.tasks {sorted(self.tasks)} differ from the datamodule's tasks {sorted(data)}"
            )
        for task, model in self.inverse_models.items():
            model.adapt(data[task])

    def setup(self, stage: str) -> None:
        missing = [task for task, model in self.inverse_models.items() if model.demo is None]
        if stage == "fit" and missing:
            raise RuntimeError(
                f"SawyerModels: tasks {missing} have no training data yet; call "
                "models.adapt(datamodule.adaptation_data()) before fitting (train.py does)"
            )

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
        groups = self.forward_model.parameter_groups() + [
            g for m in self.inverse_models.values() for g in m.parameter_groups()
        ]
        hp = self.forward_model.hparams
        return make_optimizer(self, groups, hp.scheduler, hp.pct_start)

    def on_save_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        checkpoint[DEMOS_KEY] = {task: m.demo_state() for task, m in self.inverse_models.items()}

    def on_load_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        demos = checkpoint.get(DEMOS_KEY, {})
        for task, model in self.inverse_models.items():
            model.load_demo_state(demos.get(task))

    def forward_error_summary(self, q: Tensor, x: Tensor, batch_size: int = 20_000) -> dict[str, float]:
        """:func:`~lfd.model_reaching.forward.error_summary` (mm) of the forward model on ``(q, x)``."""
        with torch.no_grad():
            errors = [
                self.forward_model.loss(qb, xb)[1] for qb, xb in zip(q.split(batch_size), x.split(batch_size))
            ]
        return error_summary(torch.cat(errors))


def load_sawyer_models(path, map_location: str | torch.device = "cpu") -> SawyerModels:
    """Load a :class:`SawyerModels` checkpoint in eval mode; every task must carry its demonstration.
    The file is checked by :func:`lfd.training.read_checkpoint` and loaded with
    ``weights_only=True``: no code from it runs.

    Raises:
        FileNotFoundError: no file at ``path``.
        lfd.training.CheckpointError: not a Lightning checkpoint (empty, truncated, foreign,
            a pickled payload) or not a Sawyer models one (one line naming the file).
        ValueError: the checkpoint holds no demonstration for some task (it was saved
            before training started).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"Sawyer models checkpoint not found: {path}")
    kind = read_checkpoint(path, keys=("state_dict", "hyper_parameters"))["hyper_parameters"].get("kind")
    if kind != SawyerModels.kind:
        raise CheckpointError(
            f"{path}: checkpoint kind {kind!r} is not {SawyerModels.kind!r}; "
            "expected a checkpoint of `python train.py experiment=sawyer_models`"
        )
    models = load_checkpoint_module(SawyerModels, path, map_location)  # sizes, keys, shapes checked
    missing = [t for t, m in models.inverse_models.items() if m.demo is None]
    if missing:
        raise ValueError(f"{path}: no demonstration stored for task(s) {missing}")
    return models
