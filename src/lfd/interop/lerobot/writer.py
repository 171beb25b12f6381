"""Writing LeRobot v3.0 dataset folders (pyarrow + PyAV, no lerobot import).

:class:`LeRobotWriter` writes the layout of :mod:`~lfd.interop.lerobot.paths` as lerobot
0.4's ``LeRobotDataset`` does (checked field by field against a dataset made by lerobot
itself, ``tests/fixtures/lerobot_v3_reference``), with the statistics of
:mod:`~lfd.interop.lerobot.stats`.

Files roll over like lerobot's: a new data (episodes) file starts when the current one
would reach ``data_files_size_in_mb`` with the next episode (estimated from the current
file's size per frame / per episode), a new video file when it would reach
``video_files_size_in_mb``; the next file's indices come from
:func:`~lfd.interop.lerobot.paths.update_chunk_file_indices`.

Use :class:`LeRobotWriter` for any episodes, :func:`lfd.interop.lerobot.export.export_lerobot`
for an lfd dataset.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lfd.interop.lerobot.io import extra_column_type, hf_feature, pyarrow_modules, write_json, write_tasks
from lfd.interop.lerobot.paths import (
    CODEBASE_VERSION,
    DATA_PATH,
    DEFAULT_CHUNK_SIZE,
    DEFAULT_DATA_FILE_SIZE_IN_MB,
    DEFAULT_VIDEO_FILE_SIZE_IN_MB,
    EPISODES_PATH,
    VIDEO_PATH,
    update_chunk_file_indices,
)
from lfd.interop.lerobot.stats import STAT_KEYS, image_histograms, image_stats, stats_to_lists, vector_stats
from lfd.io.video import CODECS, VideoFileWriter, video_info

#: Frame-level features every LeRobot dataset has, after the user's.
DEFAULT_FEATURES = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}
#: Episode metadata rows buffered before a parquet row group is written (as lerobot).
META_BUFFER = 10
_MB = 1024**2


@dataclass
class LeRobotEpisode:
    """One episode for :class:`LeRobotWriter`.

    Attributes:
        state: ``(T, S)`` ``observation.state`` per frame.
        action: ``(T, A)`` action per frame.
        frames: camera name -> ``(T, H, W, 3)`` uint8 RGB frames.
        task: natural-language task string (one per episode here).
        extra: extra episode columns (str, int, float, bool or flat numeric lists), written
            after lerobot's own columns (lerobot keeps columns it does not know).
    """

    state: np.ndarray
    action: np.ndarray
    frames: dict[str, np.ndarray]
    task: str
    extra: dict[str, Any] = field(default_factory=dict)


class LeRobotWriter:
    """Write episodes into a new LeRobot v3.0 dataset folder.

    Args:
        root: dataset folder (must not exist, or be empty).
        fps: frames per second (``timestamp = frame_index / fps`` exactly).
        robot_type: ``info.json`` robot type.
        state_names, action_names: names of the ``observation.state`` / ``action`` entries.
        cameras: camera name -> ``(height, width)``; features ``observation.images.<name>``.
        codec: ``"av1"`` (lerobot's default, libsvtav1) or ``"h264"`` (libx264).
        chunks_size, data_files_size_in_mb, video_files_size_in_mb: rollover limits (lerobot's
            defaults 1000, 100, 200).
        crf, g: video encoder quality and GOP (lerobot: 30, 2).

    Example::

        w = LeRobotWriter("/tmp/ds", fps=10, robot_type="panda", state_names=["q0"],
                          action_names=["q0"], cameras={"front": (64, 64)})
        w.add_episode(LeRobotEpisode(np.zeros((5, 1)), np.zeros((5, 1)),
                                     {"front": np.zeros((5, 64, 64, 3), np.uint8)}, "reach"))
        w.finalize()
    """

    def __init__(
        self,
        root: str | Path,
        *,
        fps: float,
        robot_type: str,
        state_names: Sequence[str],
        action_names: Sequence[str],
        cameras: dict[str, tuple[int, int]],
        codec: str = "av1",
        chunks_size: int = DEFAULT_CHUNK_SIZE,
        data_files_size_in_mb: float = DEFAULT_DATA_FILE_SIZE_IN_MB,
        video_files_size_in_mb: float = DEFAULT_VIDEO_FILE_SIZE_IN_MB,
        crf: int = 30,
        g: int = 2,
    ) -> None:
        if codec not in CODECS:
            raise ValueError(f"LeRobotWriter.codec: expected one of {sorted(CODECS)}, got {codec!r}")
        if not (fps > 0 and math.isfinite(fps)):
            raise ValueError(f"LeRobotWriter.fps: expected a finite number > 0, got {fps}")
        if not (isinstance(chunks_size, int) and chunks_size >= 1):
            raise ValueError(f"LeRobotWriter.chunks_size: expected an int >= 1, got {chunks_size!r}")
        if not (data_files_size_in_mb > 0 and video_files_size_in_mb > 0):
            raise ValueError("LeRobotWriter: data_files_size_in_mb and video_files_size_in_mb must be > 0")
        self.root = Path(root)
        if self.root.exists() and any(self.root.iterdir()):
            raise FileExistsError(f"LeRobotWriter: {self.root} exists and is not empty")
        self.root.mkdir(parents=True, exist_ok=True)
        self.fps, self.robot_type, self.codec = fps, robot_type, codec
        self.chunks_size = chunks_size
        self.data_mb, self.video_mb = float(data_files_size_in_mb), float(video_files_size_in_mb)
        self.crf, self.g = crf, g
        self.cameras = {f"observation.images.{name}": tuple(hw) for name, hw in cameras.items()}
        self.features: dict[str, dict] = {}
        for key, (h, w) in self.cameras.items():
            self.features[key] = {
                "dtype": "video",
                "shape": [h, w, 3],
                "names": ["height", "width", "channels"],
            }
        self.features["observation.state"] = {
            "dtype": "float32",
            "shape": [len(state_names)],
            "names": list(state_names),
        }
        self.features["action"] = {
            "dtype": "float32",
            "shape": [len(action_names)],
            "names": list(action_names),
        }
        self.features.update({k: dict(v) for k, v in DEFAULT_FEATURES.items()})
        self.tasks: dict[str, int] = {}
        self.n_episodes = self.n_frames = 0
        # data files
        self._data = {"chunk": 0, "file": 0, "writer": None, "start": 0}
        # video files, per key
        self._video: dict[str, dict] = {k: {"chunk": 0, "file": 0, "writer": None} for k in self.cameras}
        # episode metadata files
        self._meta = {"chunk": 0, "file": 0, "writer": None, "rows": 0, "buffer": [], "schema": None}
        # exact global stats
        self._vectors: dict[str, list[np.ndarray]] = {}
        self._hists: dict[str, np.ndarray] = {}
        self._data_schema = None
        self._extra_keys: list[str] | None = None

    # ------------------------------------------------------------------ paths
    def _path(self, template: str, chunk: int, file: int, **kw) -> Path:
        return self.root / template.format(chunk_index=chunk, file_index=file, **kw)

    # ------------------------------------------------------------------ episodes
    def add_episode(self, ep: LeRobotEpisode) -> int:
        """Append one episode (its data rows, video frames, metadata row and statistics);
        returns its ``episode_index``.

        Raises:
            ValueError: ``state`` / ``action`` not ``(T, S)`` / ``(T, A)`` with ``T >= 1`` or not
                finite, cameras other than the writer's, frames not uint8 ``(T, H, W, 3)``, an
                empty task, or ``extra`` keys other than the first episode's.
        """
        state, action = np.asarray(ep.state, np.float32), np.asarray(ep.action, np.float32)
        T = len(state)
        for name, arr, feat in (("state", state, "observation.state"), ("action", action, "action")):
            width = self.features[feat]["shape"][0]
            if arr.ndim != 2 or arr.shape[1] != width or len(arr) != T or T < 1:
                raise ValueError(
                    f"LeRobotEpisode.{name}: expected ({T}, {width}) with T >= 1, got {arr.shape}"
                )
            if not np.isfinite(arr).all():
                raise ValueError(f"LeRobotEpisode.{name}: contains NaN or inf")
        names = {f"observation.images.{c}" for c in ep.frames}
        if names != set(self.cameras):
            raise ValueError(
                f"LeRobotEpisode.frames: expected cameras {sorted(self.cameras)}, got {sorted(names)}"
            )
        if not isinstance(ep.task, str) or not ep.task:
            raise ValueError(f"LeRobotEpisode.task: expected a non-empty string, got {ep.task!r}")
        if self._extra_keys is None:
            self._extra_keys = list(ep.extra)
        elif list(ep.extra) != self._extra_keys:
            raise ValueError(
                f"LeRobotEpisode.extra: every episode needs the keys {self._extra_keys}, got {list(ep.extra)}"
            )
        ep_index = self.n_episodes
        task_index = self.tasks.setdefault(ep.task, len(self.tasks))
        frame_index = np.arange(T, dtype=np.int64)
        columns = {
            "observation.state": state,
            "action": action,
            "timestamp": (frame_index / self.fps).astype(np.float32),
            "frame_index": frame_index,
            "episode_index": np.full(T, ep_index, np.int64),
            "index": np.arange(self.n_frames, self.n_frames + T, dtype=np.int64),
            "task_index": np.full(T, task_index, np.int64),
        }
        row: dict[str, Any] = {"episode_index": ep_index, "tasks": [ep.task], "length": T}
        row.update(self._write_data(columns, T))
        for key in self.cameras:
            row.update(self._write_video(key, ep.frames[key.removeprefix("observation.images.")], T))
        stats: dict[str, dict[str, np.ndarray]] = {}
        for key in self.features:
            if key in self.cameras:
                frames = ep.frames[key.removeprefix("observation.images.")]
                hist = image_histograms(frames)
                self._hists[key] = self._hists.get(key, 0) + hist
                stats[key] = image_stats(hist, T)
            else:
                stats[key] = vector_stats(columns[key])
                self._vectors.setdefault(key, []).append(columns[key])
        for feat, s in stats.items():
            for k in STAT_KEYS:
                row[f"stats/{feat}/{k}"] = np.asarray(s[k]).tolist()
        row.update(
            {k: (np.asarray(v).tolist() if isinstance(v, np.ndarray) else v) for k, v in ep.extra.items()}
        )
        self._write_meta_row(row, ep.extra)
        self.n_episodes += 1
        self.n_frames += T
        return ep_index

    def _write_data(self, columns: dict[str, np.ndarray], T: int) -> dict[str, int]:
        pa, pq = pyarrow_modules()
        d = self._data
        if d["writer"] is not None:
            path = self._path(DATA_PATH, d["chunk"], d["file"])
            size_mb = os.path.getsize(path) / _MB
            per_frame = size_mb / max(1, self.n_frames - d["start"])
            if size_mb + per_frame * T >= self.data_mb:
                d["writer"].close()
                d["writer"] = None
                d["chunk"], d["file"] = update_chunk_file_indices(d["chunk"], d["file"], self.chunks_size)
                d["start"] = self.n_frames
        arrays = []
        for value in columns.values():
            if value.ndim == 2:
                arrays.append(pa.FixedSizeListArray.from_arrays(pa.array(value.reshape(-1)), value.shape[1]))
            else:
                arrays.append(pa.array(value))
        if self._data_schema is None:
            hf = {k: hf_feature(self.features[k]) for k in columns}
            fingerprint = hashlib.sha256(json.dumps(self.features, sort_keys=True).encode()).hexdigest()[:16]
            meta = {"huggingface": json.dumps({"info": {"features": hf}, "fingerprint": fingerprint})}
            self._data_schema = pa.schema(
                [pa.field(k, a.type) for k, a in zip(columns, arrays, strict=True)], metadata=meta
            )
        table = pa.Table.from_arrays(arrays, schema=self._data_schema)
        if d["writer"] is None:
            path = self._path(DATA_PATH, d["chunk"], d["file"])
            path.parent.mkdir(parents=True, exist_ok=True)
            d["writer"] = pq.ParquetWriter(
                path, schema=self._data_schema, compression="snappy", use_dictionary=True
            )
        d["writer"].write_table(table)
        start = self.n_frames
        return {
            "data/chunk_index": d["chunk"],
            "data/file_index": d["file"],
            "dataset_from_index": start,
            "dataset_to_index": start + T,
        }

    def _write_video(self, key: str, frames: np.ndarray, T: int) -> dict[str, Any]:
        v = self._video[key]
        h, w = self.cameras[key]
        frames = np.asarray(frames)
        if frames.shape != (T, h, w, 3) or frames.dtype != np.uint8:
            raise ValueError(
                f"LeRobotEpisode.frames[{key!r}]: expected uint8 ({T}, {h}, {w}, 3), got {frames.dtype} {frames.shape}"
            )
        writer: VideoFileWriter | None = v["writer"]
        if writer is not None and writer.n_frames > 0:
            est_mb = writer.bytes_written / writer.n_frames * T / _MB
            if writer.bytes_written / _MB + est_mb >= self.video_mb:
                writer.close()
                writer = v["writer"] = None
                v["chunk"], v["file"] = update_chunk_file_indices(v["chunk"], v["file"], self.chunks_size)
        if writer is None:
            path = self._path(VIDEO_PATH, v["chunk"], v["file"], video_key=key)
            writer = v["writer"] = VideoFileWriter(
                path, fps=self.fps, width=w, height=h, codec=self.codec, crf=self.crf, g=self.g
            )
        start, end = writer.write_episode(frames)
        return {
            f"videos/{key}/chunk_index": v["chunk"],
            f"videos/{key}/file_index": v["file"],
            f"videos/{key}/from_timestamp": float(start),
            f"videos/{key}/to_timestamp": float(end),
        }

    def _meta_schema(self, row: dict[str, Any], extra: dict[str, Any]):
        pa, _ = pyarrow_modules()
        fields = []
        for key in row:
            if key == "tasks":
                t = pa.list_(pa.string())
            elif key in extra:
                t = extra_column_type(extra[key])
            elif key.startswith("stats/"):
                feat, stat = key[len("stats/") :].rsplit("/", 1)
                if stat == "count":
                    t = pa.list_(pa.int64())
                elif feat in self.cameras:
                    t = pa.list_(pa.list_(pa.list_(pa.float64())))
                elif stat in ("min", "max") and self.features[feat]["dtype"] == "int64":
                    t = pa.list_(pa.int64())
                else:
                    t = pa.list_(pa.float64())
            elif key.endswith("_timestamp"):
                t = pa.float64()
            else:
                t = pa.int64()
            fields.append(pa.field(key, t))
        fields += [
            pa.field("meta/episodes/chunk_index", pa.int64()),
            pa.field("meta/episodes/file_index", pa.int64()),
        ]
        return pa.schema(fields)

    def _write_meta_row(self, row: dict[str, Any], extra: dict[str, Any]) -> None:
        m = self._meta
        if m["schema"] is None:
            m["schema"] = self._meta_schema(row, extra)
        if m["writer"] is not None and m["rows"] > 0:
            size_mb = os.path.getsize(self._path(EPISODES_PATH, m["chunk"], m["file"])) / _MB
            if size_mb + size_mb / m["rows"] >= self.data_mb:
                self._flush_meta(close=True)
                m["chunk"], m["file"] = update_chunk_file_indices(m["chunk"], m["file"], self.chunks_size)
        # a buffered row of the previous file is flushed above, so the buffer holds this file's rows only
        row["meta/episodes/chunk_index"], row["meta/episodes/file_index"] = m["chunk"], m["file"]
        m["buffer"].append(row)
        if len(m["buffer"]) >= META_BUFFER or m["writer"] is None:
            self._flush_meta()

    def _flush_meta(self, close: bool = False) -> None:
        pa, pq = pyarrow_modules()
        m = self._meta
        if m["buffer"]:
            if m["writer"] is None:
                path = self._path(EPISODES_PATH, m["chunk"], m["file"])
                path.parent.mkdir(parents=True, exist_ok=True)
                m["writer"] = pq.ParquetWriter(
                    path, schema=m["schema"], compression="snappy", use_dictionary=True
                )
                m["rows"] = 0
            m["writer"].write_table(pa.Table.from_pylist(m["buffer"], schema=m["schema"]))
            m["rows"] += len(m["buffer"])
            m["buffer"] = []
        if close and m["writer"] is not None:
            m["writer"].close()
            m["writer"], m["rows"] = None, 0

    # ------------------------------------------------------------------ finish
    def finalize(self, splits: dict[str, str] | None = None) -> Path:
        """Close every file and write ``info.json``, ``stats.json`` and ``tasks.parquet``.

        Args:
            splits: ``{"train": "0:N", ...}`` episode ranges (default: all in ``train``).

        Returns:
            The dataset folder.

        Raises:
            ValueError: no episode was added.
        """
        if self.n_episodes == 0:
            raise ValueError("LeRobotWriter.finalize: no episodes were added")
        if self._data["writer"] is not None:
            self._data["writer"].close()
            self._data["writer"] = None
        self._flush_meta(close=True)
        for v in self._video.values():
            if v["writer"] is not None:
                v["writer"].close()
                v["writer"] = None
        for key in self.cameras:
            first = self._path(VIDEO_PATH, 0, 0, video_key=key)
            info = video_info(first).lerobot_info()
            self.features[key]["info"] = info
        stats = {}
        for key in self.features:
            if key in self.cameras:
                stats[key] = image_stats(self._hists[key], self.n_frames)
            else:
                stats[key] = vector_stats(np.concatenate(self._vectors[key]))
        write_json(self.root / "meta" / "stats.json", stats_to_lists(stats))
        write_tasks(self.root / "meta" / "tasks.parquet", list(self.tasks))
        info = {
            "codebase_version": CODEBASE_VERSION,
            "robot_type": self.robot_type,
            "total_episodes": self.n_episodes,
            "total_frames": self.n_frames,
            "total_tasks": len(self.tasks),
            "chunks_size": self.chunks_size,
            "data_files_size_in_mb": _num(self.data_mb),
            "video_files_size_in_mb": _num(self.video_mb),
            "fps": _num(self.fps),
            "splits": splits or {"train": f"0:{self.n_episodes}"},
            "data_path": DATA_PATH,
            "video_path": VIDEO_PATH if self.cameras else None,
            "features": self.features,
        }
        write_json(self.root / "meta" / "info.json", info)
        return self.root


def _num(x: float) -> int | float:
    return int(x) if float(x) == int(x) else float(x)
