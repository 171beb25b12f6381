"""Episode plan (which object, which split) and the per-episode ``.npz`` file.

Episode ``i`` of a dataset is fully determined by the generator config, the seed and
``i``: :func:`plan_episodes` fixes its object and split, and the placement is drawn from
``numpy.random.default_rng([seed, PLACEMENT_STREAM, i])`` inside the generator. That is
what makes the bytes independent of the number of worker processes and shards.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lfd.data.config import GeneratorConfig
from lfd.data.storage import DatasetError
from lfd.sim.expert import DISCARD_REASONS
from lfd.sim.objects import ObjectSpec, Placement, sample_objects

SPLITS = ("train", "val", "test")
EPISODE_DIR = "episodes"
# Independent random streams derived from the seed.
TRAIN_OBJECT_STREAM, TEST_OBJECT_STREAM, SPLIT_STREAM, PLACEMENT_STREAM = range(4)


def episode_path(index: int) -> str:
    """Path of episode ``index`` relative to the dataset folder."""
    return f"{EPISODE_DIR}/ep-{index:05d}.npz"


@dataclass(frozen=True)
class EpisodePlan:
    """What episode ``index`` shows: ``obj`` (``object_index`` within its group, the
    training or the test objects), in split ``split``, placement number
    ``placement_index`` of that object."""

    index: int
    split: str
    object_index: int
    placement_index: int
    obj: ObjectSpec


def plan_episodes(cfg: GeneratorConfig) -> list[EpisodePlan]:
    """All episodes, in index order: training objects (object-major, ``n_train_placements``
    each; per object a random ``n_val_placements`` of them are validation), then the test
    objects (new instances of the same families) with ``n_test_placements`` each."""
    rng = np.random.default_rng
    train_objs = sample_objects(rng([cfg.seed, TRAIN_OBJECT_STREAM]), cfg.n_train_objects, cfg.families, prefix="train")
    test_objs = sample_objects(rng([cfg.seed, TEST_OBJECT_STREAM]), cfg.n_test_objects, cfg.families, prefix="test")
    plans: list[EpisodePlan] = []
    for j, obj in enumerate(train_objs):
        val = set(rng([cfg.seed, SPLIT_STREAM, j]).permutation(cfg.n_train_placements)[: cfg.n_val_placements].tolist())
        for k in range(cfg.n_train_placements):
            plans.append(EpisodePlan(len(plans), "val" if k in val else "train", j, k, obj))
    for j, obj in enumerate(test_objs):
        for k in range(cfg.n_test_placements):
            plans.append(EpisodePlan(len(plans), "test", j, k, obj))
    return plans


def placement_rng(cfg: GeneratorConfig, index: int) -> np.random.Generator:
    """The random stream episode ``index`` draws its placements from."""
    return np.random.default_rng([cfg.seed, PLACEMENT_STREAM, index])


@dataclass
class EpisodeRecord:
    """One episode loaded from disk (everything but the image frames).

    Attributes:
        index, split, object_index: from the plan.
        obj, placement: the object and where it stood (torso frame).
        arrays: every numeric array of the file except ``frames``/``wrist_frames``
            (``data/README.md`` lists the keys and shapes).
        path: the ``.npz`` file.
    """

    index: int
    split: str
    object_index: int
    obj: ObjectSpec
    placement: Placement
    arrays: dict[str, np.ndarray]
    path: Path

    @property
    def target_point(self) -> np.ndarray:
        """``(3,)`` grasp target point (torso frame): where the demonstration's tool
        frame ends; evaluation measures the final distance to it."""
        return self.arrays["target_point"]

    def discarded(self) -> dict[str, int]:
        """Discarded attempts before this episode succeeded, by reason."""
        return dict(zip(DISCARD_REASONS, self.arrays["discarded"].tolist(), strict=True))

    def frames(self, key: str = "frames") -> np.ndarray:
        """``(T, H, W, 3)`` uint8 frames (``key="wrist_frames"`` for the wrist camera)."""
        with np.load(self.path, allow_pickle=False) as z:
            if key not in z.files:
                raise DatasetError(f"{self.path}: no '{key}' in the episode file")
            return z[key]

    @classmethod
    def load(cls, path: Path) -> EpisodeRecord:
        """Read an episode file (without decompressing its frames)."""
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files if k not in ("frames", "wrist_frames")}
        except FileNotFoundError as e:
            raise DatasetError(f"missing episode file {path}") from e
        except Exception as e:  # zipfile/numpy raise several types for damaged archives
            raise DatasetError(f"corrupt episode file {path}: {e}") from e
        obj = ObjectSpec(
            shape=str(arrays["object_shape"]),
            dims=tuple(arrays["object_dims"].tolist()),
            rgba=tuple(arrays["object_rgba"].tolist()),
            mass=float(arrays["object_mass"]),
            name=str(arrays["object_name"]),
        )
        x, y, yaw = arrays["placement"].tolist()
        return cls(
            index=int(arrays["index"]),
            split=str(arrays["split"]),
            object_index=int(arrays["object_index"]),
            obj=obj,
            placement=Placement(x, y, yaw),
            arrays=arrays,
            path=Path(path),
        )
