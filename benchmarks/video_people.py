"""Who is followed when several people are in view: MediaPipe's single-person tracker against lfd's
person following, per view, on Pose2Sim's ``Demo_MultiPerson``.

    python benchmarks/video_people.py --demo <Pose2Sim/Demo_MultiPerson> [--cache kp/] [--person largest --reference 2]

The demo's four synchronised views show a bare-chested man exercising and a woman in a white
T-shirt (and, in cam02, a bystander in dark clothes). The man is the person to follow; he is the
largest person in cam03's first frame (``--person largest --reference 2``).

Identity reference, independent of both methods (neither looks at colour): the share of skin
pixels (OpenCV HSV hue <= 25 and saturation >= 45) inside the followed person's shoulder-hip
quadrilateral in the original frame; at least half is the man, less someone else (the woman's
shirt has saturation <= 30, the bystander's clothes hue ~30). The thresholds were read off 40
frames (10 per view); the frames where the man stands with his back against the woman (cam03,
frames 80-99) were checked by eye: there a detection on the man covers part of her shirt too.

Prints JSON: per method and view, ``kept`` (frames where the man is followed), ``someone_else``
(frames showing another person) and ``missing`` (frames with nobody followed), of ``frames``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import numpy as np

from lfd.human.multiview import read_calibration
from lfd.human.multiview.people import follow_person_in_videos
from lfd.human.video import VideoKeypoints, estimate_keypoints
from lfd.human.video.people import VideoPeople, estimate_people


def is_the_man(frame_bgr: np.ndarray, px: np.ndarray) -> bool:
    """The torso colour reference (see the module docstring) for one person's (33, 2) px."""
    mask = np.zeros(frame_bgr.shape[:2], np.uint8)
    cv2.fillPoly(mask, [px[[11, 12, 24, 23]].astype(np.int32)], 1)
    if not mask.any():
        return False
    hue, sat, _ = cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2HSV)[mask > 0].T.astype(float)
    skin = (hue <= 25) & (sat >= 45)
    return bool(skin.mean() >= 0.5)


def score(video: Path, kp: VideoKeypoints) -> dict:
    cap = cv2.VideoCapture(str(video))
    counts = {"kept": 0, "someone_else": 0, "missing": 0, "frames": kp.n_frames}
    for f in range(kp.n_frames):
        ok, frame = cap.read()
        if not ok:
            break
        if not kp.detected[f] or not np.isfinite(kp.pixels[f][[11, 12, 23, 24]]).all():
            counts["missing"] += 1
        elif is_the_man(frame, kp.pixels[f]):
            counts["kept"] += 1
        else:
            counts["someone_else"] += 1
    cap.release()
    return counts


def cached(path: Path | None, load, make):
    if path is not None and path.exists():
        return load(path)
    value = make()
    if path is not None:
        value.save(path)
    return value


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--demo", required=True, type=Path)
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument("--model", default="full")
    ap.add_argument("--person", default="largest", help="largest, central, x,y or x0,y0,x1,y1 px")
    ap.add_argument("--reference", type=int, default=2, help="view (index) in which --person is chosen")
    args = ap.parse_args()
    calib = read_calibration(args.demo / "calibration" / "Calib.qca.txt", n_cameras=4)
    videos = [args.demo / "videos" / f"{name}.mp4" for name in calib.names]
    if args.cache:
        args.cache.mkdir(parents=True, exist_ok=True)

    def at(name: str) -> Path | None:
        return args.cache / name if args.cache else None

    single = [
        cached(
            at(f"{n}_{args.model}.npz"),
            VideoKeypoints.load,
            lambda v=v: estimate_keypoints(v, model=args.model),
        )
        for n, v in zip(calib.names, videos)
    ]
    people = [
        cached(
            at(f"{n}_{args.model}_people.npz"),
            VideoPeople.load,
            lambda v=v: estimate_people(v, model=args.model),
        )
        for n, v in zip(calib.names, videos)
    ]
    choice = (
        args.person if args.person in ("largest", "central") else [float(x) for x in args.person.split(",")]
    )
    followed, _ = follow_person_in_videos(
        calib, people, choice, args.reference, videos=videos, model=args.model
    )
    result = {
        "single_person_tracker": {n: score(v, kp) for n, v, kp in zip(calib.names, videos, single)},
        "person_followed_across_views": {n: score(v, kp) for n, v, kp in zip(calib.names, videos, followed)},
    }
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
