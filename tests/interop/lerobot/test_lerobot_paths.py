"""Chunk / file index arithmetic and path templates of the v3.0 layout."""

from __future__ import annotations

import pytest

from lfd.interop.lerobot.paths import (
    DATA_PATH,
    VIDEO_PATH,
    check_template,
    dataset_file,
    update_chunk_file_indices,
)


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


def test_templates_and_files_stay_inside_the_folder(tmp_path):
    assert check_template("info.json", "data_path", DATA_PATH) == DATA_PATH
    assert check_template("info.json", "video_path", VIDEO_PATH) == VIDEO_PATH
    for bad in (
        "../x/{chunk_index}",
        "/abs/{file_index}",
        "C:\\x\\{file_index}",
        "{episode_index}",
        "{0}",
        None,
    ):
        with pytest.raises(ValueError, match="info.json data_path: "):
            check_template("info.json", "data_path", bad)
    with pytest.raises(ValueError, match="allowed fields"):
        check_template("info.json", "data_path", "{video_key}")
    (tmp_path / "ds" / "data").mkdir(parents=True)
    assert (
        dataset_file(tmp_path / "ds", "data_path", "data/f.parquet") == tmp_path / "ds" / "data" / "f.parquet"
    )
    (tmp_path / "ds" / "link").symlink_to(tmp_path)
    for rel in ("../f.parquet", "link/f.parquet", str(tmp_path / "f.parquet")):
        with pytest.raises(ValueError, match="data_path .* leads outside the dataset folder"):
            dataset_file(tmp_path / "ds", "data_path", rel)
