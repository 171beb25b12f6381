"""Video of a person -> per-frame pose landmarks -> :class:`~lfd.human.Skeleton`.

Decoding is PyAV (any container/codec FFmpeg reads); frame times are the stream's
presentation timestamps (``pts * time_base``), so variable-frame-rate phone videos keep
their real clock. The pose estimator is MediaPipe Pose 0.10.14 (BlazePose GHUM, the *full*
landmark model ``pose_landmark_full.tflite`` and the detector ship inside the wheel: nothing
is downloaded). Install it with the optional extra: ``pip install "lfd[video]"``.

Per frame it keeps the 33 landmarks' pixel coordinates (of the original frame), their
visibility, and MediaPipe's metric *world* landmarks (m, origin between the hips, axes like
the camera's: x right, y down, z away from the camera). :meth:`VideoKeypoints.to_skeleton`
turns them into a :class:`Skeleton` with the canonical joint names of :mod:`lfd.human`
(``shoulder_right``, ``elbow_right``, ``wrist_right``, ``hip_left``, ...), so
:func:`lfd.human.analyze_arm` runs unchanged.

Frames without a person are kept (``detected`` False, NaN landmarks): ``analyze_arm``
bridges short gaps and reports long ones. A second person: MediaPipe follows one person;
when its estimate jumps to someone else (the torso centre lands farther from where the
followed person was last seen than ``max_jump + max_speed * dt`` torso lengths, within
``reacquire_s`` seconds) the frame is searched again in a crop around the followed person's last box; if
the person is not found there the frame is marked ``other_person`` and left out.

Example::

    >>> from lfd.human.video import estimate_keypoints          # doctest: +SKIP
    >>> kp = estimate_keypoints("person.mp4", width=640)          # doctest: +SKIP
    >>> from lfd.human import analyze_arm                         # doctest: +SKIP
    >>> result = analyze_arm(kp.to_skeleton(), side="right")      # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import io
import os
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from lfd.io.files import write_bytes_atomic

from .skeleton import Skeleton, canonical_joint_name

__all__ = [
    "MEDIAPIPE_LANDMARKS",
    "VideoKeypoints",
    "estimate_keypoints",
    "iter_frames",
    "load_pose_estimator",
    "video_info",
]

# MediaPipe Pose landmark order (BlazePose topology, 33 points).
MEDIAPIPE_LANDMARKS = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye", "right_eye_outer",
    "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder", "right_shoulder", "left_elbow",
    "right_elbow", "left_wrist", "right_wrist", "left_pinky", "right_pinky", "left_index", "right_index",
    "left_thumb", "right_thumb", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
    "right_ankle", "left_heel", "right_heel", "left_foot_index", "right_foot_index",
)  # fmt: skip
_CANONICAL_OVERRIDES = {"left_index": "hand_tip_left", "right_index": "hand_tip_right", "nose": "head"}
CANONICAL_NAMES = tuple(_CANONICAL_OVERRIDES.get(n, canonical_joint_name(n)) for n in MEDIAPIPE_LANDMARKS)
# Left/right landmark pairs (index into the 33) that decide a front/back relabelling.
# The trunk (shoulders, hips): arms move fast and legs cross in a side view of a walk.
_LEFT = [MEDIAPIPE_LANDMARKS.index(f"left_{n}") for n in ("shoulder", "hip")]
_RIGHT = [MEDIAPIPE_LANDMARKS.index(MEDIAPIPE_LANDMARKS[i].replace("left", "right")) for i in _LEFT]
_ALL_LEFT = [i for i, n in enumerate(MEDIAPIPE_LANDMARKS) if "left" in n]
_ALL_RIGHT = [MEDIAPIPE_LANDMARKS.index(MEDIAPIPE_LANDMARKS[i].replace("left", "right")) for i in _ALL_LEFT]
_TORSO = [MEDIAPIPE_LANDMARKS.index(n) for n in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")]
# Connections drawn on the video frame (arm and torso).
ARM_EDGES = (
    (11, 13),
    (13, 15),
    (12, 14),
    (14, 16),
    (11, 12),
    (11, 23),
    (12, 24),
    (23, 24),
    (15, 19),
    (16, 20),
)


# ---------------------------------------------------------------------------- decoding
def _open(path: str | os.PathLike):
    try:
        import av
    except ImportError as exc:  # pragma: no cover - av is in the [video] extra
        raise ImportError('video decoding needs PyAV: pip install "lfd[video]"') from exc
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


def video_info(path: str | os.PathLike) -> dict:
    """Width, height (px), nominal fps, frame count (0 when the container does not say) and duration (s)."""
    with _open(path) as container:
        stream = container.streams.video[0]
        rate = float(stream.average_rate) if stream.average_rate else float("nan")
        duration = float(stream.duration * stream.time_base) if stream.duration else float("nan")
        return {"width": stream.width, "height": stream.height, "fps": rate, "frames": int(stream.frames or 0),
                "duration": duration}  # fmt: skip


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
        FileNotFoundError, ValueError (not a decodable video, bad arguments).
    """
    if stride < 1 or (width is not None and width < 16) or (max_frames is not None and max_frames < 1):
        raise ValueError(f"iter_frames needs stride >= 1, width >= 16 or None, max_frames >= 1 or None; got "
                         f"stride={stride}, width={width}, max_frames={max_frames}")  # fmt: skip
    container = _open(path)
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


# ---------------------------------------------------------------------------- estimator
def _protobuf_compat() -> None:
    """MediaPipe 0.10.14's Python layer predates protobuf 5: restore the two calls it uses.

    ``GetPrototype`` was removed from the symbol database / message factory (replaced by
    ``message_factory.GetMessageClass``) and ``FieldDescriptor.label`` by ``is_repeated``;
    the solution API uses both when it sets calculator options and reads output packets.
    """
    from google.protobuf import message_factory, symbol_database

    for cls in (symbol_database.SymbolDatabase, message_factory.MessageFactory):
        if not hasattr(cls, "GetPrototype"):
            cls.GetPrototype = lambda self, descriptor: message_factory.GetMessageClass(descriptor)


def _set_calculator_options(self, config, params) -> None:
    """Replacement of ``SolutionBase._modify_calculator_options`` that works on protobuf 4 to 7."""
    from mediapipe.python.solution_base import CALCULATOR_TO_OPTIONS

    nested: dict[str, list] = {}
    for key, value in params.items():
        node_name, field = key.split(".")
        nested.setdefault(node_name, []).append((field, value))

    def apply(options, fields):
        for field, value in fields:
            fd = options.DESCRIPTOR.fields_by_name[field]
            repeated = fd.is_repeated if hasattr(fd, "is_repeated") else fd.label == fd.LABEL_REPEATED
            if value is None:
                options.ClearField(field)
            elif repeated:
                options.ClearField(field)
                getattr(options, field).extend(value)
            else:
                setattr(options, field, value)

    done = 0
    for node in config.node:
        if node.name not in nested:
            continue
        options_type = CALCULATOR_TO_OPTIONS.get(node.calculator)
        if options_type is None:
            raise ValueError(f"Modifying the calculator options of {node.name} is not supported.")
        if node.node_options:
            for elem in node.node_options:
                if elem.type_url.split("/")[-1] == options_type.DESCRIPTOR.full_name:
                    options = options_type.FromString(elem.value)
                    apply(options, nested[node.name])
                    elem.value = options.SerializeToString()
                    break
            else:
                options = options_type()
                apply(options, nested[node.name])
                node.node_options.add().Pack(options)
        else:
            apply(node.options.Extensions[options_type.ext], nested[node.name])
        done += 1
    if done < len(nested):
        raise ValueError("Not all calculator params are valid.")


def load_pose_estimator(static: bool = False, min_detection_confidence: float = 0.5,
                        min_tracking_confidence: float = 0.5):  # fmt: skip
    """A MediaPipe Pose estimator (full model, shipped in the wheel); ``static`` = no tracking.

    Raises:
        ImportError: mediapipe is not installed (``pip install "lfd[video]"``).
    """
    try:
        _protobuf_compat()
        from mediapipe.python import solution_base

        solution_base.SolutionBase._modify_calculator_options = _set_calculator_options
        from mediapipe.python.solutions import pose as mp_pose
    except ImportError as exc:
        raise ImportError(
            'the video pose estimator needs MediaPipe: pip install "lfd[video]" (mediapipe==0.10.14)'
        ) from exc
    return mp_pose.Pose(static_image_mode=static, model_complexity=1, smooth_landmarks=not static,
                        enable_segmentation=False, min_detection_confidence=min_detection_confidence,
                        min_tracking_confidence=min_tracking_confidence)  # fmt: skip


def _landmarks(result, size: tuple[int, int], offset=(0.0, 0.0), scale=1.0):
    """(33, 2) px, (33,) visibility, (33, 3) world m, or None when no person was found."""
    if result.pose_landmarks is None or result.pose_world_landmarks is None:
        return None
    w, h = size
    lm = result.pose_landmarks.landmark
    px = np.array([[p.x * w, p.y * h] for p in lm]) * scale + np.asarray(offset)
    vis = np.array([p.visibility for p in lm])
    world = np.array([[p.x, p.y, p.z] for p in result.pose_world_landmarks.landmark])
    return px, vis, world


# ---------------------------------------------------------------------------- result type
@dataclasses.dataclass(eq=False)
class VideoKeypoints:
    """Pose landmarks of one person in a video.

    Attributes:
        t: (T,) s, presentation time of each processed frame (first frame = 0).
        frame_index: (T,) int, index of the frame in the video stream.
        pixels: (T, 33, 2) px in the original frame (x right, y down); NaN where not detected.
        visibility: (T, 33) in [0, 1] (MediaPipe's visibility); 0 where not detected.
        world: (T, 33, 3) m, MediaPipe world landmarks (origin between the hips; x right,
            y down, z away from the camera); NaN where not detected.
        detected: (T,) bool, the followed person was found.
        other_person: (T,) bool, a different person was found and left out.
        image_size: (width, height) px of the original frames.
        source: the video path. seconds: wall time of the estimation, s.
    """

    t: np.ndarray
    frame_index: np.ndarray
    pixels: np.ndarray
    visibility: np.ndarray
    world: np.ndarray
    detected: np.ndarray
    other_person: np.ndarray
    image_size: tuple[int, int]
    source: str = ""
    seconds: float = float("nan")
    names: tuple[str, ...] = MEDIAPIPE_LANDMARKS

    @property
    def n_frames(self) -> int:
        return len(self.t)

    @property
    def fps(self) -> float:
        """Frames processed per second of wall time (estimation speed)."""
        return self.n_frames / self.seconds if self.seconds > 0 else float("nan")

    def front_back_flips(self, switch: float = 0.5) -> np.ndarray:
        """(T,) bool: frames whose left/right labels MediaPipe swapped (front/back confusion).

        BlazePose sometimes decides in one frame that a person facing the camera has turned
        their back to it (or the reverse): every left landmark takes the right one's place in
        the image. A real turn moves the landmarks continuously, so the labelling of each
        detected frame (as given, or swapped) is chosen by dynamic programming to minimise the
        summed pixel distance of the trunk landmarks (shoulders, hips) from one detected frame to
        the next, plus ``switch`` torso lengths for every change of labelling (so ambiguous,
        side-on frames do not toggle it); of the two global labellings the one MediaPipe gave
        for most frames is kept. Returns the frames to swap.
        """
        if switch < 0:
            raise ValueError(f"switch must be >= 0 (torso lengths per change of labelling), got {switch!r}")
        frames = np.nonzero(self.detected)[0]
        flips = np.zeros(self.n_frames, bool)
        if len(frames) == 0:
            return flips
        px = self.pixels[frames]
        torso = np.median([_torso(p)[1] for p in px])
        direct = (np.linalg.norm(px[1:, _LEFT] - px[:-1, _LEFT], axis=-1)
                  + np.linalg.norm(px[1:, _RIGHT] - px[:-1, _RIGHT], axis=-1)).sum(1)  # fmt: skip
        cross = (np.linalg.norm(px[1:, _RIGHT] - px[:-1, _LEFT], axis=-1)
                 + np.linalg.norm(px[1:, _LEFT] - px[:-1, _RIGHT], axis=-1)).sum(1)  # fmt: skip
        direct, cross = np.nan_to_num(direct, nan=0.0), np.nan_to_num(cross, nan=0.0)
        n = len(frames)
        cost = np.zeros(2)  # state 0: labels as given, 1: swapped
        back = np.zeros((n, 2), int)
        for i in range(1, n):
            stay = cost + direct[i - 1]  # same state as the previous frame
            move = cost[::-1] + cross[i - 1] + switch * torso  # the other state
            back[i] = np.where(stay <= move, [0, 1], [1, 0])
            cost = np.minimum(stay, move)
        state = np.zeros(n, int)
        state[-1] = int(np.argmin(cost))
        for i in range(n - 1, 0, -1):
            state[i - 1] = back[i, state[i]]
        flips[frames] = state.astype(bool)
        if flips[frames].mean() > 0.5:
            flips[frames] = ~flips[frames]
        return flips

    def repaired(self, switch: float = 0.5) -> VideoKeypoints:
        """A copy with the :meth:`front_back_flips` undone: left/right landmarks swapped back and
        the world landmarks' depth mirrored (``z -> -z`` about the hips: the relabelled estimate
        is the mirror image of the person through the image plane)."""
        flips = self.front_back_flips(switch)
        out = dataclasses.replace(
            self, pixels=self.pixels.copy(), visibility=self.visibility.copy(), world=self.world.copy()
        )
        for arr in (out.pixels, out.visibility, out.world):
            sub = arr[flips]
            sub[:, _ALL_LEFT], sub[:, _ALL_RIGHT] = arr[flips][:, _ALL_RIGHT], arr[flips][:, _ALL_LEFT]
            arr[flips] = sub
        out.world[flips, :, 2] *= -1.0
        return out

    def to_skeleton(self, min_visibility: float = 0.5, repair_flips: bool = False) -> Skeleton:
        """A :class:`Skeleton` of the world landmarks with canonical joint names.

        Landmarks with visibility below ``min_visibility`` are marked untracked (treated as
        missing by :func:`~lfd.human.analyze_arm`); ``up`` is ``(0, -1, 0)`` (MediaPipe's y
        points down). With ``repair_flips`` the frames MediaPipe labelled back to front are
        repaired first (:meth:`repaired`; reliable for a person facing the camera, not for a
        side view of a walk, where the global labelling is ambiguous). Raises ``ValueError`` when no frame has a person.
        """
        if not 0.0 <= min_visibility <= 1.0:
            raise ValueError(f"min_visibility must be in [0, 1], got {min_visibility!r}")
        if not self.detected.any():
            raise ValueError(
                f"no person found in any of the {self.n_frames} frames of {self.source or 'the video'}"
            )
        kp = self.repaired() if repair_flips else self
        tracked = (kp.visibility >= min_visibility) & kp.detected[:, None]
        return Skeleton(kp.t, CANONICAL_NAMES, kp.world, tracked, source=f"{kp.source} (mediapipe)",
                        up=np.array([0.0, -1.0, 0.0]))  # fmt: skip

    def points(self, names) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (T, K, 2) and visibility (T, K) of landmarks by MediaPipe or canonical name."""
        idx = [self.names.index(n) if n in self.names else CANONICAL_NAMES.index(n) for n in names]
        return self.pixels[:, idx], self.visibility[:, idx]

    def table(self) -> dict[str, np.ndarray]:
        """Per-frame columns: time, frame, flags, and per landmark px, py, visibility, X, Y, Z (m)."""
        cols = {"time_s": self.t, "frame": self.frame_index.astype(float), "detected": self.detected.astype(float),
                "other_person": self.other_person.astype(float)}  # fmt: skip
        for j, name in enumerate(CANONICAL_NAMES):
            cols[f"{name}_px"], cols[f"{name}_py"] = self.pixels[:, j, 0], self.pixels[:, j, 1]
            cols[f"{name}_visibility"] = self.visibility[:, j]
            for k, axis in enumerate("xyz"):
                cols[f"{name}_{axis}_m"] = self.world[:, j, k]
        return cols

    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write :meth:`table` as CSV (NaN as empty). Returns the path."""
        from .analysis import _atomic_write

        cols = self.table()
        data = np.column_stack(list(cols.values()))
        lines = [",".join(cols)] + [
            ",".join("" if not np.isfinite(v) else f"{v:.6g}" for v in row) for row in data
        ]
        return _atomic_write(path, "\n".join(lines) + "\n")

    def save(self, path: str | os.PathLike) -> Path:
        """Write all arrays to an ``.npz`` cache (read back with :meth:`load`)."""
        buffer = io.BytesIO()
        np.savez_compressed(buffer, t=self.t, frame_index=self.frame_index, pixels=self.pixels, visibility=self.visibility,
                            world=self.world, detected=self.detected, other_person=self.other_person,
                            image_size=np.array(self.image_size), source=np.array(self.source),
                            seconds=np.array(self.seconds))  # fmt: skip
        write_bytes_atomic(Path(path), buffer.getvalue())
        return Path(path)

    @classmethod
    def load(cls, path: str | os.PathLike) -> VideoKeypoints:
        """Read a cache written by :meth:`save`."""
        p = Path(path)
        if not p.exists():
            raise FileNotFoundError(f"keypoint cache not found: {p}")
        with np.load(p) as z:
            return cls(t=z["t"], frame_index=z["frame_index"], pixels=z["pixels"], visibility=z["visibility"],
                       world=z["world"], detected=z["detected"], other_person=z["other_person"],
                       image_size=tuple(int(v) for v in z["image_size"]), source=str(z["source"]),
                       seconds=float(z["seconds"]))  # fmt: skip


def _torso(px: np.ndarray) -> tuple[np.ndarray, float]:
    pts = px[_TORSO]
    centre = pts.mean(0)
    length = float(np.linalg.norm(pts[:2].mean(0) - pts[2:].mean(0)))
    return centre, max(length, 1.0)


def estimate_keypoints(
    video: str | os.PathLike,
    *,
    width: int | None = 640,
    stride: int = 1,
    max_frames: int | None = None,
    min_detection_confidence: float = 0.5,
    min_tracking_confidence: float = 0.5,
    max_jump: float = 0.5,
    max_speed: float = 3.0,
    reacquire_s: float = 1.0,
    progress: bool = False,
) -> VideoKeypoints:
    """Run the pose estimator over a video (see the module docstring).

    Args:
        video: path of the video file.
        width: frames are resized to this width (px) before estimation (None = original);
            landmarks are reported in original-frame pixels.
        stride: process every ``stride``-th frame. max_frames: at most this many frames.
        min_detection_confidence, min_tracking_confidence: MediaPipe thresholds.
        max_jump, max_speed: the followed person's torso centre may move ``max_jump + max_speed * dt``
            torso lengths in ``dt`` seconds since they were last seen; farther is a different person.
        reacquire_s: s; after this long without the person, whoever is found is accepted.
        progress: show a tqdm progress bar over frames.

    Returns:
        :class:`VideoKeypoints` (one entry per processed frame).

    Raises:
        FileNotFoundError, ValueError (unreadable video, bad arguments), ImportError (no mediapipe).
    """
    if not (max_jump > 0 and max_speed >= 0 and reacquire_s >= 0):
        raise ValueError(
            f"max_jump must be > 0, max_speed and reacquire_s >= 0; got {max_jump!r}, {max_speed!r}, {reacquire_s!r}"
        )
    info = video_info(video)
    tracker = load_pose_estimator(False, min_detection_confidence, min_tracking_confidence)
    searcher = None
    ts, idxs, pxs, viss, worlds, det, other = [], [], [], [], [], [], []
    last = None  # (t, centre, torso length, box) of the followed person
    total = info["frames"] // stride if info["frames"] else None
    if max_frames is not None and total is not None:
        total = min(total, max_frames)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=total, desc=f"pose {Path(video).name}", unit="frame")
    start = time.perf_counter()
    try:
        for index, t, rgb in iter_frames(video, width, stride, max_frames):
            h, w = rgb.shape[:2]
            scale = info["width"] / w
            found = _landmarks(tracker.process(rgb), (w, h), scale=scale)
            is_other = False
            if found is not None and last is not None and t - last[0] <= reacquire_s:
                centre, _ = _torso(found[0])
                if np.linalg.norm(centre - last[1]) > last[2] * (max_jump + max_speed * (t - last[0])):
                    # Someone else: look for the followed person around where they were.
                    if searcher is None:
                        searcher = load_pose_estimator(
                            True, min_detection_confidence, min_tracking_confidence
                        )
                    x0, y0, x1, y1 = (last[3] / scale).astype(int)
                    crop = np.ascontiguousarray(rgb[max(y0, 0) : max(y1, 0), max(x0, 0) : max(x1, 0)])
                    again = None
                    if crop.shape[0] > 32 and crop.shape[1] > 32:
                        again = _landmarks(searcher.process(crop), (crop.shape[1], crop.shape[0]),
                                           offset=(max(x0, 0) * scale, max(y0, 0) * scale), scale=scale)  # fmt: skip
                    allowed = last[2] * (max_jump + max_speed * (t - last[0]))
                    if again is not None and np.linalg.norm(_torso(again[0])[0] - last[1]) <= allowed:
                        found = again
                    else:
                        found, is_other = None, True
            if found is not None:
                px, vis, world = found
                centre, length = _torso(px)
                lo, hi = px.min(0), px.max(0)
                pad = 0.5 * (hi - lo).max()
                last = (t, centre, length, np.concatenate([lo - pad, hi + pad]))
            else:
                px, vis, world = np.full((33, 2), np.nan), np.zeros(33), np.full((33, 3), np.nan)
            ts.append(t)
            idxs.append(index)
            pxs.append(px)
            viss.append(vis)
            worlds.append(world)
            det.append(found is not None)
            other.append(is_other)
            if bar is not None:
                bar.update(1)
    finally:
        tracker.close()
        if searcher is not None:
            searcher.close()
        if bar is not None:
            bar.close()
    t = np.array(ts)
    # Some containers repeat a timestamp; keep the clock strictly increasing.
    for i in range(1, len(t)):
        if t[i] <= t[i - 1]:
            t[i] = t[i - 1] + 1e-6
    return VideoKeypoints(t=t, frame_index=np.array(idxs), pixels=np.array(pxs), visibility=np.array(viss),
                          world=np.array(worlds), detected=np.array(det, bool), other_person=np.array(other, bool),
                          image_size=(info["width"], info["height"]), source=str(video),
                          seconds=time.perf_counter() - start)  # fmt: skip
