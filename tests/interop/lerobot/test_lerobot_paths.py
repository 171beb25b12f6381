"""Chunk / file index arithmetic and path templates of the v3.0 layout."""

from __future__ import annotations

from lfd.interop.lerobot.paths import DATA_PATH, VIDEO_PATH, update_chunk_file_indices


def test_chunk_indices():
    assert update_chunk_file_indices(0, 0, 1000) == (0, 1)
    assert update_chunk_file_indices(0, 998, 1000) == (0, 999)
    assert update_chunk_file_indices(0, 999, 1000) == (1, 0)
    assert update_chunk_file_indices(3, 1, 2) == (4, 0)


def test_path_templates():
    assert DATA_PATH.format(chunk_index=1, file_index=23) == "data/chunk-001/file-023.parquet"
    assert (
        VIDEO_PATH.format(video_key="observation.images.front", chunk_index=0, file_index=1000)
        == "videos/observation.images.front/chunk-000/file-1000.mp4"
    )
