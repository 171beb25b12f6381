"""Reaching-demonstration datasets: generation, on-disk format, loading, LightningDataModule.

The on-disk format is documented in ``data/README.md``. Typical use::

    from lfd.visuomotor.data import ReachDataModule

    dm = ReachDataModule(name="quick", root="data", mode="dmp", image_size=64)
    dm.prepare_data()        # generate (parallel, resumable) or verify data/quick
    dm.setup("fit")
    batch = next(iter(dm.train_dataloader()))   # image, joints, goal, weights, ...

Lower level: :func:`generate_dataset` (also per shard) and :func:`merge_shards`,
:func:`load_dataset` / :func:`verify_dataset`, the dataset views
:class:`DMPReachDataset` and :class:`VelocityReachDataset`. The Sawyer models' data
(forward-kinematics samples, demonstrations, inverse-model paths) is in :mod:`lfd.model_reaching.data`.

Names are loaded on first use (PEP 562): Lightning and PyBullet are imported only by the
modules that need them, so e.g. ``import lfd.model_reaching.data`` works without PyBullet.
"""

from typing import TYPE_CHECKING

from lfd._lazy import exports, lazy_getattr

_EXPORTS = exports(
    {
        "config": ["GeneratorConfig"],
        "datamodule": ["ReachDataModule"],
        "datasets": [
            "DMPReachDataset",
            "ReachData",
            "VelocityReachDataset",
            "image_augmentation",
            "load_dataset",
        ],
        "episodes": ["SPLITS", "EpisodePlan", "EpisodeRecord", "plan_episodes"],
        "generate": ["GenerationReport", "code_version", "dataset_dir", "generate_dataset", "merge_shards"],
        "manifest": ["verify_dataset"],
        "lfd.io.files": ["DatasetError"],
    }
)
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_getattr(__name__, _EXPORTS)

if TYPE_CHECKING:
    from lfd.io.files import DatasetError

    from .config import GeneratorConfig
    from .datamodule import ReachDataModule
    from .datasets import DMPReachDataset, ReachData, VelocityReachDataset, image_augmentation, load_dataset
    from .episodes import SPLITS, EpisodePlan, EpisodeRecord, plan_episodes
    from .generate import GenerationReport, code_version, dataset_dir, generate_dataset, merge_shards
    from .manifest import verify_dataset
