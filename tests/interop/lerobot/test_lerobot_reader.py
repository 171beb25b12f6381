"""LeRobotFolder and read_info: the lerobot-written reference loads (frame table, tasks,
video frames), clear errors for other versions and missing pieces, decoding tolerance."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from lfd.interop import LeRobotFolder, read_info
from lfd.io.video import decode_video_frames

REFERENCE = Path(__file__).resolve().parents[2] / "fixtures" / "lerobot_v3_reference"


def test_reads_the_lerobot_written_reference():
    folder = LeRobotFolder(REFERENCE)
    assert len(folder) == 3 and folder.tasks == ["reach the red cube"]
    table = pq.read_table(REFERENCE / "data/chunk-000/file-000.parquet")
    np.testing.assert_array_equal(
        folder.data["observation.state"], np.array(table.column("observation.state").to_pylist(), np.float32)
    )
    frames = folder.frames(2, "observation.images.front")
    assert frames.shape == (30, 64, 64, 3) and frames.dtype == np.uint8


def _edit_info(root, **changes):
    path = root / "meta" / "info.json"
    info = json.loads(path.read_text())
    for k, v in changes.items():
        if v is None:
            info.pop(k, None)
        else:
            info[k] = v
    path.write_text(json.dumps(info))
    return info


def test_clear_errors(reference_copy, tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        read_info(tmp_path / "nothing")
    _edit_info(reference_copy, codebase_version="v2.1")
    with pytest.raises(ValueError, match="codebase_version is 'v2.1'"):
        LeRobotFolder(reference_copy)
    info = _edit_info(reference_copy, codebase_version="v3.0")
    del info["features"]["observation.state"]
    _edit_info(reference_copy, features=info["features"])
    with pytest.raises(ValueError, match="missing features \\['observation.state'\\]"):
        LeRobotFolder(reference_copy)
    with pytest.raises(ValueError, match="missing keys"):
        _edit_info(reference_copy, fps=None)
        read_info(reference_copy)


def test_missing_video_and_data_files(reference_copy):
    video = next((reference_copy / "videos").rglob("*.mp4"))
    video.unlink()
    folder = LeRobotFolder(reference_copy)
    with pytest.raises(FileNotFoundError, match="video file"):
        folder.frames(0, "observation.images.front")
    with pytest.raises(ValueError, match="no video feature"):
        folder.frames(0, "observation.images.top")
    next((reference_copy / "data").rglob("*.parquet")).unlink()
    with pytest.raises(FileNotFoundError, match="data file"):
        LeRobotFolder(reference_copy)


def test_decode_tolerance(tiny_lerobot):
    path = LeRobotFolder(tiny_lerobot).video_path(0, "observation.images.front")
    with pytest.raises(ValueError, match="no frame within"):
        decode_video_frames(path, [0.5 / 7.25])  # half-way between two frames
    with pytest.raises(FileNotFoundError):
        decode_video_frames(path.with_name("missing.mp4"), [0.0])
