"""Monocular vs 4-view triangulated arm angles on the Pose2Sim demo, and pose-estimation speed.

    python benchmarks/video_multiview.py --demo <Pose2Sim/Demo_SinglePerson> [--cache kp_cache/]

Runs MediaPipe on the 4 synchronised views (keypoints cached as .npz), triangulates them with
the Qualisys calibration (confidence-weighted DLT, outlier views rejected), and prints the
reprojection error and, per camera, the RMSE (deg) of elbow flexion and shoulder elevation of
the monocular estimate against the triangulated reference, plus the estimator's frames/s.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from lfd.human import Skeleton, analyze_arm
from lfd.human.multiview import read_calibration, triangulate
from lfd.human.video import CANONICAL_NAMES, VideoKeypoints, estimate_keypoints


def arm_angles(skeleton: Skeleton, side: str) -> np.ndarray:
    """(T, 2) deg: elbow flexion and shoulder elevation (upper arm vs the trunk's down axis)."""
    a = analyze_arm(skeleton, side=side, max_gap=0.3)
    u = a.positions[:, 1] - a.positions[:, 0]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    elevation = np.degrees(np.arccos(np.clip(-u[:, 2], -1, 1)))
    fore = a.positions[:, 2] - a.positions[:, 1]
    fore /= np.linalg.norm(fore, axis=1, keepdims=True)
    elbow = np.degrees(np.arccos(np.clip((u * fore).sum(1), -1, 1)))
    return np.stack([elbow, elevation], 1)


def main() -> dict:
    ap = argparse.ArgumentParser()
    ap.add_argument("--demo", required=True, type=Path)
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument(
        "--repair",
        action="store_true",
        help="undo MediaPipe's front/back relabelling (VideoKeypoints.repaired)",
    )
    ap.add_argument("--strategy", default="greedy", choices=("subsets", "greedy"))
    ap.add_argument("--max-error-px", type=float, default=20.0)
    args = ap.parse_args()
    calib = read_calibration(args.demo / "calibration" / "Calib.qca.txt", n_cameras=4)
    kps = []
    for name in calib.names:
        cache = args.cache / f"{name}.npz" if args.cache else None
        if cache is not None and cache.exists():
            kps.append(VideoKeypoints.load(cache))
            continue
        kp = estimate_keypoints(args.demo / "videos" / f"{name}.mp4", width=args.width, progress=True)
        if cache is not None:
            kp.save(cache)
        kps.append(kp)
    if args.repair:
        kps = [
            k.repaired() for k in kps
        ]  # MediaPipe's front/back relabelling undone (VideoKeypoints.repaired)
    T = min(k.n_frames for k in kps)
    pixels = np.stack([k.pixels[:T] for k in kps])
    conf = np.stack([k.visibility[:T] for k in kps])
    tri = triangulate(calib, pixels, conf, strategy=args.strategy, max_error_px=args.max_error_px)
    arm = [
        CANONICAL_NAMES.index(f"{p}_{s}") for p in ("shoulder", "elbow", "wrist") for s in ("left", "right")
    ]
    reproj = tri.error[:, arm]
    ref = Skeleton(
        kps[0].t[:T], CANONICAL_NAMES, tri.points, source="triangulated", up=np.array([0.0, 0.0, 1.0])
    )
    out = {"frames": T, "reprojection_px_median_arm": float(np.nanmedian(reproj)),
           "reprojection_px_median_all": float(np.nanmedian(tri.error)),
           "views_per_arm_joint": float(tri.used[:, :, arm].sum(0).mean()),
           "pose_fps": [k.fps for k in kps], "rmse_deg": {}}  # fmt: skip
    rows = []
    for side in ("right", "left"):
        reference = arm_angles(ref, side)
        for name, kp in zip(calib.names, kps):
            mono = arm_angles(kp.to_skeleton(repair_flips=False), side)[:T]  # already repaired (or not)
            ok = np.isfinite(mono).all(1) & np.isfinite(reference).all(1)
            rmse = np.sqrt(np.mean((mono[ok] - reference[ok]) ** 2, axis=0))
            out["rmse_deg"][f"{name}_{side}"] = {"elbow_flexion": float(rmse[0]), "shoulder_elevation": float(rmse[1]),
                                                 "frames": int(ok.sum())}  # fmt: skip
            rows += [rmse[0], rmse[1]]
    out["median_rmse_deg"] = float(np.median(rows))
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
