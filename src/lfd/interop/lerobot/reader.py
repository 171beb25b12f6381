"""Reading LeRobot v3.0 datasets: :func:`read_info` (checked ``meta/info.json``) and
:class:`LeRobotFolder` (episode metadata, tasks, the frame table and video frames).

Frames are decoded with PyAV at ``from_timestamp + frame_index / fps`` in the episode's
video file (lerobot's own rule), each within ``tolerance_s`` of a decoded frame's time.
Every file is looked up inside the dataset folder only: ``data_path`` / ``video_path``
templates and files (symbolic links included) that lead elsewhere are refused
(:mod:`~lfd.interop.lerobot.paths`), as are corrupt JSON and parquet files, each with one
line naming the field or file.
:class:`~lfd.interop.lerobot.datamodule.LeRobotDataModule` trains lfd's policies on a folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from lfd.interop.lerobot.io import read_json, read_parquet_columns, read_table, read_tasks
from lfd.interop.lerobot.paths import CODEBASE_VERSION, check_template, dataset_file
from lfd.io.video import decode_video_frames

REQUIRED_INFO = ("codebase_version", "fps", "total_episodes", "total_frames", "features", "data_path")
#: Columns of ``meta/episodes`` this reader needs (video columns are looked up per camera).
EPISODE_COLUMNS = (
    "episode_index",
    "data/chunk_index",
    "data/file_index",
    "dataset_from_index",
    "dataset_to_index",
)
REQUIRED_FEATURES = (
    "observation.state",
    "action",
    "timestamp",
    "frame_index",
    "episode_index",
    "index",
    "task_index",
)


def read_info(root: str | Path) -> dict[str, Any]:
    """``meta/info.json`` of a v3.0 dataset, checked: the version must be ``"v3.0"``, every
    required key and frame feature present, ``data_path`` / ``video_path`` relative
    templates inside the folder (:func:`~lfd.interop.lerobot.paths.check_template`).

    Raises:
        FileNotFoundError: no folder or no ``meta/info.json``.
        ValueError: corrupt JSON, another ``codebase_version``, a missing key / feature, or a
            path template leading outside the folder.
    """
    root = Path(root)
    path = root / "meta" / "info.json"
    if not root.is_dir():
        raise FileNotFoundError(f"LeRobot dataset folder {root} not found")
    if not path.is_file():
        raise FileNotFoundError(f"{root} is no LeRobot dataset: {path} not found")
    info = read_json(dataset_file(root, "file", "meta/info.json"))
    if not isinstance(info, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(info).__name__}")
    version = info.get("codebase_version")
    if version != CODEBASE_VERSION:
        raise ValueError(
            f"{path}: codebase_version is {version!r}; this reader reads LeRobot {CODEBASE_VERSION!r} only "
            "(convert older datasets with lerobot's convert_dataset_v21_to_v30)"
        )
    missing = [k for k in REQUIRED_INFO if k not in info]
    if missing:
        raise ValueError(f"{path}: missing keys {missing}")
    if not isinstance(info["features"], dict):
        raise ValueError(f"{path} features: expected an object, got {type(info['features']).__name__}")
    missing = [k for k in REQUIRED_FEATURES if k not in info["features"]]
    if missing:
        raise ValueError(f"{path}: missing features {missing}; it has {sorted(info['features'])}")
    check_template(path, "data_path", info["data_path"])
    if info.get("video_path") is not None or any(
        isinstance(f, dict) and f.get("dtype") == "video" for f in info["features"].values()
    ):
        check_template(path, "video_path", info.get("video_path"))
    return info


def parse_splits(splits: dict[str, str], n_episodes: int) -> dict[str, list[int]]:
    """``{"train": "0:40", "val": "40:50"}`` -> episode index lists (ranges checked)."""
    out = {}
    for name, spec in splits.items():
        try:
            a, b = (int(x) for x in str(spec).split(":"))
        except ValueError as e:
            raise ValueError(f"info.json splits.{name}: expected 'start:end', got {spec!r}") from e
        if not 0 <= a <= b <= n_episodes:
            raise ValueError(f"info.json splits.{name}: range {spec!r} outside 0:{n_episodes}")
        out[name] = list(range(a, b))
    return out


class LeRobotFolder:
    """A v3.0 dataset folder in memory: ``info``, ``episodes`` (one dict per episode,
    every column of ``meta/episodes``), ``tasks`` (strings by task index) and the frame
    table ``data`` (column -> ``(N, ...)`` array, rows in ``index`` order).

    Args:
        root: dataset folder.
        tolerance_s: allowed gap between a requested timestamp and a decoded frame.
    """

    def __init__(self, root: str | Path, tolerance_s: float = 1e-4) -> None:
        self.root = Path(root)
        self.info = read_info(self.root)
        self.fps = float(self.info["fps"])
        self.tolerance_s = tolerance_s
        self.features = self.info["features"]
        self.video_keys = [k for k, f in self.features.items() if f.get("dtype") == "video"]
        ep_files = sorted((self.root / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
        if not ep_files:
            raise FileNotFoundError(f"{self.root}: no meta/episodes/chunk-*/file-*.parquet")
        rows = []
        for f in ep_files:
            table = read_table(dataset_file(self.root, "file", f.relative_to(self.root)))
            missing = [c for c in EPISODE_COLUMNS if c not in table.column_names]
            if missing:
                raise ValueError(f"{f}: missing columns {missing}")
            rows += table.to_pylist()
        rows.sort(key=lambda r: r["episode_index"])
        if [r["episode_index"] for r in rows] != list(range(self.info["total_episodes"])):
            raise ValueError(
                f"{self.root}: meta/episodes holds {len(rows)} episodes, info.json says {self.info['total_episodes']}"
            )
        self.episodes = rows
        tasks_path = self.root / "meta" / "tasks.parquet"
        if not tasks_path.is_file():
            raise FileNotFoundError(f"{self.root}: meta/tasks.parquet not found")
        self.tasks = read_tasks(dataset_file(self.root, "file", "meta/tasks.parquet"))
        data_files = sorted(
            {
                self._file("data_path", chunk_index=r["data/chunk_index"], file_index=r["data/file_index"])
                for r in rows
            }
        )
        for f in data_files:
            if not f.is_file():
                raise FileNotFoundError(f"{self.root}: data file {f} (listed in meta/episodes) not found")
        self.data = read_parquet_columns(data_files)
        missing = [k for k in REQUIRED_FEATURES if k not in self.data]
        if missing:
            raise ValueError(f"{self.root}: data parquet lacks columns {missing}")
        order = np.argsort(self.data["index"], kind="stable")
        self.data = {k: v[order] for k, v in self.data.items()}
        if len(self.data["index"]) != self.info["total_frames"]:
            raise ValueError(
                f"{self.root}: {len(self.data['index'])} frames in data/, info.json says {self.info['total_frames']}"
            )

    def _file(self, field: str, **values) -> Path:
        """The file that ``info.json``'s template ``field`` names for ``values``, inside the folder."""
        template = self.info[field]
        try:
            rel = template.format(**values)
        except (ValueError, TypeError) as e:  # e.g. a string where {chunk_index:03d} wants an int
            raise ValueError(f"{self.root}: {field} {template!r} cannot take {values} ({e})") from e
        return dataset_file(self.root, field, rel)

    def __len__(self) -> int:
        return len(self.episodes)

    def episode_slice(self, ep: int) -> slice:
        """Rows of episode ``ep`` in :attr:`data`."""
        r = self.episodes[ep]
        return slice(r["dataset_from_index"], r["dataset_to_index"])

    def video_path(self, ep: int, key: str) -> Path:
        """The video file holding episode ``ep``'s frames of video feature ``key``."""
        r = self.episodes[ep]
        return self._file(
            "video_path",
            video_key=key,
            chunk_index=r[f"videos/{key}/chunk_index"],
            file_index=r[f"videos/{key}/file_index"],
        )

    def frames(self, ep: int, key: str, frame_index: np.ndarray | None = None) -> np.ndarray:
        """``(n, H, W, 3)`` uint8 frames of episode ``ep`` from video ``key`` (all, or those
        with the given ``frame_index``), decoded at ``from_timestamp + frame_index / fps``."""
        if key not in self.video_keys:
            raise ValueError(f"{self.root}: no video feature {key!r}; it has {self.video_keys}")
        if frame_index is None:
            frame_index = self.data["frame_index"][self.episode_slice(ep)]
        ts = (
            self.episodes[ep][f"videos/{key}/from_timestamp"] + np.asarray(frame_index, np.float64) / self.fps
        )
        return decode_video_frames(self.video_path(ep, key), ts, self.tolerance_s)
