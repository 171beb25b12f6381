"""Pose estimation over a whole video, following one person.

MediaPipe follows one person; when its estimate jumps to someone else (the torso centre lands
farther from where the followed person was last seen than ``max_jump + max_speed * dt`` torso
lengths, within ``reacquire_s`` seconds) the frame is searched again in a crop around the
followed person's last box; if the person is not found there the frame is marked
``other_person`` and left out. Frames without a person are kept (``detected`` False, NaN
landmarks): :func:`~lfd.human.analyze_arm` bridges short gaps and reports long ones.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

from lfd.io.video import frame_bar, increasing_times, iter_frames, video_info

from .estimator import landmarks_of, load_pose_estimator
from .keypoints import VideoKeypoints
from .landmarks import torso

__all__ = ["estimate_keypoints"]


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
    model: str = "full",
    heavy_model: str | os.PathLike | None = None,
    person=None,
    max_people: int = 4,
) -> VideoKeypoints:
    """Run the pose estimator over a video, following one person (see the module docstring).

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
        model: landmark model, ``"full"`` (in MediaPipe's wheel) or ``"heavy"`` (more accurate,
            slower; see :func:`~lfd.human.video.estimator.load_pose_estimator`). heavy_model: path
            of a verified ``pose_landmark_heavy.tflite`` (None = MediaPipe's module folder).
        person: None: MediaPipe's single-person tracker follows the most prominent person (as
            above). ``"largest"``, ``"central"``, a point ``(x, y)`` or a box ``(x0, y0, x1, y1)``
            px: everyone (up to ``max_people``) is found and followed and this person, chosen in
            the first frame with anyone, is kept (:mod:`lfd.human.video.people`); frames without
            them are marked, never filled with someone else.

    Returns:
        :class:`VideoKeypoints` (one entry per processed frame).

    Raises:
        FileNotFoundError: no such video; ``model="heavy"`` without the heavy model.
        ValueError: unreadable video, bad arguments. ImportError: mediapipe is not installed.
    """
    if person is not None:
        from .people import check_person, estimate_people

        choice = check_person(person)
        people = estimate_people(
            video,
            width=width,
            stride=stride,
            max_frames=max_frames,
            max_people=max_people,
            min_detection_confidence=min_detection_confidence,
            min_tracking_confidence=min_tracking_confidence,
            max_jump=max_jump,
            max_speed=max_speed,
            reacquire_s=reacquire_s,
            progress=progress,
            model=model,
            heavy_model=heavy_model,
        )
        return people.person(people.choose(choice))
    if not (max_jump > 0 and max_speed >= 0 and reacquire_s >= 0):
        raise ValueError(
            f"max_jump must be > 0, max_speed and reacquire_s >= 0; got {max_jump!r}, {max_speed!r}, {reacquire_s!r}"
        )
    info = video_info(video)
    tracker = load_pose_estimator(
        False, min_detection_confidence, min_tracking_confidence, model=model, heavy_model=heavy_model
    )
    searcher = None
    ts, idxs, pxs, viss, worlds, det, other = [], [], [], [], [], [], []
    last = None  # (t, centre, torso length, box) of the followed person
    bar = frame_bar(f"pose {Path(video).name}", info, stride, max_frames) if progress else None
    start = time.perf_counter()
    try:
        for index, t, rgb in iter_frames(video, width, stride, max_frames):
            h, w = rgb.shape[:2]
            scale = info.width / w
            found = landmarks_of(tracker.process(rgb), (w, h), scale=scale)
            is_other = False
            if found is not None and last is not None and t - last[0] <= reacquire_s:
                centre, _ = torso(found[0])
                if np.linalg.norm(centre - last[1]) > last[2] * (max_jump + max_speed * (t - last[0])):
                    # Someone else: look for the followed person around where they were.
                    if searcher is None:
                        searcher = load_pose_estimator(
                            True, min_detection_confidence, min_tracking_confidence, model, heavy_model
                        )
                    x0, y0, x1, y1 = (last[3] / scale).astype(int)
                    crop = np.ascontiguousarray(rgb[max(y0, 0) : max(y1, 0), max(x0, 0) : max(x1, 0)])
                    again = None
                    if crop.shape[0] > 32 and crop.shape[1] > 32:
                        again = landmarks_of(
                            searcher.process(crop),
                            (crop.shape[1], crop.shape[0]),
                            offset=(max(x0, 0) * scale, max(y0, 0) * scale),
                            scale=scale,
                        )
                    allowed = last[2] * (max_jump + max_speed * (t - last[0]))
                    if again is not None and np.linalg.norm(torso(again[0])[0] - last[1]) <= allowed:
                        found = again
                    else:
                        found, is_other = None, True
            if found is not None:
                px, vis, world = found
                centre, length = torso(px)
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
    t = increasing_times(ts)
    return VideoKeypoints(
        t=t,
        frame_index=np.array(idxs),
        pixels=np.array(pxs),
        visibility=np.array(viss),
        world=np.array(worlds),
        detected=np.array(det, bool),
        other_person=np.array(other, bool),
        image_size=(info.width, info.height),
        source=str(video),
        seconds=time.perf_counter() - start,
        model=model,
    )
