"""The datamodules of the Sawyer forward and inverse models (thesis ch. 5).

* **Forward model** (:class:`SawyerFKDataModule`): joint configurations drawn uniformly
  within the joint limits and labelled with the end-effector position by the robot's batched
  forward kinematics. Training batches are fresh samples every step (:class:`FKSampleStream`);
  validation and test sets are fixed by the seed.
* **Inverse models** (:class:`SawyerInverseDataModule`): per task, the demonstration and its
  augmented paths of :mod:`lfd.model_reaching.demonstrations`, as ``(error, velocity)`` pairs.
* :class:`SawyerModelsDataModule`: both in one (``configs/data/sawyer_models.yaml``).

Units: metres, radians, seconds. No PyBullet here: ``import lfd.model_reaching.data`` works
without a simulator.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

import lightning as L
import numpy as np
import torch
from lightning.pytorch.utilities import CombinedLoader
from torch import Tensor
from torch.utils.data import DataLoader, IterableDataset, TensorDataset

from lfd.model_reaching.demonstrations import (
    TASK_ORIENTATIONS_DEG,
    InverseData,
    InverseDataConfig,
    build_inverse_data,
    make_demonstration,
)
from lfd.robots import load_robot

__all__ = [
    "FKSampleStream",
    "SawyerFKDataModule",
    "SawyerInverseDataModule",
    "SawyerModelsDataModule",
    "sample_fk",
]


# ---------------------------------------------------------------------------- forward-model samples
def sample_fk(robot, n: int, generator: torch.Generator) -> tuple[Tensor, Tensor]:
    """``n`` configurations uniform within the joint limits (float32, rad) and their
    end-effector positions (float32, m; FK evaluated in float64)."""
    q = robot.sample_q(n, generator)
    return q.float(), robot.fk(q)[:, :3, 3].float()


class FKSampleStream(IterableDataset):
    """Fresh ``(q (B, n), x (B, 3))`` batches for each training step, ``batches_per_epoch``
    per pass. Pass ``k`` draws from a generator seeded with ``(seed, k)``, so a run is
    reproducible and no two epochs see the same samples."""

    def __init__(self, robot_name: str, batch_size: int, batches_per_epoch: int, seed: int) -> None:
        self.robot = load_robot(robot_name)
        self.batch_size, self.batches_per_epoch, self.seed = batch_size, batches_per_epoch, seed
        self.epoch = 0

    def __len__(self) -> int:
        return self.batches_per_epoch

    def __iter__(self) -> Iterator[tuple[Tensor, Tensor]]:
        gen = torch.Generator().manual_seed(self.seed * 1_000_003 + self.epoch)
        self.epoch += 1
        for _ in range(self.batches_per_epoch):
            yield sample_fk(self.robot, self.batch_size, gen)


class SawyerFKDataModule(L.LightningDataModule):
    """Forward-model data: fresh uniform samples for training, fixed validation and test sets.

    Args:
        robot: robot name for :func:`lfd.robots.load_robot`.
        batch_size: samples per training step.
        batches_per_epoch: training steps per epoch (each on new samples).
        n_val, n_test: sizes of the fixed validation / test sets (seeds ``seed + 1``, ``seed + 2``).
        eval_batch_size: batch size of validation and test.
        seed: seed of all sampling.
    """

    def __init__(
        self,
        robot: str = "sawyer",
        batch_size: int = 256,
        batches_per_epoch: int = 1600,
        n_val: int = 20_000,
        n_test: int = 100_000,
        eval_batch_size: int = 20_000,
        seed: int = 0,
    ) -> None:
        super().__init__()
        for name, value in (
            ("batch_size", batch_size),
            ("batches_per_epoch", batches_per_epoch),
            ("n_val", n_val),
            ("n_test", n_test),
            ("eval_batch_size", eval_batch_size),
        ):
            if int(value) < 1:
                raise ValueError(f"SawyerFKDataModule.{name}: expected an int >= 1, got {value!r}")
        self.robot_name = robot
        self.batch_size, self.batches_per_epoch = int(batch_size), int(batches_per_epoch)
        self.n_val, self.n_test, self.eval_batch_size, self.seed = (
            int(n_val),
            int(n_test),
            int(eval_batch_size),
            int(seed),
        )
        self._stream: FKSampleStream | None = None
        self._fixed: dict[str, TensorDataset] = {}

    def fixed_set(self, split: str) -> TensorDataset:
        """The fixed ``"val"`` or ``"test"`` set as a ``TensorDataset(q, x)`` (built once)."""
        if split not in self._fixed:
            offset, n = {"val": (1, self.n_val), "test": (2, self.n_test)}[split]
            self._fixed[split] = TensorDataset(
                *sample_fk(load_robot(self.robot_name), n, torch.Generator().manual_seed(self.seed + offset))
            )
        return self._fixed[split]

    def train_dataloader(self) -> DataLoader:
        if self._stream is None:
            self._stream = FKSampleStream(self.robot_name, self.batch_size, self.batches_per_epoch, self.seed)
        return DataLoader(self._stream, batch_size=None)

    def val_dataloader(self) -> DataLoader:
        return DataLoader(self.fixed_set("val"), batch_size=self.eval_batch_size)

    def test_dataloader(self) -> DataLoader:
        return DataLoader(self.fixed_set("test"), batch_size=self.eval_batch_size)


# ---------------------------------------------------------------------------- inverse-model data
class SawyerInverseDataModule(L.LightningDataModule):
    """Inverse-model data of one or more tasks (end-effector orientations).

    Each task gets its demonstration (:func:`make_demonstration`) and its augmented paths
    (:func:`build_inverse_data`), both set by one :class:`InverseDataConfig`; 10 % of the
    augmented paths (``val_fraction``, never the demonstration) are held out for
    validation. Batches are dictionaries ``{task: (errors (B, 3), velocities (B, n))}``.

    Args:
        tasks: ``{name: {"orientation_deg": [r, p, y], "demo_csv": path}}`` with either key
            (the recorded file wins when both are given); default the original cube and cup
            orientations with scripted demonstrations.
        robot: robot name.
        config: demonstration and augmentation settings, an :class:`InverseDataConfig` or a
            mapping of its fields (``configs/data/sawyer_models.yaml``: ``inverse.config``).
        val_fraction: fraction of paths held out.
        batch_size: samples per step and task.
    """

    def __init__(
        self,
        tasks: Mapping[str, Mapping] | None = None,
        robot: str = "sawyer",
        config: InverseDataConfig | Mapping | None = None,
        val_fraction: float = 0.1,
        batch_size: int = 128,
    ) -> None:
        super().__init__()
        tasks = {
            k: dict(v)
            for k, v in (
                tasks or {k: {"orientation_deg": v} for k, v in TASK_ORIENTATIONS_DEG.items()}
            ).items()
        }
        for name, task in tasks.items():
            unknown = set(task) - {"orientation_deg", "demo_csv"}
            if unknown or not task:
                raise ValueError(
                    f"SawyerInverseDataModule.tasks.{name}: expected orientation_deg and/or demo_csv, got "
                    f"{sorted(task)}"
                )
        if not 0.0 <= val_fraction < 1.0:
            raise ValueError(
                f"SawyerInverseDataModule.val_fraction: expected a number in [0, 1), got {val_fraction}"
            )
        self.tasks = tasks
        self.robot_name = robot
        self.config = InverseDataConfig.from_mapping(config)
        self.val_fraction, self.batch_size, self.seed = val_fraction, int(batch_size), self.config.seed
        self.data: dict[str, InverseData] = {}
        self._splits: dict[str, dict[str, TensorDataset]] = {}

    def prepare(self) -> dict[str, InverseData]:
        """Build (once) and return every task's :class:`InverseData`."""
        if not self.data:
            robot = load_robot(self.robot_name)
            for name, task in self.tasks.items():
                demo = make_demonstration(
                    robot, task.get("orientation_deg"), task.get("demo_csv"), self.config
                )
                self.data[name] = build_inverse_data(robot, demo, self.config)
                self._splits[name] = self._split(self.data[name])
        return self.data

    def setup(self, stage: str | None = None) -> None:
        self.prepare()

    def adaptation_data(self) -> dict[str, InverseData]:
        """Every task's :class:`InverseData` (built once), from which
        :meth:`lfd.model_reaching.inverse.InverseModel.adapt` takes its normalisation and
        demonstration; ``train.py`` hands it over before fitting."""
        return self.prepare()

    def _split(self, data: InverseData) -> dict[str, TensorDataset]:
        n_paths = len(data.goals)
        order = 1 + np.random.default_rng(self.seed).permutation(n_paths - 1)
        n_val = int(round(self.val_fraction * (n_paths - 1)))
        split = {"val": order[:n_val], "train": np.concatenate([[0], order[n_val:]])}

        def pairs(rows: np.ndarray) -> TensorDataset:
            e = torch.from_numpy(data.errors[rows].reshape(-1, 3)).float()
            v = torch.from_numpy(data.velocities[rows].reshape(-1, data.velocities.shape[-1])).float()
            return TensorDataset(e, v)

        return {k: pairs(rows) for k, rows in split.items() if len(rows)}

    def loaders(self, split: str) -> dict[str, DataLoader]:
        """``{task: DataLoader}`` of one split (``"train"`` shuffles)."""
        self.prepare()
        gen = torch.Generator().manual_seed(self.seed)
        return {
            name: DataLoader(s[split], batch_size=self.batch_size, shuffle=split == "train", generator=gen)
            for name, s in self._splits.items()
            if split in s
        }

    def train_dataloader(self) -> CombinedLoader:
        return CombinedLoader(self.loaders("train"), mode="max_size_cycle")

    def val_dataloader(self) -> CombinedLoader:
        return CombinedLoader(self.loaders("val"), mode="max_size")


class SawyerModelsDataModule(L.LightningDataModule):
    """Both models' data in one datamodule: batches ``{"forward": (q, x), "inverse": {task: (e, qd)}}``.

    Training cycles the (small) inverse-model sets while the forward model gets
    ``batches_per_epoch`` fresh batches; validation runs both fixed sets; test is the
    forward model's fixed test set.

    Args:
        forward: :class:`SawyerFKDataModule` arguments.
        inverse: :class:`SawyerInverseDataModule` arguments.
    """

    def __init__(self, forward: Mapping | None = None, inverse: Mapping | None = None) -> None:
        super().__init__()
        self.forward = SawyerFKDataModule(**dict(forward or {}))
        self.inverse = SawyerInverseDataModule(**dict(inverse or {}))

    def setup(self, stage: str | None = None) -> None:
        if stage in (None, "fit", "validate"):
            self.inverse.prepare()

    def adaptation_data(self) -> dict[str, InverseData]:
        """Every task's :class:`InverseData` (built once), from which
        :meth:`lfd.model_reaching.SawyerModels.adapt` takes its normalisation and demonstrations;
        ``train.py`` hands it over before fitting."""
        return self.inverse.prepare()

    def train_dataloader(self) -> CombinedLoader:
        return CombinedLoader(
            {"forward": self.forward.train_dataloader(), "inverse": self.inverse.loaders("train")},
            mode="max_size_cycle",
        )

    def val_dataloader(self) -> CombinedLoader:
        return CombinedLoader(
            {"forward": self.forward.val_dataloader(), "inverse": self.inverse.loaders("val")},
            mode="max_size",
        )

    def test_dataloader(self) -> DataLoader:
        return self.forward.test_dataloader()
