"""The ``multiview`` source: several synchronised, calibrated videos of one person -> one 3-D skeleton.

Per view, MediaPipe keypoints (:func:`lfd.human.video.estimate_keypoints`, the ``settings.pose`` options);
then, over the views, the left/right labels are reconciled and views showing someone else left out
(:func:`lfd.human.multiview.reconcile_left_right`), and every landmark is triangulated by confidence-
weighted DLT, dropping the views that disagree (:func:`lfd.human.multiview.triangulate`). The result
is a :class:`lfd.human.Skeleton` in the calibration's world frame (m), analysed and retargeted like a
skeleton file. Units: s, m, px.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .settings import ImitationSettings

__all__ = ["estimate_multiview", "match_views"]


def match_views(videos: Sequence[str | os.PathLike], camera_names: Sequence[str]) -> list[Path]:
    """The videos in the calibration's camera order: by file stem when every stem names a camera
    (``cam01.mp4`` for camera ``cam01``), else in the order given.

    Raises:
        ValueError: not as many videos as cameras, or fewer than 2.
    """
    paths = [Path(str(v)) for v in videos]
    if len(paths) < 2:
        raise ValueError(f"source: a multiview source needs at least 2 videos, got {len(paths)}")
    if len(paths) != len(camera_names):
        raise ValueError(
            f"source: {len(paths)} videos for the {len(camera_names)} cameras of the calibration "
            f"({', '.join(camera_names)}); give one video per camera"
        )
    stems = {p.stem: p for p in paths}
    if len(stems) == len(paths) and set(stems) == set(camera_names):
        return [stems[n] for n in camera_names]
    return paths


def estimate_multiview(settings: ImitationSettings, videos: Sequence[str | os.PathLike], out: Path):
    """Triangulated skeleton of ``videos`` with ``settings.calibration`` (``.qca.txt``, ``.toml`` or ``.json``).

    Options: ``settings.pose`` (width, stride, max_frames, model, heavy_model, min_visibility) and
    ``settings.multiview``: ``max_error_px`` (views disagreeing more are dropped per joint and frame),
    ``other_person_px`` (null: every view shows the person), ``up`` (the world frame's up vector).
    Writes ``out/keypoints_<camera>.npz`` per view. The views are taken as synchronised: frame ``k``
    of every view is one instant (view 1's times); the shortest view sets the length.

    Returns:
        ``(skeleton, detail)``: the :class:`lfd.human.Skeleton` (landmarks triangulated by fewer than 2
        agreeing views are NaN) and a dict for the summary (views, reprojection error, relabelled frames).

    Raises:
        ValueError: no ``calibration``, fewer than 2 videos, not one video per camera, a malformed
            calibration, an undecodable video.
        FileNotFoundError: a missing video or calibration file.
    """
    from lfd.human import Skeleton
    from lfd.human.multiview import read_calibration, reconcile_left_right, triangulate
    from lfd.human.video import estimate_keypoints
    from lfd.human.video.landmarks import ALL_LEFT, ALL_RIGHT, CANONICAL_NAMES, LEFT_RIGHT_GROUPS

    if settings.calibration is None:
        raise ValueError(
            "calibration: a multiview source needs the cameras' calibration file "
            "(calibration=<.qca.txt | .toml | .json>)"
        )
    for v in videos:
        if not Path(str(v)).is_file():
            raise FileNotFoundError(f"source: no video at {v}")
    calib = read_calibration(settings.calibration)
    paths = match_views(videos, calib.names)
    mv = settings.multiview
    up = np.asarray(mv.up, float)
    kps = []
    options = settings.pose.estimator_options()
    person = options.pop("person")
    if person is None:
        for path in paths:
            kps.append(estimate_keypoints(path, **options))
    else:  # several people in view: everyone found per view, the chosen one followed across them
        from lfd.human.multiview.people import follow_person_in_videos
        from lfd.human.video.people import estimate_people

        if mv.person_view >= calib.n_cameras:
            raise ValueError(
                f"multiview.person_view must be a view in [0, {calib.n_cameras}), got {mv.person_view}"
            )
        people = [estimate_people(path, **options) for path in paths]
        kps, _ = follow_person_in_videos(
            calib, people, person, mv.person_view, videos=paths, width=options["width"],
            model=options["model"], heavy_model=options["heavy_model"],
        )  # fmt: skip
    for name, kp in zip(calib.names, kps):
        kp.save(out / f"keypoints_{name}.npz")
    T = min(k.n_frames for k in kps)
    pixels = np.stack([k.pixels[:T] for k in kps])
    conf = np.stack([k.visibility[:T] for k in kps])
    other_px = mv.other_person_px
    labels = reconcile_left_right(
        calib,
        pixels,
        conf,
        list(zip(ALL_LEFT, ALL_RIGHT)),
        groups=LEFT_RIGHT_GROUPS,
        other_person_px=None if other_px is None else float(other_px),
    )
    tri = triangulate(
        calib,
        labels.pixels,
        labels.confidence,
        min_confidence=float(settings.pose.min_visibility),
        max_error_px=float(mv.max_error_px),
    )
    tracked = np.isfinite(tri.points).all(-1)
    skeleton = Skeleton(
        kps[0].t[:T],
        CANONICAL_NAMES,
        tri.points,
        tracked,
        source=f"{len(paths)} views triangulated with {settings.calibration}",
        up=up / np.linalg.norm(up),
    )
    detail = {
        "videos": [str(p) for p in paths],
        "cameras": list(calib.names),
        "calibration": settings.calibration,
        "view_frames": T,
        "reprojection_px_median": float(np.nanmedian(tri.error)) if np.isfinite(tri.error).any() else None,
        "views_per_landmark_mean": float(tri.used.sum(0)[tracked].mean()) if tracked.any() else 0.0,
        "relabelled_frames": {n: int(s.any(1).sum()) for n, s in zip(calib.names, labels.swapped)},
        "other_person_frames": {n: int(o.sum()) for n, o in zip(calib.names, labels.other_person)},
    }
    return skeleton, detail
