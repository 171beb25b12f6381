"""``ReachDataModule``: the PyBullet reaching-demonstration dataset for Lightning."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import lightning as L
import torch
from torch.utils.data import DataLoader, Dataset

from lfd.io.files import DatasetError
from lfd.sim.depth import DEPTH_ENCODINGS
from lfd.sim.objects import SHAPES
from lfd.visuomotor.data.config import GeneratorConfig
from lfd.visuomotor.data.datasets import (
    DMPReachDataset,
    ReachData,
    VelocityReachDataset,
    image_augmentation,
    load_dataset,
)
from lfd.visuomotor.data.generate import GenerationReport, dataset_dir, generate_dataset
from lfd.visuomotor.protocols import ITEM_MODES

__all__ = ["ReachDataModule"]

MODES = dict(zip(ITEM_MODES, (DMPReachDataset, VelocityReachDataset), strict=True))


class ReachDataModule(L.LightningDataModule):
    """Reaching demonstrations (images, joints, DMP parameters) generated in PyBullet.

    ``prepare_data()`` generates ``<root>/<name>`` if it is missing, resumes it if
    unfinished and verifies it otherwise (a dataset with another config raises
    :class:`~lfd.io.files.DatasetError`). ``setup()`` loads the train / val / test
    splits in the item layout of ``mode`` (see :class:`~lfd.visuomotor.data.datasets.DMPReachDataset`
    and :class:`~lfd.visuomotor.data.datasets.VelocityReachDataset`).

    Generator arguments (``seed`` ... ``robot``, ``val_sizes``, ``sizes``, ``lighting``, ``camera_pose``,
    ``table_texture``, ``clutter``) are those of :class:`~lfd.visuomotor.data.config.GeneratorConfig` and define the
    dataset's content; the others only change how it is made or served.

    Args:
        name: dataset folder name under ``root``.
        root: folder holding datasets.
        mode: ``"dmp"`` (one item per episode) or ``"velocity"`` (one item per step).
        batch_size, num_workers: DataLoader settings (``num_workers`` loader processes).
        augment: colour jitter + small random shifts on training images (RGB input only).
        input_depth: what the policies see: RGB-D (``True``; the dataset must be made with
            ``depth: true``) or RGB (``False``), ``None`` = ``depth``. So an RGB policy can
            train on an RGB-D dataset's colour frames: ``experiment=quick`` generates one
            dataset for both of its policies.
        depth_encoding: the RGB-D depth channel (:data:`lfd.sim.depth.DEPTH_ENCODINGS`):
            ``"range"`` or ``"relief"`` (in front of the table plane); RGB-D input only.
        num_gen_workers: generation processes (default: all CPU cores).
        shard, num_shards: generate only shard ``shard`` of ``num_shards`` into
            ``<root>/<name>.shard-<i>-of-<N>`` (join with :func:`lfd.visuomotor.data.merge_shards`);
            a sharded datamodule cannot be ``setup()``.
        progress: show generation progress.
        train_objects: loading only (not the content): train on the episodes of the first
            this many training objects (:meth:`ReachData.with_train_objects`, statistics
            recomputed on them); ``None`` = all. For data-efficiency grids on one dataset.
    """

    def __init__(
        self,
        name: str = "quick",
        root: str | Path = "data",
        mode: str = "dmp",
        *,
        seed: int = 0,
        n_train_objects: int = 12,
        n_train_placements: int = 16,
        n_test_objects: int = 4,
        n_test_placements: int = 6,
        val_fraction: float = 0.2,
        n_val_objects: int = 0,
        n_val_object_placements: int = 0,
        families: Sequence[str] = SHAPES,
        train_families: Sequence[str] | None = None,
        x_range: Sequence[float] = (0.45, 0.70),
        y_range: Sequence[float] = (-0.30, 0.30),
        yaw_range_deg: Sequence[float] = (-90.0, 90.0),
        image_size: int = 128,
        wrist_camera: bool = False,
        depth: bool = False,
        duration: float = 4.0,
        n_steps: int = 100,
        substeps: int = 10,
        approach_fraction: float = 0.75,
        tolerance: float = 0.01,
        n_basis: int = 20,
        max_attempts: int = 30,
        robot: str = "pr2_right_arm",
        val_sizes: str = "inside",
        sizes: str = "classic",
        lighting: str = "fixed",
        camera_pose: str = "fixed",
        table_texture: str = "plain",
        clutter: int = 0,
        batch_size: int = 32,
        num_workers: int = 0,
        augment: bool = False,
        input_depth: bool | None = None,
        depth_encoding: str = "range",
        num_gen_workers: int | None = None,
        shard: int | None = None,
        num_shards: int = 1,
        progress: bool = True,
        train_objects: int | None = None,
    ) -> None:
        super().__init__()
        if mode not in MODES:
            raise ValueError(f"ReachDataModule.mode: expected one of {sorted(MODES)}, got {mode!r}")
        if not (isinstance(batch_size, int) and batch_size >= 1):
            raise ValueError(f"ReachDataModule.batch_size: expected an int >= 1, got {batch_size!r}")
        self.config = GeneratorConfig(
            seed=seed,
            n_train_objects=n_train_objects,
            n_train_placements=n_train_placements,
            n_test_objects=n_test_objects,
            n_test_placements=n_test_placements,
            val_fraction=val_fraction,
            n_val_objects=n_val_objects,
            n_val_object_placements=n_val_object_placements,
            families=tuple(families),
            train_families=None if train_families is None else tuple(train_families),
            x_range=tuple(x_range),
            y_range=tuple(y_range),
            yaw_range_deg=tuple(yaw_range_deg),
            image_size=image_size,
            wrist_camera=wrist_camera,
            depth=depth,
            duration=duration,
            n_steps=n_steps,
            substeps=substeps,
            approach_fraction=approach_fraction,
            tolerance=tolerance,
            n_basis=n_basis,
            max_attempts=max_attempts,
            robot=robot,
            val_sizes=val_sizes,
            sizes=sizes,
            lighting=lighting,
            camera_pose=camera_pose,
            table_texture=table_texture,
            clutter=clutter,
        )
        self.input_depth = bool(depth if input_depth is None else input_depth)
        if self.input_depth and not depth:
            raise ValueError(
                "ReachDataModule.input_depth: true needs a dataset recorded with depth: true (it has depth: false)"
            )
        if depth_encoding not in DEPTH_ENCODINGS:
            raise ValueError(
                f"ReachDataModule.depth_encoding: expected one of {DEPTH_ENCODINGS}, got {depth_encoding!r}"
            )
        if depth_encoding != "range" and not self.input_depth:
            raise ValueError(
                f"ReachDataModule.depth_encoding: {depth_encoding!r} is an encoding of the depth channel; "
                "the input is RGB (input_depth: false)"
            )
        self.depth_encoding = depth_encoding
        if augment and self.input_depth:
            raise ValueError(
                "ReachDataModule: augment (colour jitter + shifts of RGB images) does not support RGB-D "
                "input (input_depth / depth: true); set augment: false"
            )
        self.name, self.mode = name, mode
        self.path = dataset_dir(root, name, shard, num_shards)
        self.shard, self.num_shards = shard, num_shards
        self.batch_size, self.num_workers, self.augment = batch_size, num_workers, augment
        self.num_gen_workers, self.progress = num_gen_workers, progress
        if train_objects is not None and (
            isinstance(train_objects, bool) or not isinstance(train_objects, int) or train_objects < 1
        ):
            raise ValueError(
                f"ReachDataModule.train_objects: expected null or an int >= 1, got {train_objects!r}"
            )
        self.train_objects = train_objects
        self.data: ReachData | None = None
        self.datasets: dict[str, Dataset] = {}
        self.generation_report: GenerationReport | None = None

    def prepare_data(self) -> None:
        """Generate, resume or verify the dataset (or shard) at :attr:`path`."""
        self.generation_report = generate_dataset(
            self.config,
            self.path,
            num_workers=self.num_gen_workers,
            shard=self.shard,
            num_shards=self.num_shards,
            progress=self.progress,
        )

    def setup(self, stage: str | None = None) -> None:
        """Load and verify the dataset, build the split datasets of :attr:`mode`."""
        if self.shard is not None:
            raise DatasetError(
                f"{self.path} is shard {self.shard} of {self.num_shards}; merge the shards and load the result"
            )
        if self.data is None:
            self.data = load_dataset(self.path, self.config)
            if self.train_objects is not None:
                self.data = self.data.with_train_objects(self.train_objects)
        view = MODES[self.mode]
        augment = image_augmentation(self.config.image_size) if self.augment else None
        wanted = {"fit": ("train", "val"), "validate": ("val",), "test": ("test",), "predict": ("test",)}.get(
            stage or "", ("train", "val", "test")
        )
        for split in wanted:
            if split not in self.datasets and self.data.manifest["episodes"][split] > 0:
                self.datasets[split] = view(
                    self.data,
                    split,
                    augment if split == "train" else None,
                    depth=self.input_depth,
                    depth_encoding=self.depth_encoding,
                )

    def fingerprint(self) -> dict:
        """The loaded dataset's fingerprint (:func:`lfd.visuomotor.data.fingerprint.dataset_fingerprint`),
        which the policies store in their checkpoints."""
        if self.data is None:
            raise RuntimeError("ReachDataModule.fingerprint: call setup() first")
        from lfd.visuomotor.data.fingerprint import dataset_fingerprint

        return dataset_fingerprint(self.data)

    @property
    def stats(self) -> dict[str, dict[str, torch.Tensor]]:
        """Normalisation statistics of the train split (see :class:`ReachData`)."""
        if self.data is None:
            raise RuntimeError("ReachDataModule.stats: call setup() first")
        return self.data.stats

    def _loader(self, split: str, shuffle: bool) -> DataLoader:
        return split_loader(self, split, shuffle)

    def train_dataloader(self) -> DataLoader:
        return self._loader("train", shuffle=True)

    def val_dataloader(self) -> DataLoader:
        return self._loader("val", shuffle=False)

    def test_dataloader(self) -> DataLoader:
        return self._loader("test", shuffle=False)


def split_loader(datamodule, split: str, shuffle: bool) -> DataLoader:
    """The DataLoader of ``datamodule.datasets[split]`` with its ``batch_size`` and ``num_workers``
    (workers persist between epochs), shared by every policy datamodule.

    Raises:
        RuntimeError: the split is not set up (empty, or ``setup()`` not called for it).
    """
    if split not in datamodule.datasets:
        raise RuntimeError(
            f"{type(datamodule).__name__}: split '{split}' is not set up (empty, or setup() not called for it)"
        )
    return DataLoader(
        datamodule.datasets[split],
        batch_size=datamodule.batch_size,
        shuffle=shuffle,
        num_workers=datamodule.num_workers,
        persistent_workers=datamodule.num_workers > 0,
    )
