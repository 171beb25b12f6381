"""A LeRobot v3.0 folder as training data for lfd's policies (:class:`LeRobotDataModule`).

The datamodule serves the item layouts of :class:`~lfd.visuomotor.data.datasets.DMPReachDataset`
(``mode="dmp"``) and :class:`~lfd.visuomotor.data.datasets.VelocityReachDataset`
(``mode="velocity"``) -- the very same classes, fed by episodes read from the folder
(:class:`~lfd.interop.lerobot.reader.LeRobotFolder`):

* joints = the first ``n_joints`` entries of ``observation.state`` (default: the action's
  size), velocity = the next ``n_joints`` entries when the state has them (lfd exports
  and the common ``q, dq`` layout), else the time derivative of the joints;
* DMP parameters from the ``lfd/dmp_*`` episode columns of an lfd export, else fitted
  to each episode's joints (:class:`lfd.dmp.DMP`, ``n_basis`` bases) -- so the CNN -> DMP
  network trains on foreign demonstrations too;
* tool path from ``lfd/ee_path``, else forward kinematics of ``robot_type`` when the
  robot catalogue knows it (needed by ``mode="dmp"`` only);
* splits from ``info.json`` (``"train": "0:500"``...); without a ``val`` split,
  ``round(val_fraction * n_train)`` training episodes spread evenly over them are held out.

Example::

    from lfd.interop import LeRobotDataModule

    dm = LeRobotDataModule("data/quick_s42.lerobot", mode="velocity", batch_size=32)
    dm.setup("fit")
    batch = next(iter(dm.train_dataloader()))    # image, joints, velocity, t, index, step
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from lfd.interop.lerobot.export import CAMERA_ARRAYS
from lfd.interop.lerobot.io import LeRobotDatasetError
from lfd.interop.lerobot.reader import LeRobotFolder, parse_splits, read_info

#: Most bytes of decoded RGB frames the datamodule holds in memory (every frame in ``mode="velocity"``,
#: each episode's first frame in ``mode="dmp"``), checked from ``info.json``'s shapes before decoding.
MAX_IMAGE_BYTES = 16 * 2**30


@dataclass
class LeRobotDataConfig:
    """What lfd's policies check against their hyper-parameters (``check_data``)."""

    image_size: int
    duration: float
    n_steps: int
    robot: str
    depth: bool = False  # the reader serves the RGB video frames


class _Episode:
    """An episode read from a LeRobot folder, shaped like an lfd ``EpisodeRecord`` (the
    parts the dataset views use: ``index``, ``split``, ``arrays``, ``frames()``)."""

    def __init__(
        self, folder: LeRobotFolder, ep: int, split: str, camera: str, arrays: dict, first_only: bool
    ) -> None:
        self.folder, self.ep, self.split, self.camera, self.arrays = folder, ep, split, camera, arrays
        self.index = int(arrays["index"])
        self.first_only = first_only

    def frames(self, key: str = "frames") -> np.ndarray:
        frame_index = np.array([0]) if self.first_only else None
        return self.folder.frames(self.ep, self.camera, frame_index)


class _Data:
    def __init__(self, path: Path, episodes: list[_Episode]) -> None:
        self.path, self.episodes = path, episodes

    def split(self, name: str) -> list[_Episode]:
        return [e for e in self.episodes if e.split == name]


@cache
def _velocity_dataset_class():
    """The velocity item dataset for episodes of any lengths, built on first use so that
    importing this module does not import :mod:`lfd.visuomotor.data` (nor what it loads)."""
    import torch

    from lfd.visuomotor.data.datasets import VelocityReachDataset, command_tensor, mode_labels

    class VelocityDataset(VelocityReachDataset):
        """:class:`~lfd.visuomotor.data.datasets.VelocityReachDataset` items from episodes of any lengths."""

        def __init__(self, data, split: str, transform=None) -> None:
            records = data.split(split)
            if not records:
                raise ValueError(f"{data.path}: split '{split}' is empty")
            self.transform = transform
            self.frames = torch.from_numpy(np.concatenate([r.frames() for r in records]))
            lengths = torch.tensor([len(r.arrays["t"]) for r in records])

            def cat(key):
                return torch.from_numpy(np.concatenate([r.arrays[key] for r in records])).float()

            self.tensors = {
                "joints": cat("joints"),
                "velocity": cat("velocities"),
                "command": command_tensor(records),
                "t": cat("t"),
                "index": torch.tensor([r.index for r in records], dtype=torch.int64).repeat_interleave(
                    lengths
                ),
                "step": torch.cat([torch.arange(int(k), dtype=torch.int64) for k in lengths]),
                **mode_labels(records, lengths),
            }

    return VelocityDataset


def _column(folder: LeRobotFolder, e: int, name: str, size: int | None = None) -> np.ndarray:
    """Episode ``e``'s ``meta/episodes`` column ``name`` as a float64 array, checked: numbers,
    all finite, ``size`` values when given.

    Raises:
        LeRobotDatasetError: one line naming the ``meta/episodes`` file, the column and the episode.
    """
    where = f"{folder.episode_files[e]} episode {e}: {name}"
    try:
        value = np.asarray(folder.episodes[e][name], dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise LeRobotDatasetError(
            f"{where}: expected numbers, got {folder.episodes[e][name]!r:.60}"
        ) from None
    if size is not None and value.size != size:
        raise LeRobotDatasetError(f"{where}: expected {size} values, got {value.size}")
    if not np.isfinite(value).all():
        raise LeRobotDatasetError(f"{where}: not finite (NaN or inf)")
    return value


def _import_lightning():
    import lightning as L

    return L


class LeRobotDataModule(_import_lightning().LightningDataModule):
    """A LeRobot v3.0 folder as a LightningDataModule for lfd's policies.

    Args:
        root: dataset folder.
        mode: ``"dmp"`` (one item per episode; equal episode lengths) or ``"velocity"``
            (one item per frame).
        camera: camera name (feature ``observation.images.<camera>``; default: the first video feature).
        n_joints: arm joints (default: the action's size).
        n_basis: DMP bases: must match the ``lfd/n_basis`` column when the folder has DMP
            columns; the number fitted otherwise (None: the column's, or 20).
        val_fraction: held-out share of the training episodes when ``info.json`` has no ``val`` split.
        batch_size, num_workers, augment: as :class:`~lfd.visuomotor.data.ReachDataModule`.
        tolerance_s: timestamp tolerance of the video decoding.
        image_size, duration, n_steps, robot: expected values (the model configs read them
            from ``data.*``); each given one must equal the folder's (square image side,
            ``(T - 1) / fps``, longest episode ``T``, ``robot_type``), else ``ValueError``.
        depth: must be False (RGB only); the model configs read ``data.depth``.
    """

    def __init__(
        self,
        root: str | Path,
        mode: str = "dmp",
        *,
        camera: str | None = None,
        n_joints: int | None = None,
        n_basis: int | None = None,
        val_fraction: float = 0.2,
        batch_size: int = 32,
        num_workers: int = 0,
        augment: bool = False,
        tolerance_s: float = 1e-4,
        image_size: int | None = None,
        duration: float | None = None,
        n_steps: int | None = None,
        robot: str | None = None,
        depth: bool = False,
    ) -> None:
        super().__init__()
        if depth:
            raise ValueError(
                "LeRobotDataModule.depth: the reader serves RGB video frames only; set depth: false"
            )
        self.expected = {"image_size": image_size, "duration": duration, "n_steps": n_steps, "robot": robot}
        from lfd.visuomotor.data.datamodule import MODES

        if mode not in MODES:
            raise ValueError(f"LeRobotDataModule.mode: expected one of {sorted(MODES)}, got {mode!r}")
        if not 0 <= val_fraction < 1:
            raise ValueError(f"LeRobotDataModule.val_fraction: expected 0 <= x < 1, got {val_fraction}")
        self.root, self.mode, self.camera = Path(root), mode, camera
        self.n_joints, self.n_basis, self.val_fraction = n_joints, n_basis, val_fraction
        self.batch_size, self.num_workers, self.augment, self.tolerance_s = (
            batch_size,
            num_workers,
            augment,
            tolerance_s,
        )
        self.folder: LeRobotFolder | None = None
        self.data: _Data | None = None
        self.config: LeRobotDataConfig | None = None
        self._stats = None
        self.datasets: dict = {}

    def prepare_data(self) -> None:
        """Check the folder (version, features) early; nothing is generated."""
        read_info(self.root)

    # ------------------------------------------------------------------ loading
    def _splits(self, folder: LeRobotFolder) -> dict[int, str]:
        splits = parse_splits(folder.info.get("splits") or {"train": f"0:{len(folder)}"}, len(folder))
        split_of = {}
        for name, eps in splits.items():
            for e in eps:
                split_of[e] = {"validation": "val"}.get(name, name)
        train = [e for e, s in sorted(split_of.items()) if s == "train"]
        if "val" not in split_of.values() and self.val_fraction > 0 and len(train) >= 2:
            n_val = max(1, round(self.val_fraction * len(train)))
            for k in np.round(np.linspace(0, len(train) - 1, n_val + 2)[1:-1]).astype(int):
                split_of[train[k]] = "val"
        return split_of

    def _load(self) -> None:
        from lfd.dmp import DMP

        folder = LeRobotFolder(self.root, self.tolerance_s)
        key = (
            f"observation.images.{self.camera}"
            if self.camera
            else (folder.video_keys[0] if folder.video_keys else None)
        )
        if key is None or key not in folder.video_keys:
            raise ValueError(f"{self.root}: no video feature {key!r}; it has {folder.video_keys}")
        h, w = folder.features[key]["shape"][:2]
        if h != w:
            raise ValueError(f"{self.root}: lfd's policies take square images, {key} is {h}x{w}")
        n_images = len(folder) if self.mode == "dmp" else len(folder.data["index"])
        if n_images * h * w * 3 > MAX_IMAGE_BYTES:
            raise LeRobotDatasetError(
                f"{self.root}: mode={self.mode!r} holds {n_images} images of {key} ({h}x{w}) in memory, "
                f"{n_images * h * w * 3 / 2**30:.1f} GiB, more than lfd loads ({MAX_IMAGE_BYTES / 2**30:.0f} GiB)"
            )
        state, action = folder.data["observation.state"], folder.data["action"]
        n = self.n_joints or action.shape[1]
        if state.shape[1] < n:
            raise ValueError(
                f"{self.root}: observation.state has {state.shape[1]} entries, fewer than n_joints={n}"
            )
        robot_type = folder.info.get("robot_type") or ""
        split_of = self._splits(folder)
        lengths = [r["length"] for r in folder.episodes]
        if self.mode == "dmp" and len(set(lengths)) != 1:
            raise ValueError(
                f"{self.root}: mode='dmp' needs equal episode lengths, got {min(lengths)}..{max(lengths)} frames"
            )
        fk = None
        episodes = []
        for e, row in enumerate(folder.episodes):
            sl = folder.episode_slice(e)
            t = folder.data["frame_index"][sl].astype(np.float64) / folder.fps
            joints = state[sl, :n].astype(np.float64)
            if state.shape[1] >= 2 * n:
                vel = state[sl, n : 2 * n].astype(np.float64)
            else:
                vel = np.gradient(joints, t, axis=0) if len(t) > 1 else np.zeros_like(joints)
            arrays = {"joints": joints, "velocities": vel, "t": t, "index": row.get("lfd/index", e)}
            if "lfd/approach_mode" in row:  # our own export: the training-only mode label survives
                arrays["approach_mode"] = np.str_(row["lfd/approach_mode"])
            for name in CAMERA_ARRAYS:  # our own export: the camera that labels the target's pixel
                if f"lfd/{name}" in row:
                    arrays[name] = _column(folder, e, f"lfd/{name}", 16).reshape(4, 4)
            if self.mode == "dmp":
                if "lfd/dmp_goal" in row:
                    k = row.get("lfd/n_basis")
                    if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= 10_000:
                        raise LeRobotDatasetError(
                            f"{folder.episode_files[e]} episode {e}: lfd/n_basis expected an integer in "
                            f"[1, 10000], got {k!r:.40}"
                        )
                    if self.n_basis is not None and self.n_basis != k:
                        raise ValueError(
                            f"LeRobotDataModule.n_basis={self.n_basis}, but {self.root} holds DMPs with {k} bases"
                        )
                    tau = _column(folder, e, "lfd/dmp_tau", 1)
                    if tau[0] <= 0:
                        raise LeRobotDatasetError(
                            f"{folder.episode_files[e]} episode {e}: lfd/dmp_tau expected > 0, got {tau[0]}"
                        )
                    arrays.update(
                        dmp_goal=_column(folder, e, "lfd/dmp_goal", n),
                        dmp_weights=_column(folder, e, "lfd/dmp_weights", n * k).reshape(n, k),
                        dmp_y0=_column(folder, e, "lfd/dmp_y0", n),
                        dmp_tau=np.float64(tau[0]),
                    )
                else:
                    dmp = DMP(n_basis=self.n_basis or 20).fit(t, joints)
                    arrays.update(
                        dmp_goal=dmp.goal_,
                        dmp_weights=dmp.weights_,
                        dmp_y0=dmp.y0_,
                        dmp_tau=np.float64(dmp.tau_),
                    )
                if "lfd/ee_path" in row:
                    ee = _column(folder, e, "lfd/ee_path", 3 * len(t)).reshape(-1, 3)
                else:
                    fk = fk or _fk(robot_type, self.root)
                    ee = fk(joints)
                poses = np.tile(np.eye(4), (len(ee), 1, 1))
                poses[:, :3, 3] = ee
                arrays["ee_poses"] = poses
                arrays["target_point"] = (
                    _column(folder, e, "lfd/target_point", 3) if "lfd/target_point" in row else ee[-1]
                )
            else:
                arrays["target_point"] = (
                    _column(folder, e, "lfd/target_point", 3) if "lfd/target_point" in row else np.zeros(3)
                )
                arrays["dmp_goal"], arrays["dmp_weights"] = joints[-1], np.zeros((n, 1))
            episodes.append(
                _Episode(folder, e, split_of.get(e, "train"), key, arrays, first_only=self.mode == "dmp")
            )
        self.folder, self.data = folder, _Data(self.root, episodes)
        T = max(lengths)
        self.config = LeRobotDataConfig(
            image_size=int(h), duration=(T - 1) / folder.fps, n_steps=int(T), robot=robot_type
        )
        for key, want in self.expected.items():
            have = getattr(self.config, key)
            if want is not None and (
                have != want if isinstance(want, str) else not np.isclose(have, want, rtol=1e-9, atol=0)
            ):
                raise ValueError(
                    f"LeRobotDataModule.{key}={want!r}, but the dataset {self.root} has {key}={have!r}"
                )

    def setup(self, stage: str | None = None) -> None:
        """Read the folder and build the split datasets of :attr:`mode`."""
        from lfd.visuomotor.data.datamodule import MODES
        from lfd.visuomotor.data.datasets import image_augmentation
        from lfd.visuomotor.data.stats import STD_FLOOR, compute_stats

        if self.data is None:
            self._load()
            train = self.data.split("train")
            if not train:
                raise ValueError(f"{self.root}: the train split is empty")
            if self.mode == "dmp":
                stats = compute_stats(train)
            else:  # episodes may differ in length here: per-step statistics over all frames
                stats = {}
                for name, key in (("joints", "joints"), ("velocity", "velocities")):
                    v = np.concatenate([e.arrays[key] for e in train])
                    stats[name] = {"mean": v.mean(axis=0), "std": np.maximum(v.std(axis=0), STD_FLOOR)}
            import torch

            self._stats = {
                name: {
                    k: torch.tensor(v, dtype=torch.float32) for k, v in entry.items() if k in ("mean", "std")
                }
                for name, entry in stats.items()
            }
        view = MODES[self.mode] if self.mode == "dmp" else _velocity_dataset_class()
        augment = image_augmentation(self.config.image_size) if self.augment else None
        wanted = {"fit": ("train", "val"), "validate": ("val",), "test": ("test",), "predict": ("test",)}.get(
            stage or "", ("train", "val", "test")
        )
        for split in wanted:
            if split not in self.datasets and self.data.split(split):
                self.datasets[split] = view(self.data, split, augment if split == "train" else None)

    @property
    def stats(self):
        """Normalisation statistics of the train split (as :attr:`lfd.visuomotor.data.ReachDataModule.stats`)."""
        if self._stats is None:
            raise RuntimeError("LeRobotDataModule.stats: call setup() first")
        return self._stats

    def _loader(self, split: str, shuffle: bool):
        from lfd.visuomotor.data.datamodule import split_loader

        return split_loader(self, split, shuffle)

    def train_dataloader(self):
        return self._loader("train", shuffle=True)

    def val_dataloader(self):
        return self._loader("val", shuffle=False)

    def test_dataloader(self):
        return self._loader("test", shuffle=False)


def _fk(robot_type: str, root: Path):
    """Tool positions ``(T, 3)`` from joints ``(T, n)`` by the catalogue robot ``robot_type``."""
    import torch

    from lfd.robots import load_robot

    try:
        robot = load_robot(robot_type)
    except (KeyError, ValueError) as e:
        raise ValueError(
            f"{root}: mode='dmp' needs tool paths: no 'lfd/ee_path' episode column and robot_type {robot_type!r} "
            f"is not in lfd's robot catalogue ({e})"
        ) from e

    def fk(joints: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return robot.fk(torch.as_tensor(joints, dtype=torch.float64))[:, :3, 3].numpy()

    return fk
