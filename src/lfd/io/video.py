"""Video I/O with PyAV: LeRobot-style MP4 encoding (AV1 or H.264, yuv420p), decoding by timestamp or frame by frame.

LeRobot v3.0 stores the frames of many episodes one after the other in one MP4 per camera
and file index; an episode's frames are found at ``from_timestamp + frame_index / fps``.
:class:`VideoFileWriter` appends episodes to such a file, :func:`decode_video_frames`
reads frames back by timestamp (seeking to the keyframe before the first one).
:func:`iter_frames` decodes any video FFmpeg reads frame by frame with its presentation times
(``pts * time_base``, so variable-frame-rate phone videos keep their real clock), and
:func:`video_info` reads a stream's size, rate, frame count and codec without decoding.

Encoder settings follow lerobot's ``encode_video_frames``: ``libsvtav1`` (preset 12) or
``libx264``, ``yuv420p``, GOP ``g=2``, ``crf=30``.

Example::

    import numpy as np
    from lfd.io.video import VideoFileWriter, decode_video_frames

    frames = np.zeros((10, 64, 64, 3), np.uint8)
    with VideoFileWriter("/tmp/v.mp4", fps=10, width=64, height=64, codec="h264") as w:
        w.write_episode(frames)
    decode_video_frames("/tmp/v.mp4", [0.0, 0.5]).shape     # (2, 64, 64, 3)
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import numpy as np

#: Our codec names -> (PyAV encoder, the codec name a decoder reports, as in info.json).
CODECS = {"av1": ("libsvtav1", "av1"), "h264": ("libx264", "h264")}


def _av():
    try:
        import av
    except ImportError as e:  # pragma: no cover - av is a declared dependency
        raise ImportError("video encoding and decoding need PyAV: pip install av") from e
    return av


def fps_fraction(fps: float) -> Fraction:
    """``fps`` as an exact fraction (24.75 -> 99/4), as the container's frame rate."""
    return Fraction(fps).limit_denominator(10_000)


class VideoFileWriter:
    """One MP4 file receiving whole episodes of ``(T, H, W, 3)`` uint8 RGB frames.

    Each episode starts with a keyframe, so it can be decoded on its own after a seek.

    Args:
        path: output ``.mp4``.
        fps: frames per second (may be fractional).
        width, height: frame size in px (even numbers for yuv420p).
        codec: ``"av1"`` (lerobot's default) or ``"h264"``.
        crf, g: constant rate factor and GOP size (lerobot: 30 and 2).
        preset: libsvtav1 preset (lerobot: 12) or libx264 preset name.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        fps: float,
        width: int,
        height: int,
        codec: str = "av1",
        crf: int = 30,
        g: int = 2,
        preset: int | str | None = None,
    ) -> None:
        if codec not in CODECS:
            raise ValueError(f"VideoFileWriter.codec: expected one of {sorted(CODECS)}, got {codec!r}")
        if width % 2 or height % 2 or width < 2 or height < 2:
            raise ValueError(f"VideoFileWriter: yuv420p needs even frame sizes, got {width}x{height}")
        av = _av()
        os.environ.setdefault("SVT_LOG", "1")  # libsvtav1: errors only, no banner per file
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.fps = fps_fraction(fps)
        self.width, self.height, self.codec = int(width), int(height), codec
        options = {"g": str(g), "crf": str(crf)}
        if codec == "av1":
            options["preset"] = str(12 if preset is None else preset)
        elif preset is not None:
            options["preset"] = str(preset)
        self._container = av.open(str(self.path), "w")
        self._stream = self._container.add_stream(CODECS[codec][0], rate=self.fps, options=options)
        self._stream.width, self._stream.height, self._stream.pix_fmt = self.width, self.height, "yuv420p"
        self._stream.time_base = Fraction(1, 1) / self.fps
        self.n_frames = 0
        self.bytes_written = 0
        self._closed = False

    @property
    def duration_s(self) -> float:
        """Seconds of video written so far (frames / fps)."""
        return float(self.n_frames / self.fps)

    def write_episode(self, frames: np.ndarray) -> tuple[float, float]:
        """Append ``frames (T, H, W, 3)`` uint8; returns the episode's ``(from, to)``
        timestamps in this file (s)."""
        av = _av()
        frames = np.asarray(frames)
        if frames.ndim != 4 or frames.shape[1:] != (self.height, self.width, 3) or frames.dtype != np.uint8:
            raise ValueError(
                f"VideoFileWriter.write_episode: expected uint8 frames (T, {self.height}, {self.width}, 3), "
                f"got {frames.dtype} {frames.shape}"
            )
        start = self.duration_s
        for k, image in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")
            frame.pts = self.n_frames
            if k == 0:
                frame.pict_type = av.video.frame.PictureType.I
            self._mux(self._stream.encode(frame))
            self.n_frames += 1
        return start, self.duration_s

    def _mux(self, packets) -> None:
        for packet in packets:
            self.bytes_written += packet.size
            self._container.mux(packet)

    def close(self) -> None:
        """Flush the encoder and finish the file (idempotent)."""
        if not self._closed:
            self._mux(self._stream.encode(None))
            self._container.close()
            self._closed = True

    def __enter__(self) -> VideoFileWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def open_video(path: str | os.PathLike):
    """An open PyAV container of ``path`` with at least one video stream (the caller closes it).

    Raises:
        FileNotFoundError: no such file, or a directory.
        ValueError: the file cannot be decoded or has no video stream.
    """
    av = _av()
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"video file not found: {p}")
    if p.is_dir():
        raise FileNotFoundError(f"video path is a directory, not a file: {p}")
    try:
        container = av.open(str(p))
    except Exception as exc:  # av.error.InvalidDataError and friends
        raise ValueError(f"video {p}: cannot be decoded ({type(exc).__name__}: {exc})") from exc
    if not container.streams.video:
        container.close()
        raise ValueError(f"video {p}: the file has no video stream")
    return container


@dataclasses.dataclass(frozen=True)
class VideoInfo:
    """What the first video stream of a file says about itself (read from the container, no decoding).

    Attributes:
        width, height: frame size, px.
        fps: nominal frame rate (the stream's average rate), Hz; NaN when the container does not say.
        frames: frame count; 0 when the container does not say.
        duration: s; NaN when the container does not say.
        codec: decoder name, AV1 decoders reported as ``"av1"`` (``"h264"``, ``"av1"``, ...).
        pix_fmt: pixel format (``"yuv420p"``, ...).
        has_audio: the file also has an audio stream.
        base_fps: the stream's base rate, Hz (the fallback when ``fps`` is NaN).
    """

    width: int
    height: int
    fps: float
    frames: int
    duration: float
    codec: str
    pix_fmt: str
    has_audio: bool
    base_fps: float

    def lerobot_info(self) -> dict:
        """The ``info`` block lerobot stores for a video feature (``video.height``, ``video.fps``, ...)."""
        fps = self.fps if np.isfinite(self.fps) else self.base_fps
        return {
            "video.height": self.height,
            "video.width": self.width,
            "video.codec": self.codec,
            "video.pix_fmt": self.pix_fmt,
            "video.is_depth_map": False,
            "video.fps": int(fps) if fps == int(fps) else fps,
            "video.channels": 3,
            "has_audio": self.has_audio,
        }


def video_info(path: str | os.PathLike) -> VideoInfo:
    """:class:`VideoInfo` of the first video stream of ``path``.

    Raises:
        FileNotFoundError, ValueError: as :func:`open_video`.
    """
    with open_video(path) as container:
        stream = container.streams.video[0]
        ctx = stream.codec_context
        return VideoInfo(
            width=int(stream.width),
            height=int(stream.height),
            fps=float(stream.average_rate) if stream.average_rate else float("nan"),
            frames=int(stream.frames or 0),
            duration=float(stream.duration * stream.time_base) if stream.duration else float("nan"),
            codec=ctx.codec.name if ctx.codec.name not in ("libdav1d", "libaom-av1") else "av1",
            pix_fmt=ctx.pix_fmt,
            has_audio=len(container.streams.audio) > 0,
            base_fps=float(stream.base_rate) if stream.base_rate else float("nan"),
        )


def decode_video_frames(path: str | Path, timestamps, tolerance_s: float = 1e-4) -> np.ndarray:
    """Frames ``(N, H, W, 3)`` uint8 RGB at ``timestamps`` (s, in this file's clock).

    Seeks to the keyframe at or before the first timestamp and decodes forward; each
    requested timestamp must match a decoded frame's time within ``tolerance_s`` (as
    lerobot's ``decode_video_frames``), else ``ValueError`` names the gap.

    Raises:
        FileNotFoundError: no such file.
        ValueError: a timestamp has no frame within the tolerance.
    """
    av = _av()
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"video file {path} not found")
    ts = np.asarray(timestamps, dtype=np.float64).reshape(-1)
    if ts.size == 0:
        raise ValueError("decode_video_frames: no timestamps given")
    first, last = float(ts.min()), float(ts.max())
    times, images = [], []
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        tb = stream.time_base
        container.seek(max(0, int((first - tolerance_s) / tb)), stream=stream, backward=True, any_frame=False)
        for frame in container.decode(stream):
            t = float(frame.pts * tb)
            if t < first - tolerance_s:
                continue
            times.append(t)
            images.append(frame.to_ndarray(format="rgb24"))
            if t >= last - tolerance_s:
                break
    if not times:
        raise ValueError(f"{path}: no frame at or after t={first:.4f} s")
    times_a = np.asarray(times)
    idx = np.abs(times_a[None, :] - ts[:, None]).argmin(axis=1)
    gap = np.abs(times_a[idx] - ts)
    if (gap > tolerance_s).any():
        bad = int(gap.argmax())
        raise ValueError(
            f"{path}: no frame within {tolerance_s} s of t={ts[bad]:.6f} s (nearest {times_a[idx[bad]]:.6f} s); "
            "the video and the timestamps disagree"
        )
    return np.stack([images[i] for i in idx])


def write_mp4(path: str | Path, frames, fps: float, codec: str = "h264", crf: int = 23) -> Path:
    """Write a whole clip ``(T, H, W, 3)`` uint8 to ``path`` (H.264 by default, plays anywhere)."""
    frames = np.asarray(frames)
    with VideoFileWriter(
        path, fps=fps, width=frames.shape[2], height=frames.shape[1], codec=codec, crf=crf, g=12
    ) as w:
        w.write_episode(frames)
    return Path(path)


def iter_frames(
    path: str | os.PathLike, width: int | None = None, stride: int = 1, max_frames: int | None = None
) -> Iterator[tuple[int, float, np.ndarray]]:
    """Decode a video: yields ``(frame_index, t, rgb)``.

    Args:
        path: any video FFmpeg reads (mp4, mov, avi, mkv, webm, ...).
        width: resize to this width in px (aspect kept, never enlarged); None = original size.
        stride: keep every ``stride``-th frame (1 = all).
        max_frames: stop after this many kept frames.

    Yields:
        frame index in the stream (0-based), presentation time t in s (from the first frame),
        ``(H, W, 3)`` uint8 RGB image.

    Raises:
        FileNotFoundError: no such file. ValueError: not a decodable video, bad arguments.
    """
    if stride < 1 or (width is not None and width < 16) or (max_frames is not None and max_frames < 1):
        raise ValueError(
            f"iter_frames needs stride >= 1, width >= 16 or None, max_frames >= 1 or None; got "
            f"stride={stride}, width={width}, max_frames={max_frames}"
        )
    container = open_video(path)
    try:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        t0, kept, index = None, 0, -1
        try:
            for frame in container.decode(stream):
                index += 1
                if index % stride:
                    continue
                t = frame.time if frame.time is not None else index / float(stream.average_rate or 30)
                t0 = t if t0 is None else t0
                if width is not None and width < frame.width:
                    h = int(round(frame.height * width / frame.width / 2) * 2)
                    rgb = frame.to_ndarray(format="rgb24", width=width, height=h)
                else:
                    rgb = frame.to_ndarray(format="rgb24")
                yield index, float(t - t0), rgb
                kept += 1
                if max_frames is not None and kept >= max_frames:
                    return
        except Exception as exc:
            if type(exc).__module__.startswith("av"):
                raise ValueError(f"video {path}: decoding failed at frame {index + 1} ({exc})") from exc
            raise
        if index < 0:
            raise ValueError(f"video {path}: no frame could be decoded")
    finally:
        container.close()


def frame_bar(desc: str, info: VideoInfo, stride: int, max_frames: int | None):
    """A tqdm progress bar over the frames ``iter_frames(video, ..., stride, max_frames)`` yields."""
    from tqdm import tqdm

    total = info.frames // stride if info.frames else None
    if max_frames is not None and total is not None:
        total = min(total, max_frames)
    return tqdm(total=total, desc=desc, unit="frame")


def increasing_times(times) -> np.ndarray:
    """Frame times (s) as a strictly increasing array: some containers repeat a timestamp."""
    t = np.array(times, float)
    for i in range(1, len(t)):
        if t[i] <= t[i - 1]:
            t[i] = t[i - 1] + 1e-6
    return t
