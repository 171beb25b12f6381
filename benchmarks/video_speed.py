"""Speed of video -> joint angles (decode + MediaPipe pose + analyze_arm) per landmark model, frames per second.

    python benchmarks/video_speed.py VIDEO [--width 640] [--frames 100] [--models full,heavy] [--repeats 2]

Prints frames/s of decoding alone, of the pose stage per model (runs alternate between the models,
``--repeats`` times, so that on a shared machine both see the same load; the median run is kept),
the ratio of the models' speeds, and of the whole chain to arm angles and torques for the first
model. Run on the machine whose speed you report (the README's numbers: 2 cores, shared).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from lfd.human import analyze_arm
from lfd.human.video import estimate_keypoints
from lfd.io.video import iter_frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("video")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--models", default="full,heavy")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    models = args.models.split(",")
    start = time.perf_counter()
    n = sum(1 for _ in iter_frames(args.video, args.width, max_frames=args.frames))
    decode = time.perf_counter() - start
    fps: dict[str, list[float]] = {m: [] for m in models}
    kps = {}
    for _ in range(args.repeats):
        for model in models:
            start = time.perf_counter()
            kps[model] = estimate_keypoints(args.video, width=args.width, max_frames=args.frames, model=model)
            fps[model].append(n / (time.perf_counter() - start))
    start = time.perf_counter()
    analyze_arm(kps[models[0]].to_skeleton(), side="right", max_gap=0.3)
    angles = time.perf_counter() - start
    pose = {m: float(np.median(v)) for m, v in fps.items()}
    print(f"{n} frames at {args.width} px, {os.cpu_count()} CPU cores: decode only {n / decode:.1f} fps")
    for m in models:
        print(f"  pose {m}: {pose[m]:.1f} fps (runs: {', '.join(f'{v:.1f}' for v in fps[m])})")
    if len(models) > 1:
        print(f"  speed ratio {models[1]} / {models[0]}: {pose[models[1]] / pose[models[0]]:.2f}")
    chain = n / (n / pose[models[0]] + angles)
    print(f"  video -> angles with {models[0]}: {chain:.1f} fps")


if __name__ == "__main__":
    main()
