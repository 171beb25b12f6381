"""``MetaWorldDataModule``: Meta-World expert demonstrations for the visuomotor policies.

Items are those of the reaching datasets (:class:`lfd.visuomotor.data.DMPReachDataset`,
:class:`lfd.visuomotor.data.VelocityReachDataset`) with the 4-D robot state of
:mod:`lfd.metaworld` in place of the joint angles ("joints" below), so every registered policy
trains on them unchanged:

* ``"dmp"`` (one item per demonstration): ``image`` (first frame), ``joints`` (start state),
  ``goal``, ``weights``, ``y0``, ``tau``, ``t``, ``trajectory`` ``(T, 4)``, ``ee_path`` ``(T, 3)``
  (the hand path), ``index``, ``placement`` ``(PLACEMENT_SIZE,)`` (the episode's placement:
  the task's random reset vector of object and goal positions, m, zero-padded; a training-only
  label for ``CNNDMPPolicy(placement_dim=...)``), ``placement_pixels`` ``(PLACEMENT_SIZE // 3 * 2,)``
  (where each of the placement's 3-D points, object and goal, appears in the first image: pixels
  ``u, v`` of :meth:`lfd.metaworld.MetaWorldTask.project`; NaN for padding; a training-only label
  for the policies' ``keypoint_weight``).
* ``"velocity"`` (one item per step): ``image``, ``joints``, ``velocity`` and ``command`` (the
  state's change per second over the next step), ``t``, ``index``, ``step``.
"""

from __future__ import annotations

from pathlib import Path

import lightning as L
import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset

from lfd.checks import check_int
from lfd.visuomotor.data.datasets import command_velocities, image_augmentation
from lfd.visuomotor.metaworld.demos import (
    MetaWorldData,
    MetaWorldDataConfig,
    generate_demonstrations,
    load_demonstrations,
)
from lfd.visuomotor.protocols import ITEM_MODES

__all__ = ["PLACEMENT_SIZE", "MetaWorldDMPDataset", "MetaWorldDataModule", "MetaWorldVelocityDataset"]

#: Entries of the served ``placement``: Meta-World's random reset vectors have 3 (an object's
#: position) or 6 (an object's and a goal's) entries in all 50 v3 tasks; shorter ones are
#: zero-padded, so one policy configuration fits every task.
PLACEMENT_SIZE = 6
#: m: the smallest spread ``stats["placement"]["std"]`` gives an entry (a coordinate a task
#: never varies, e.g. a puck's height, or padding), so that normalising it stays finite.
MIN_PLACEMENT_STD = 0.01


def padded_placement(placement, where: str = "the placement") -> np.ndarray:
    """``(PLACEMENT_SIZE,)`` m: a task's placement vector (e.g. ``MetaWorldTask.placement``), zero-padded.

    Raises:
        ValueError: a placement longer than :data:`PLACEMENT_SIZE` (one line naming ``where``).
    """
    p = np.asarray(placement, dtype=np.float64).ravel()
    if p.size > PLACEMENT_SIZE:
        raise ValueError(f"placement: at most {PLACEMENT_SIZE} entries expected, {where} has {p.size}")
    return np.pad(p, (0, PLACEMENT_SIZE - p.size))


def placement_pixels(config: MetaWorldDataConfig, eps) -> np.ndarray:
    """``(E, PLACEMENT_SIZE // 3 * 2)`` px: where each 3-D point of the episodes' placements (the
    object's and the goal's position) appears in their images, ``u, v`` per point
    (:meth:`lfd.metaworld.MetaWorldTask.project`, the dataset's camera); NaN for the zero padding
    of a shorter placement. The camera is fixed, so one reset of the task gives its pose."""
    from lfd.metaworld.env import MetaWorldTask, placement_seed

    out = np.full((len(eps), PLACEMENT_SIZE // 3 * 2), np.nan)
    with MetaWorldTask(
        config.task, image_size=config.image_size, camera=config.camera, fovy=config.camera_fovy
    ) as task:
        task.reset(placement_seed(config.seed, "train", 0))
        for i, e in enumerate(eps):
            p = np.asarray(e.arrays["placement"], dtype=np.float64).ravel()
            n = p.size // 3
            out[i, : 2 * n] = task.project(p[: 3 * n].reshape(n, 3)).ravel()
    return out


def placements(eps) -> np.ndarray:
    """``(E, PLACEMENT_SIZE)`` m: the episodes' placements, zero-padded (:func:`padded_placement`).

    Raises:
        ValueError: a placement longer than :data:`PLACEMENT_SIZE`.
    """
    out = np.zeros((len(eps), PLACEMENT_SIZE))
    for i, e in enumerate(eps):
        out[i] = padded_placement(e.arrays["placement"], f"episode {e.index}")
    return out


def _image(frame: torch.Tensor) -> torch.Tensor:
    return frame.permute(2, 0, 1).float().div_(255.0)


def _index(split: str, i: int) -> int:
    """Episode index across splits (train ``i``, validation ``100000 + i``)."""
    return i if split == "train" else 100_000 + i


class MetaWorldDMPDataset(Dataset):
    """One item per demonstration of ``split`` (module docstring).

    Args:
        data, split: the dataset and split.
        transform: applied to every item's float image (training augmentation), or None.
        frames: the item's image is frame 0 (``1``, the default), or a random one of the first
            ``frames`` frames of the episode, drawn per item access (training only: the arm has
            moved a little, the objects not yet; the DMP and the start state stay the episode's).
        pixels: ``(E, PLACEMENT_SIZE // 3 * 2)`` the split's :func:`placement_pixels`, served as
            ``placement_pixels`` (None: not served).
    """

    def __init__(
        self,
        data: MetaWorldData,
        split: str,
        transform=None,
        frames: int = 1,
        pixels: np.ndarray | None = None,
    ) -> None:
        eps = data.split(split)
        self.frames = torch.from_numpy(np.stack([e.frames[:frames] for e in eps]))
        self.transform, self.window = transform, frames

        def stack(key):
            return torch.from_numpy(np.stack([e.arrays[key] for e in eps])).float()

        states = stack("states")
        self.tensors = {
            "joints": states[:, 0],
            "goal": stack("dmp_goal"),
            "weights": stack("dmp_weights"),
            "y0": stack("dmp_y0"),
            "tau": stack("dmp_tau"),
            "t": stack("t"),
            "trajectory": states,
            "ee_path": states[..., :3],
            "index": torch.tensor([_index(split, e.index) for e in eps], dtype=torch.int64),
            "placement": torch.from_numpy(placements(eps)).float(),
        }
        if pixels is not None:
            self.tensors["placement_pixels"] = torch.from_numpy(np.asarray(pixels)).float()

    def __len__(self) -> int:
        return self.frames.shape[0]

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        step = int(torch.randint(self.window, ())) if self.window > 1 else 0
        image = _image(self.frames[i, step])
        if self.transform is not None:
            image = self.transform(image)
        return {**{k: v[i] for k, v in self.tensors.items()}, "image": image}


class MetaWorldVelocityDataset(Dataset):
    """One item per step of every demonstration of ``split`` (module docstring)."""

    def __init__(self, data: MetaWorldData, split: str, transform=None) -> None:
        eps = data.split(split)
        self.transform = transform
        steps = eps[0].states.shape[0]
        self.frames = torch.from_numpy(np.concatenate([e.frames for e in eps]))
        command = np.concatenate([command_velocities(e.states, e.arrays["t"]) for e in eps])
        self.tensors = {
            "joints": torch.from_numpy(np.concatenate([e.states for e in eps])).float(),
            "velocity": torch.from_numpy(command).float(),
            "command": torch.from_numpy(command).float(),
            "t": torch.from_numpy(np.concatenate([e.arrays["t"] for e in eps])).float(),
            "index": torch.tensor([_index(split, e.index) for e in eps], dtype=torch.int64).repeat_interleave(
                steps
            ),
            "step": torch.arange(steps, dtype=torch.int64).repeat(len(eps)),
        }

    def __len__(self) -> int:
        return self.frames.shape[0]

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        image = _image(self.frames[i])
        if self.transform is not None:
            image = self.transform(image)
        return {**{k: v[i] for k, v in self.tensors.items()}, "image": image}


MODES = dict(zip(ITEM_MODES, (MetaWorldDMPDataset, MetaWorldVelocityDataset), strict=True))


class MetaWorldDataModule(L.LightningDataModule):
    """Expert demonstrations of one Meta-World task (:mod:`lfd.visuomotor.metaworld.demos`).

    ``prepare_data()`` generates ``<root>/<name>`` if missing, resumes it if unfinished and
    verifies it otherwise; ``setup()`` serves the train and validation splits in the item layout
    of ``mode`` (module docstring).

    Args:
        task, seed, n_train, n_val, image_size, camera, camera_fovy, n_steps, n_basis, max_attempts: the
            content (:class:`~lfd.visuomotor.metaworld.demos.MetaWorldDataConfig`).
        name, root: the dataset folder ``<root>/<name>``.
        mode: ``"dmp"`` or ``"velocity"`` (the policy's ``item_mode``; ``train.py`` passes it).
        batch_size, num_workers: DataLoader settings.
        train_episodes: train on the first this many train episodes only (None: all), for
            data-efficiency studies on one dataset; statistics are recomputed on them.
        augment: colour jitter and random shifts of up to 4 px of the training images
            (:func:`lfd.visuomotor.data.datasets.image_augmentation`), every policy kind.
        dmp_frames: ``"dmp"`` items only: a training item's image is one of the first
            ``dmp_frames`` frames of its episode, drawn anew every time (1: the first frame;
            None: any frame of the episode).
        progress: show the generation progress bar.
        n_joints, control_dt, depth, robot: fixed facts (4, 0.0125 s, False, None) that the data
            config states for the policies (``data_arguments``); any other value is refused.

    Raises:
        ValueError: a bad setting (one line naming it).
    """

    input_depth = False
    depth_encoding = "range"

    def __init__(
        self,
        task: str,
        name: str | None = None,
        root: str | Path = "data",
        mode: str = "dmp",
        *,
        seed: int = 0,
        n_train: int = 50,
        n_val: int = 10,
        image_size: int = 96,
        camera: str = "corner",
        camera_fovy: float | None = None,
        n_steps: int = 150,
        n_basis: int = 20,
        max_attempts: int = 5,
        batch_size: int = 32,
        num_workers: int = 0,
        train_episodes: int | None = None,
        augment: bool = False,
        dmp_frames: int | None = 1,
        progress: bool = True,
        n_joints: int = 4,
        control_dt: float | None = None,
        depth: bool = False,
        robot: str | None = None,
    ) -> None:
        super().__init__()
        if mode not in MODES:
            raise ValueError(f"data.mode must be one of {', '.join(MODES)}, got {mode!r}")
        self.config = MetaWorldDataConfig(
            task=task,
            seed=seed,
            n_train=n_train,
            n_val=n_val,
            image_size=image_size,
            camera=camera,
            camera_fovy=camera_fovy,
            n_steps=n_steps,
            n_basis=n_basis,
            max_attempts=max_attempts,
        )
        fixed = {
            "control_dt": (control_dt, self.config.control_dt),
            "depth": (depth, False),
            "robot": (robot, None),
        }
        for key, (given, value) in fixed.items():
            if given is not None and given != value:
                raise ValueError(
                    f"data.{key} is {value!r} for Meta-World (fixed by the simulator), got {given!r}"
                )
        if n_joints != MetaWorldDataConfig.n_joints:
            raise ValueError(
                f"data.n_joints must be {MetaWorldDataConfig.n_joints} (hand xyz, gripper), got {n_joints!r}"
            )
        check_int(batch_size, "data.batch_size", minimum=1)
        check_int(num_workers, "data.num_workers", minimum=0)
        check_int(train_episodes, "data.train_episodes", minimum=1, optional=True)
        if train_episodes is not None and train_episodes > n_train:
            raise ValueError(
                f"data.train_episodes must be at most data.n_train={n_train}, got {train_episodes}"
            )
        check_int(dmp_frames, "data.dmp_frames", minimum=1, optional=True)
        if dmp_frames is None:
            dmp_frames = n_steps
        if dmp_frames > n_steps:
            raise ValueError(f"data.dmp_frames must be at most data.n_steps={n_steps}, got {dmp_frames}")
        if not isinstance(augment, bool):
            raise ValueError(f"data.augment must be true or false, got {augment!r}")
        self.augment, self.dmp_frames = augment, dmp_frames
        self.mode, self.batch_size, self.num_workers = mode, batch_size, num_workers
        self.train_episodes, self.progress = train_episodes, progress
        self.path = Path(root) / (name or f"metaworld_{task}_n{n_train}_s{seed}")
        self.data: MetaWorldData | None = None
        self.datasets: dict[str, Dataset] = {}

    def prepare_data(self) -> None:
        generate_demonstrations(self.config, self.path, progress=self.progress)

    def setup(self, stage: str | None = None) -> None:
        if self.data is None:
            data = load_demonstrations(self.path, self.config)
            if self.train_episodes is not None:
                data = data.with_train_episodes(self.train_episodes)
            self.data = data
        augment = image_augmentation(self.config.image_size) if self.augment else None
        if self.mode == "dmp":
            # the pixel labels are those of the unshifted images: not served with the shifts
            pixels = {"train": None, "val": None}
            if augment is None:  # one task (one camera pose) for both splits
                n_train = len(self.data.split("train"))
                both = placement_pixels(self.config, [*self.data.split("train"), *self.data.split("val")])
                pixels = {"train": both[:n_train], "val": both[n_train:]}
            train = MetaWorldDMPDataset(
                self.data, "train", augment, frames=self.dmp_frames, pixels=pixels["train"]
            )
            val = MetaWorldDMPDataset(self.data, "val", pixels=pixels["val"])
        else:
            train = MetaWorldVelocityDataset(self.data, "train", augment)
            val = MetaWorldVelocityDataset(self.data, "val")
        self.datasets = {"train": train, "val": val}

    @property
    def stats(self) -> dict[str, dict[str, torch.Tensor]]:
        if self.data is None:
            raise RuntimeError("MetaWorldDataModule.stats: call setup() first")
        out = {k: {m: torch.as_tensor(v[m]) for m in ("mean", "std")} for k, v in self.data.stats.items()}
        train = placements(self.data.split("train"))
        out["placement"] = {
            "mean": torch.as_tensor(train.mean(0)),
            "std": torch.as_tensor(np.maximum(train.std(0), MIN_PLACEMENT_STD)),
        }
        return out

    @property
    def background(self) -> torch.Tensor:
        """The per-pixel median of the training episodes' first images ``(3, H, W)`` in [0, 1]:
        the fixed camera's scene without what each episode placed (policies'
        ``subtract_background``)."""
        if self.data is None:
            raise RuntimeError("MetaWorldDataModule.background: call setup() first")
        first = np.stack([e.frames[0] for e in self.data.split("train")])
        return _image(torch.from_numpy(np.median(first, axis=0)))

    def fingerprint(self) -> dict:
        if self.data is None:
            raise RuntimeError("MetaWorldDataModule.fingerprint: call setup() first")
        return self.data.fingerprint()

    def _loader(self, split: str, shuffle: bool) -> DataLoader:
        return DataLoader(
            self.datasets[split],
            batch_size=self.batch_size,
            shuffle=shuffle,
            num_workers=self.num_workers,
            persistent_workers=self.num_workers > 0,
        )

    def train_dataloader(self) -> DataLoader:
        return self._loader("train", True)

    def val_dataloader(self) -> DataLoader:
        return self._loader("val", False)
