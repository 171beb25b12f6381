"""Where a LeRobot v3.0 dataset keeps its files, and how file indices advance.

The layout is the one lerobot 0.4's ``LeRobotDataset`` writes::

    meta/info.json                                   codebase_version "v3.0", fps, totals, features ...
    meta/stats.json                                  min/max/mean/std/count/q01..q99 per feature
    meta/tasks.parquet                               task string (pandas index) -> task_index
    meta/episodes/chunk-000/file-000.parquet         one row per episode (+ per-episode stats)
    data/chunk-000/file-000.parquet                  one row per frame, one row group per episode
    videos/observation.images.<cam>/chunk-000/file-000.mp4   frames of many episodes, one after the other

Data, episode and video files are numbered ``(chunk_index, file_index)``; file indices run
up to ``chunks_size`` per chunk, then the chunk index moves on
(:func:`update_chunk_file_indices`).

A dataset read from elsewhere is not trusted: :func:`check_template` and
:func:`dataset_file` refuse ``info.json`` path templates and files that lead outside the
dataset folder.
"""

from __future__ import annotations

import string
from pathlib import Path, PurePosixPath, PureWindowsPath

from lfd.interop.lerobot.io import LeRobotDatasetError

CODEBASE_VERSION = "v3.0"
#: Files per chunk (lerobot's default).
DEFAULT_CHUNK_SIZE = 1000
#: Size (MiB) at which a data or episode-metadata parquet file rolls over (lerobot's default).
DEFAULT_DATA_FILE_SIZE_IN_MB = 100
#: Size (MiB) at which a video file rolls over (lerobot's default).
DEFAULT_VIDEO_FILE_SIZE_IN_MB = 200
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"


def update_chunk_file_indices(chunk_index: int, file_index: int, chunks_size: int) -> tuple[int, int]:
    """The ``(chunk_index, file_index)`` after the given one: ``file_index + 1``, or file 0 of
    the next chunk after ``chunks_size`` files (lerobot's rule; ``(0, 999) -> (1, 0)`` for 1000)."""
    if file_index == chunks_size - 1:
        return chunk_index + 1, 0
    return chunk_index, file_index + 1


#: The fields each path template of ``info.json`` may use.
TEMPLATE_FIELDS = {
    "data_path": ("chunk_index", "file_index"),
    "video_path": ("video_key", "chunk_index", "file_index"),
}


def _relative_inside(rel: str) -> bool:
    """Whether ``rel`` is a relative path with no ``..`` part (POSIX or Windows spelling)."""
    win = PureWindowsPath(rel)
    return not (
        PurePosixPath(rel).is_absolute() or win.is_absolute() or win.drive or win.root or ".." in win.parts
    )


def check_template(info_path: str | Path, name: str, template: object) -> str:
    """``template``, the ``info.json`` field ``name`` (``"data_path"`` or ``"video_path"``),
    checked: a relative path string without ``..`` using only the fields of
    :data:`TEMPLATE_FIELDS` (no attribute or index access).

    Raises:
        LeRobotDatasetError: (a ``ValueError``) one line naming ``info_path`` and the field.
    """
    where = f"{info_path} {name}"
    if not isinstance(template, str):
        raise LeRobotDatasetError(f"{where}: expected a relative path template, got {template!r}")
    allowed = TEMPLATE_FIELDS[name]
    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(template) if f is not None]
    except ValueError as e:
        raise LeRobotDatasetError(f"{where}: {template!r} is not a format template ({e})") from e
    bad = [f for f in fields if f not in allowed]
    if bad:
        raise LeRobotDatasetError(f"{where}: {template!r} uses {bad}; allowed fields are {list(allowed)}")
    if not _relative_inside(template):
        raise LeRobotDatasetError(
            f"{where}: {template!r} points outside the dataset folder (absolute or '..')"
        )
    return template


def dataset_file(root: str | Path, what: str, rel: str | Path) -> Path:
    """``root / rel``, refused unless it stays inside ``root`` once resolved (``..``,
    absolute paths and symbolic links followed).

    Raises:
        LeRobotDatasetError: (a ``ValueError``) one line naming ``what`` (the field or file the path came from).
    """
    root = Path(root)
    path = root / rel
    if not _relative_inside(str(rel)) or not path.resolve().is_relative_to(root.resolve()):
        raise LeRobotDatasetError(f"{root}: {what} {str(rel)!r} leads outside the dataset folder")
    return path
