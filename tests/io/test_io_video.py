"""lfd.io.video decoding: frame by frame with real (variable) presentation times, resizing,
stride and max_frames; video_info for both its callers; unreadable files give clear errors."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import numpy as np
import pytest

from lfd.io.video import iter_frames, video_info, write_mp4


def write_video(path: Path, frames, times=None, rate: int = 30) -> Path:
    """Write RGB frames to an MP4; ``times`` (s) become the presentation timestamps (ms clock)."""
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=rate)
        stream.width, stream.height = frames[0].shape[1], frames[0].shape[0]
        stream.pix_fmt = "yuv420p"
        stream.codec_context.time_base = stream.time_base = Fraction(1, 1000)
        for i, img in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(img), format="rgb24")
            frame.pts = int(round((times[i] if times is not None else i / rate) * 1000))
            frame.time_base = stream.time_base
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    return path


def test_bad_videos_give_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="video file not found"):
        list(iter_frames(tmp_path / "missing.mp4"))
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 100)
    with pytest.raises(ValueError, match="cannot be decoded"):
        video_info(junk)
    with pytest.raises(ValueError, match="stride"):
        list(iter_frames(junk, stride=0))


def _frames(n: int, width: int = 64, height: int = 48) -> list[np.ndarray]:
    """``n`` flat grey frames whose brightness encodes the frame index (20 + 10 i)."""
    return [np.full((height, width, 3), 20 + 10 * i, np.uint8) for i in range(n)]


def test_iter_frames_keeps_variable_frame_times_and_counts(tmp_path):
    times = np.cumsum(np.r_[0.0, np.tile([0.030, 0.045], 4)])  # 9 frames, variable rate
    path = write_video(tmp_path / "vfr.mp4", _frames(9), times)
    out = list(iter_frames(path))
    assert [i for i, _, _ in out] == list(range(9))
    np.testing.assert_allclose([t for _, t, _ in out], times, atol=1.5e-3)
    brightness = [float(rgb.mean()) for _, _, rgb in out]
    np.testing.assert_allclose(brightness, 20 + 10 * np.arange(9), atol=3)  # decoded in order
    kept = list(iter_frames(path, stride=3, max_frames=2))
    assert [i for i, _, _ in kept] == [0, 3]
    np.testing.assert_allclose(kept[1][1], times[3], atol=1.5e-3)


def test_iter_frames_resizes_down_only(tmp_path):
    path = write_video(tmp_path / "v.mp4", _frames(2, width=64, height=48))
    assert next(iter_frames(path, width=32))[2].shape == (24, 32, 3)  # aspect kept, even height
    assert next(iter_frames(path, width=128))[2].shape == (48, 64, 3)  # never enlarged
    assert next(iter_frames(path))[2].dtype == np.uint8


def test_video_info_serves_both_callers(tmp_path):
    path = write_mp4(tmp_path / "c.mp4", np.stack(_frames(10)), fps=10)
    info = video_info(path)
    assert (info.width, info.height, info.frames) == (64, 48, 10)
    assert info.fps == pytest.approx(10.0) and info.duration == pytest.approx(1.0)
    assert info.lerobot_info() == {
        "video.height": 48,
        "video.width": 64,
        "video.codec": "h264",
        "video.pix_fmt": "yuv420p",
        "video.is_depth_map": False,
        "video.fps": 10,
        "video.channels": 3,
        "has_audio": False,
    }
    with pytest.raises(FileNotFoundError, match="directory"):
        video_info(tmp_path)
