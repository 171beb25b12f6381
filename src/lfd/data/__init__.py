"""Reaching-demonstration datasets: generation, on-disk format, loading, LightningDataModule.

The on-disk format is documented in ``data/README.md``. Typical use::

    from lfd.data import ReachDataModule

    dm = ReachDataModule(name="quick", root="data", mode="dmp", image_size=64)
    dm.prepare_data()        # generate (parallel, resumable) or verify data/quick
    dm.setup("fit")
    batch = next(iter(dm.train_dataloader()))   # image, joints, goal, weights, ...

Lower level: :func:`generate_dataset` (also per shard) and :func:`merge_shards`,
:func:`load_dataset` / :func:`verify_dataset`, the dataset views
:class:`DMPReachDataset` and :class:`VelocityReachDataset`.
"""

from typing import TYPE_CHECKING

from .config import GeneratorConfig
from .datasets import DMPReachDataset, ReachData, VelocityReachDataset, image_augmentation, load_dataset
from .episodes import SPLITS, EpisodePlan, EpisodeRecord, plan_episodes
from .generate import GenerationReport, code_version, dataset_dir, generate_dataset, merge_shards
from .manifest import verify_dataset
from .storage import DatasetError

if TYPE_CHECKING:
    from .datamodule import ReachDataModule

__all__ = [
    "SPLITS",
    "DMPReachDataset",
    "DatasetError",
    "EpisodePlan",
    "EpisodeRecord",
    "GenerationReport",
    "GeneratorConfig",
    "ReachData",
    "ReachDataModule",
    "VelocityReachDataset",
    "code_version",
    "dataset_dir",
    "generate_dataset",
    "image_augmentation",
    "load_dataset",
    "merge_shards",
    "plan_episodes",
    "verify_dataset",
]


def __getattr__(name: str):
    # Lightning is imported on first use of the datamodule only: generation workers, the
    # simulator-side tools and the tests of the dataset format do not need it.
    if name == "ReachDataModule":
        from .datamodule import ReachDataModule

        return ReachDataModule
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
