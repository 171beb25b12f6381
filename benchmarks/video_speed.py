"""Speed of video -> joint angles (decode + MediaPipe pose + analyze_arm), frames per second.

    python benchmarks/video_speed.py VIDEO [--width 640] [--frames 150]

Prints frames/s of decoding alone, of the pose stage, and of the whole chain to arm angles
and torques (decoding's share of the chain shows how much the estimator costs).
"""

from __future__ import annotations

import argparse
import time

from lfd.human import analyze_arm
from lfd.human.video import estimate_keypoints
from lfd.io.video import iter_frames


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("video")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--frames", type=int, default=150)
    args = ap.parse_args()
    start = time.perf_counter()
    n = sum(1 for _ in iter_frames(args.video, args.width, max_frames=args.frames))
    decode = time.perf_counter() - start
    start = time.perf_counter()
    kp = estimate_keypoints(args.video, width=args.width, max_frames=args.frames)
    pose = time.perf_counter() - start
    start = time.perf_counter()
    analyze_arm(kp.to_skeleton(), side="right", max_gap=0.3)
    angles = time.perf_counter() - start
    print(
        f"{n} frames at {args.width} px: decode only {n / decode:.1f} fps, pose {n / pose:.1f} fps, "
        f"video -> angles {n / (pose + angles):.1f} fps (decode is {decode / (pose + angles):.0%} of the chain)"
    )


if __name__ == "__main__":
    main()
