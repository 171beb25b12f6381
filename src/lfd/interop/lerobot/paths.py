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
"""

from __future__ import annotations

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
