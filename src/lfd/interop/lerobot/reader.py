"""Reading LeRobot v3.0 datasets: :func:`read_info` (checked ``meta/info.json``) and
:class:`LeRobotFolder` (episode metadata, tasks, the frame table and video frames).

Frames are decoded with PyAV at ``from_timestamp + frame_index / fps`` in the episode's
video file (lerobot's own rule), each within ``tolerance_s`` of a decoded frame's time.
Every file is looked up inside the dataset folder only: ``data_path`` / ``video_path``
templates and files (symbolic links included) that lead elsewhere are refused
(:mod:`~lfd.interop.lerobot.paths`), as are corrupt JSON and parquet files, each with one
line naming the field or file.

A folder is not trusted: every count and size ``info.json`` declares is checked against
lfd's caps (:data:`MAX_EPISODES`, :data:`MAX_FRAMES`, :data:`MAX_FEATURE_VALUES`,
:data:`MAX_FPS`, :data:`MAX_IMAGE_SIDE`) and against the row and value counts in the parquet
footers (:data:`MAX_FRAME_VALUES`, :data:`MAX_EPISODE_VALUES`) before anything is allocated;
each episode's index range must hold exactly its own frames (no overlap, ``from < to``), the
video columns of every camera must be there, and ``observation.state`` / ``action`` must be
finite. Every refusal is a
:class:`~lfd.interop.lerobot.io.LeRobotDatasetError` (a ``ValueError``; a missing file or
folder a :class:`~lfd.interop.lerobot.io.LeRobotFileMissing`, also a ``FileNotFoundError``)
with one line naming the file, the field and the episode.
:class:`~lfd.interop.lerobot.datamodule.LeRobotDataModule` trains lfd's policies on a folder.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from lfd.checks import one_line
from lfd.interop.lerobot.io import (
    LeRobotDatasetError,
    LeRobotFileMissing,
    parquet_footer,
    read_json,
    read_parquet_columns,
    read_table,
    read_tasks,
)
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
#: Most episodes a folder may declare (``total_episodes``).
MAX_EPISODES = 1_000_000
#: Most frames a folder may declare (``total_frames``): the frame table is held in memory.
MAX_FRAMES = 50_000_000
#: Most values (list entries counted one by one) the data parquet files may hold together, as their
#: footers declare: the frame table in memory stays within about 2 GB.
MAX_FRAME_VALUES = 250_000_000
#: Most values the ``meta/episodes`` parquet files may hold together (read as Python objects), and
#: ``meta/tasks.parquet`` on its own.
MAX_EPISODE_VALUES = 20_000_000
#: Most values of one frame feature (the product of its ``shape``; video features excepted).
MAX_FEATURE_VALUES = 65_536
#: Highest frame rate (``fps``, Hz) accepted.
MAX_FPS = 10_000.0
#: Largest height or width (px) of a video feature.
MAX_IMAGE_SIDE = 8192
#: A feature name: letters, digits, ``_``, ``-`` and ``.`` (it becomes a folder name for videos).
FEATURE_NAME = re.compile(r"[A-Za-z0-9_\-]+(\.[A-Za-z0-9_\-]+)*")
#: Frame features that must hold finite numbers.
FINITE_FEATURES = ("observation.state", "action", "timestamp")


def _count(path: Path, name: str, value: object, cap: int) -> int:
    """``value`` (the ``info.json`` field ``name``) checked: an int in ``[0, cap]``."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= cap:
        raise LeRobotDatasetError(f"{path} {name}: expected an integer in [0, {cap}], got {value!r}")
    return value


def _check_footers(root: Path, what: str, files: list[Path], rows: int, field: str, cap: int) -> None:
    """The parquet ``files`` (``what`` of the folder ``root``), by their footers alone, hold the
    ``rows`` rows ``info.json``'s ``field`` declares and at most ``cap`` values together."""
    footers = [parquet_footer(f) for f in files]
    declared = sum(r for r, _ in footers)
    if declared != rows:
        raise LeRobotDatasetError(
            f"{root}: {what} holds {declared} rows, {root / 'meta' / 'info.json'} {field} says {rows}"
        )
    values = sum(v for _, v in footers)
    if values > cap:
        raise LeRobotDatasetError(
            f"{root}: {what} declares {values} values in its parquet footers, more than lfd reads ({cap})"
        )


def _check_features(path: Path, features: dict) -> None:
    """Every feature an object with a string ``dtype`` and a ``shape`` of positive ints, within the caps."""
    for key, feature in features.items():
        where = f"{path} features.{key}"
        if not isinstance(feature, dict):
            raise LeRobotDatasetError(
                f"{where}: expected an object with dtype and shape, got {feature!r:.80}"
            )
        if not FEATURE_NAME.fullmatch(str(key)):
            raise LeRobotDatasetError(
                f"{path} features: name {key!r:.80} is not a feature name (letters, digits, '_', '-', '.')"
            )
        dtype, shape = feature.get("dtype"), feature.get("shape")
        if not isinstance(dtype, str):
            raise LeRobotDatasetError(f"{where}.dtype: expected a string, got {dtype!r:.80}")
        if (
            not isinstance(shape, list)
            or not 1 <= len(shape) <= 4
            or any(isinstance(n, bool) or not isinstance(n, int) or n < 1 for n in shape)
        ):
            raise LeRobotDatasetError(
                f"{where}.shape: expected a list of 1-4 positive integers, got {shape!r:.80}"
            )
        if dtype == "video":
            if len(shape) != 3 or max(shape[:2]) > MAX_IMAGE_SIDE or shape[2] not in (1, 3, 4):
                raise LeRobotDatasetError(
                    f"{where}.shape: expected [height, width, channels] with sides <= {MAX_IMAGE_SIDE} "
                    f"and 1, 3 or 4 channels, got {shape}"
                )
        elif math.prod(shape) > MAX_FEATURE_VALUES:
            raise LeRobotDatasetError(
                f"{where}.shape: {shape} holds {math.prod(shape)} values per frame, more than lfd reads "
                f"({MAX_FEATURE_VALUES})"
            )


def read_info(root: str | Path) -> dict[str, Any]:
    """``meta/info.json`` of a v3.0 dataset, checked: the version must be ``"v3.0"``, every
    required key and frame feature present, ``fps`` a number in ``(0, MAX_FPS]``,
    ``total_episodes`` / ``total_frames`` integers within :data:`MAX_EPISODES` /
    :data:`MAX_FRAMES`, every feature an object with a ``dtype`` and a ``shape`` of positive
    integers within :data:`MAX_FEATURE_VALUES` (video: ``[H, W, C]``, sides within
    :data:`MAX_IMAGE_SIDE`), feature names plain (letters, digits, ``_-.``), ``data_path`` /
    ``video_path`` relative templates inside the folder
    (:func:`~lfd.interop.lerobot.paths.check_template`).

    Raises:
        LeRobotFileMissing: no folder or no ``meta/info.json`` (a ``FileNotFoundError``).
        LeRobotDatasetError: corrupt JSON, another ``codebase_version``, a missing key / feature,
            a value out of range, or a path template leading outside the folder (a ``ValueError``;
            one line naming the file and the field).
    """
    root = Path(root)
    path = root / "meta" / "info.json"
    if not root.is_dir():
        raise LeRobotFileMissing(f"LeRobot dataset folder {root} not found")
    if not path.is_file():
        raise LeRobotFileMissing(f"{root} is no LeRobot dataset: {path} not found")
    info = read_json(dataset_file(root, "file", "meta/info.json"))
    if not isinstance(info, dict):
        raise LeRobotDatasetError(f"{path}: expected a JSON object, got {type(info).__name__}")
    version = info.get("codebase_version")
    if version != CODEBASE_VERSION:
        raise LeRobotDatasetError(
            f"{path}: codebase_version is {version!r:.40}; this reader reads LeRobot {CODEBASE_VERSION!r} only "
            "(convert older datasets with lerobot's convert_dataset_v21_to_v30)"
        )
    missing = [k for k in REQUIRED_INFO if k not in info]
    if missing:
        raise LeRobotDatasetError(f"{path}: missing keys {missing}")
    fps = info["fps"]
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not 0 < fps <= MAX_FPS:
        raise LeRobotDatasetError(f"{path} fps: expected a number in (0, {MAX_FPS:g}], got {fps!r:.40}")
    _count(path, "total_episodes", info["total_episodes"], MAX_EPISODES)
    _count(path, "total_frames", info["total_frames"], MAX_FRAMES)
    if not isinstance(info["features"], dict):
        raise LeRobotDatasetError(
            f"{path} features: expected an object, got {type(info['features']).__name__}"
        )
    missing = [k for k in REQUIRED_FEATURES if k not in info["features"]]
    if missing:
        raise LeRobotDatasetError(f"{path}: missing features {missing}; it has {sorted(info['features'])}")
    _check_features(path, info["features"])
    check_template(path, "data_path", info["data_path"])
    if info.get("video_path") is not None or any(f["dtype"] == "video" for f in info["features"].values()):
        check_template(path, "video_path", info.get("video_path"))
    return info


def parse_splits(splits: dict[str, str], n_episodes: int) -> dict[str, list[int]]:
    """``{"train": "0:40", "val": "40:50"}`` -> episode index lists (ranges checked).

    Raises:
        LeRobotDatasetError: not an object of ``"start:end"`` strings, or a range outside ``0:n_episodes``.
    """
    if not isinstance(splits, dict):
        raise LeRobotDatasetError(f"info.json splits: expected an object, got {splits!r:.80}")
    out = {}
    for name, spec in splits.items():
        try:
            a, b = (int(x) for x in str(spec).split(":"))
        except ValueError:
            raise LeRobotDatasetError(
                f"info.json splits.{name}: expected 'start:end', got {spec!r:.80}"
            ) from None
        if not 0 <= a <= b <= n_episodes:
            raise LeRobotDatasetError(f"info.json splits.{name}: range {spec!r} outside 0:{n_episodes}")
        out[name] = list(range(a, b))
    return out


class LeRobotFolder:
    """A v3.0 dataset folder in memory: ``info``, ``episodes`` (one dict per episode,
    every column of ``meta/episodes``), ``episode_files`` (the ``meta/episodes`` parquet file
    each episode's row came from), ``tasks`` (strings by task index) and the frame table
    ``data`` (column -> ``(N, ...)`` array, rows in ``index`` order, ``index == 0..N-1``).

    Everything is checked before it is used (see the module's docstring): the declared
    counts against the caps and the parquet footers before any table is read, each
    episode's ``[dataset_from_index, dataset_to_index)`` against the frames' own
    ``episode_index``, the video columns of each camera, finite ``observation.state`` and
    ``action``.

    Args:
        root: dataset folder.
        tolerance_s: allowed gap between a requested timestamp and a decoded frame.

    Raises:
        LeRobotFileMissing: the folder or a file it lists is missing.
        LeRobotDatasetError: anything else that is wrong, in one line naming the file, the
            field and the episode.
    """

    def __init__(self, root: str | Path, tolerance_s: float = 1e-4) -> None:
        self.root = Path(root)
        self.info = read_info(self.root)
        self.fps = float(self.info["fps"])
        self.tolerance_s = tolerance_s
        self.features = self.info["features"]
        self.video_keys = [k for k, f in self.features.items() if f["dtype"] == "video"]
        ep_files = sorted((self.root / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
        if not ep_files:
            raise LeRobotFileMissing(f"{self.root}: no meta/episodes/chunk-*/file-*.parquet")
        ep_files = [dataset_file(self.root, "file", f.relative_to(self.root)) for f in ep_files]
        n_episodes = self.info["total_episodes"]
        _check_footers(self.root, "meta/episodes", ep_files, n_episodes, "total_episodes", MAX_EPISODE_VALUES)
        rows, self.episode_files = [], []
        for f in ep_files:
            table = read_table(f)
            missing = [c for c in EPISODE_COLUMNS if c not in table.column_names]
            missing += [
                f"videos/{key}/{c}"
                for key in self.video_keys
                for c in ("chunk_index", "file_index", "from_timestamp")
                if f"videos/{key}/{c}" not in table.column_names
            ]
            if missing:
                raise LeRobotDatasetError(f"{f}: missing columns {missing}")
            for row in table.to_pylist():
                rows.append(row)
                self.episode_files.append(f)
        for r, f in zip(rows, self.episode_files, strict=True):
            self._check_row(f, r)
        order = sorted(range(len(rows)), key=lambda i: rows[i]["episode_index"])
        rows = [rows[i] for i in order]
        self.episode_files = [self.episode_files[i] for i in order]
        for e, (r, f) in enumerate(zip(rows, self.episode_files, strict=True)):
            if r["episode_index"] != e:
                raise LeRobotDatasetError(
                    f"{f}: episode_index {r['episode_index']} found where episode {e} is due "
                    f"(episodes must be 0..{n_episodes - 1}, each once)"
                )
        self.episodes = rows
        tasks_path = self.root / "meta" / "tasks.parquet"
        if not tasks_path.is_file():
            raise LeRobotFileMissing(f"{self.root}: meta/tasks.parquet not found")
        tasks_file = dataset_file(self.root, "file", "meta/tasks.parquet")
        _, values = parquet_footer(tasks_file)
        if values > MAX_EPISODE_VALUES:
            raise LeRobotDatasetError(
                f"{tasks_file}: declares {values} values in its footer, more than lfd reads ({MAX_EPISODE_VALUES})"
            )
        self.tasks = read_tasks(tasks_file)
        self.data_files = [
            self._file("data_path", chunk_index=r["data/chunk_index"], file_index=r["data/file_index"])
            for r in rows
        ]
        data_files = sorted(set(self.data_files))
        for f in data_files:
            if not f.is_file():
                raise LeRobotFileMissing(f"{self.root}: data file {f} (listed in meta/episodes) not found")
        n_frames = self.info["total_frames"]
        _check_footers(self.root, "data/", data_files, n_frames, "total_frames", MAX_FRAME_VALUES)
        self.data = read_parquet_columns(data_files)
        missing = [k for k in REQUIRED_FEATURES if k not in self.data]
        if missing:
            raise LeRobotDatasetError(f"{self.root}: data parquet lacks columns {missing}")
        order = np.argsort(self.data["index"], kind="stable")
        self.data = {k: v[order] for k, v in self.data.items()}
        if not np.array_equal(self.data["index"], np.arange(n_frames)):
            raise LeRobotDatasetError(
                f"{', '.join(map(str, data_files))}: column index is not 0..{n_frames - 1}, each once"
            )
        self._check_frames()

    def _check_row(self, f: Path, r: dict) -> None:
        """One ``meta/episodes`` row: integer indices, ``0 <= from < to <= total_frames``, ``length``
        (when there) ``to - from``, finite non-negative video timestamps."""
        ep = r.get("episode_index")
        where = f"{f} episode {ep}"
        ints = [
            "episode_index",
            "data/chunk_index",
            "data/file_index",
            "dataset_from_index",
            "dataset_to_index",
        ]
        ints += [f"videos/{k}/{c}" for k in self.video_keys for c in ("chunk_index", "file_index")]
        for c in ints:
            if isinstance(r[c], bool) or not isinstance(r[c], int) or r[c] < 0:
                raise LeRobotDatasetError(f"{where}: {c} expected an integer >= 0, got {r[c]!r:.40}")
        a, b = r["dataset_from_index"], r["dataset_to_index"]
        if not a < b <= self.info["total_frames"]:
            raise LeRobotDatasetError(
                f"{where}: frames dataset_from_index {a} .. dataset_to_index {b} are not a range in "
                f"0..{self.info['total_frames']} (from < to <= total_frames)"
            )
        if "length" in r and r["length"] != b - a:
            raise LeRobotDatasetError(
                f"{where}: length {r['length']!r:.40} != dataset_to_index - dataset_from_index ({b - a})"
            )
        for k in self.video_keys:
            t = r[f"videos/{k}/from_timestamp"]
            if isinstance(t, bool) or not isinstance(t, int | float) or not (math.isfinite(t) and t >= 0):
                raise LeRobotDatasetError(
                    f"{where}: videos/{k}/from_timestamp expected a finite number >= 0, got {t!r:.40}"
                )

    def _check_frames(self) -> None:
        """Each episode's rows hold its own frames (``episode_index``), in order, no two
        episodes sharing a frame; :data:`FINITE_FEATURES` finite."""
        ep_of = self.data["episode_index"]
        previous = None
        for e in sorted(range(len(self.episodes)), key=lambda e: self.episodes[e]["dataset_from_index"]):
            sl, f = self.episode_slice(e), self.data_files[e]
            if previous is not None and sl.start < self.episode_slice(previous).stop:
                raise LeRobotDatasetError(
                    f"{self.episode_files[e]} episode {e}: frames {sl.start}..{sl.stop} overlap episode "
                    f"{previous}'s {self.episode_slice(previous).start}..{self.episode_slice(previous).stop}"
                )
            previous = e
            wrong = np.flatnonzero(ep_of[sl] != e)
            if wrong.size:
                raise LeRobotDatasetError(
                    f"{f} episode {e}: frame {sl.start + wrong[0]} (of dataset_from_index {sl.start} .. "
                    f"dataset_to_index {sl.stop}) has episode_index {ep_of[sl][wrong[0]]}"
                )
        frame_index = self.data["frame_index"]
        if frame_index.dtype.kind not in "iu" or (frame_index < 0).any():
            raise LeRobotDatasetError(f"{self.root}: data column frame_index expected integers >= 0")
        for key in FINITE_FEATURES:
            values = self.data[key]
            if values.dtype.kind not in "fiu":
                raise LeRobotDatasetError(
                    f"{self.root}: data column {key} holds {values.dtype}, expected numbers"
                )
            bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                e = int(ep_of[row])
                raise LeRobotDatasetError(
                    f"{self.data_files[e]} episode {e}: {key} is not finite (NaN or inf) at frame "
                    f"{row - self.episodes[e]['dataset_from_index']} (index {row})"
                )

    def _file(self, field: str, **values) -> Path:
        """The file that ``info.json``'s template ``field`` names for ``values``, inside the folder."""
        template = self.info[field]
        try:
            rel = template.format(**values)
        except (ValueError, TypeError) as e:  # e.g. a string where {chunk_index:03d} wants an int
            raise LeRobotDatasetError(f"{self.root}: {field} {template!r} cannot take {values} ({e})") from e
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
        with the given ``frame_index``), decoded at ``from_timestamp + frame_index / fps``.

        Raises:
            LeRobotDatasetError: ``key`` is no video feature, or the video file cannot give
                these frames (corrupt, too short, no frame near a timestamp): one line naming
                the file, the feature and the episode.
            LeRobotFileMissing: the video file is missing.
        """
        if key not in self.video_keys:
            raise LeRobotDatasetError(f"{self.root}: no video feature {key!r}; it has {self.video_keys}")
        if frame_index is None:
            frame_index = self.data["frame_index"][self.episode_slice(ep)]
        ts = (
            self.episodes[ep][f"videos/{key}/from_timestamp"] + np.asarray(frame_index, np.float64) / self.fps
        )
        path = self.video_path(ep, key)
        if not path.is_file():
            raise LeRobotFileMissing(f"{self.root}: video file {path} of {key}, episode {ep}, not found")
        try:
            return decode_video_frames(path, ts, self.tolerance_s)
        except (ValueError, OSError) as e:  # PyAV's decoding errors are both
            raise LeRobotDatasetError(f"{path} ({key}, episode {ep}): {one_line(str(e))}") from e
