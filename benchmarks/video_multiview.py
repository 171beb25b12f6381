"""Monocular vs 4-view triangulated arm angles on a Pose2Sim demo, per landmark model (full, heavy).

    python benchmarks/video_multiview.py --demo <Pose2Sim/Demo_SinglePerson> [--cache kp/] [--models full,heavy]

Runs MediaPipe on the 4 synchronised views (640 px; keypoints cached as ``<cache>/<view>_<model>.npz``),
reconciles each view's left/right labels and leaves out views that show someone else
(:func:`lfd.human.multiview.reconcile_left_right`, ``--no-reconcile`` to skip), triangulates with the
Qualisys calibration (confidence-weighted DLT; worst views dropped above ``--max-error-px``, and
once with all views kept), and prints as JSON per model:

* ``flips``: frames per view whose labels MediaPipe swapped front/back (``VideoKeypoints.front_back_flips``);
* ``reprojection_px_median_arm`` / ``..._all_views``: median reprojection error of the shoulders,
  elbows and wrists, with rejection (views showing someone else and joints' worst views) / with
  every view kept (labels reconciled, nothing left out);
* ``monocular_median_abs_deg``: median over views, arms and frames of |monocular - triangulated| for
  elbow flexion (angle between upper arm and forearm) and shoulder elevation (angle between the
  upper arm and the trunk's downward axis, hips' midpoint minus shoulders' midpoint), both from 3-D
  keypoint geometry, after the same zero-phase Butterworth low-pass of both (``--cutoff`` Hz, 6 as
  ``analyze_arm``'s default; ``..._raw``: unfiltered); views showing someone else are left out of it;
* ``monocular_lifted_median_abs_deg``: the same with the arms' depth lifted from bone lengths
  (:func:`lfd.human.video.lifting.lift_arm_depth`), over all frames and over the first half
  (``validation``: its length percentile was chosen there) and the second half (``test``);
  ``monocular_halves_median_abs_deg``: the world landmarks' errors on the same halves;
* ``monocular_lifted_median_abs_deg_visible_arm``: the lifted errors over the frames where the arm's
  shoulder, elbow and wrist all have visibility >= 0.5 (imitation's ``pose.min_visibility``
  treats landmarks below as missing);
* ``depth_sign_agreement``: per view, upper arm and forearm (both arms), the fraction of frames in
  which the world landmarks' depth difference along the segment has the sign of the triangulated
  one in that camera's frame (where the latter exceeds 3 cm): lifting takes only this sign;
* ``arms``: per arm ``measured`` or why it cannot be analysed (the other arm is still measured);
* ``pose_fps``: the estimator's frames/s per view (noisy on a shared machine: see video_speed.py).

With ``--person`` (several people in view) every view's people are found and followed
(:func:`lfd.human.video.people.estimate_people`, cached as ``<view>_<model>_people.npz``) and the
person chosen in view ``--reference`` is followed across the views
(:func:`lfd.human.multiview.people.follow_person_in_videos`); the rest is the same.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from lfd.human.filters import butterworth_filter
from lfd.human.multiview import read_calibration, reconcile_left_right, triangulate
from lfd.human.multiview.people import follow_person_in_videos
from lfd.human.video import MEDIAPIPE_LANDMARKS, VideoKeypoints, estimate_keypoints
from lfd.human.video.landmarks import ALL_LEFT, ALL_RIGHT, LEFT_RIGHT_GROUPS
from lfd.human.video.lifting import lift_arm_depth
from lfd.human.video.people import VideoPeople, estimate_people

SIDES = ("left", "right")
#: px; a view fitting the others worse than this shows someone else (chosen on the single-person
#: demo, where no view is left out with it; 30 px already drops good side views there).
OTHER_PERSON_PX = 50.0


def idx(name: str) -> int:
    return MEDIAPIPE_LANDMARKS.index(name)


def arm_angles(points: np.ndarray, side: str) -> np.ndarray:
    """(T, 2) deg, elbow flexion and shoulder elevation of ``points`` (T, 33, 3) (NaN where a joint is missing)."""
    sh, el, wr = (points[:, idx(f"{side}_{j}")] for j in ("shoulder", "elbow", "wrist"))
    down = points[:, [idx("left_hip"), idx("right_hip")]].mean(1) - points[
        :, [idx("left_shoulder"), idx("right_shoulder")]
    ].mean(1)

    def angle(a, b):
        with np.errstate(invalid="ignore"):
            cos = (a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        return np.degrees(np.arccos(np.clip(cos, -1, 1)))

    return np.stack([angle(el - sh, wr - el), angle(el - sh, down)], 1)


def keypoints(demo: Path, names, model: str, width: int, cache: Path | None) -> list[VideoKeypoints]:
    out = []
    for name in names:
        path = cache / f"{name}_{model}.npz" if cache else None
        if path is not None and path.exists():
            out.append(VideoKeypoints.load(path))
            continue
        kp = estimate_keypoints(demo / "videos" / f"{name}.mp4", width=width, model=model, progress=True)
        if path is not None:
            kp.save(path)
        out.append(kp)
    return out


def people_keypoints(demo: Path, calib, model: str, width: int, cache: Path | None, choice, reference: int):
    """Everyone in every view (cached as ``<cache>/<view>_<model>_people.npz``), then the chosen
    person followed across the views with crop searches."""
    people = []
    for name in calib.names:
        path = cache / f"{name}_{model}_people.npz" if cache else None
        if path is not None and path.exists():
            people.append(VideoPeople.load(path))
            continue
        found = estimate_people(demo / "videos" / f"{name}.mp4", width=width, model=model, progress=True)
        if path is not None:
            found.save(path)
        people.append(found)
    videos = [demo / "videos" / f"{name}.mp4" for name in calib.names]
    kps, _ = follow_person_in_videos(
        calib, people, choice, reference, videos=videos, width=width, model=model
    )
    return kps


def evaluate(calib, kps: list[VideoKeypoints], args) -> dict:
    T = min(k.n_frames for k in kps)
    pixels = np.stack([k.pixels[:T] for k in kps])
    conf = np.stack([k.visibility[:T] for k in kps])
    other = np.zeros(pixels.shape[:2], bool)
    out: dict = {
        "frames": T,
        "flips": {n: int(k.front_back_flips()[:T].sum()) for n, k in zip(calib.names, kps)},
    }
    kept_px, kept_conf = pixels, conf
    if not args.no_reconcile:
        pairs = list(zip(ALL_LEFT, ALL_RIGHT))
        labels = reconcile_left_right(
            calib, pixels, conf, pairs, groups=LEFT_RIGHT_GROUPS, other_person_px=OTHER_PERSON_PX
        )
        # "All views kept": labels reconciled, but no view left out.
        every = reconcile_left_right(calib, pixels, conf, pairs, groups=LEFT_RIGHT_GROUPS)
        kept_px, kept_conf = every.pixels, every.confidence
        pixels, conf, other = labels.pixels, labels.confidence, labels.other_person
        out["relabelled_frames"] = {n: int(s.any(1).sum()) for n, s in zip(calib.names, labels.swapped)}
        out["other_person_frames"] = {n: int(o.sum()) for n, o in zip(calib.names, other)}
    arm = [idx(f"{s}_{j}") for j in ("shoulder", "elbow", "wrist") for s in SIDES]
    kept = triangulate(calib, kept_px, kept_conf, max_error_px=math.inf)
    tri = triangulate(calib, pixels, conf, strategy=args.strategy, max_error_px=args.max_error_px)
    out["reprojection_px_median_arm"] = float(np.nanmedian(tri.error[:, arm]))
    out["reprojection_px_median_arm_all_views"] = float(np.nanmedian(kept.error[:, arm]))
    out["reprojection_px_median_all_joints"] = float(np.nanmedian(tri.error))
    out["reprojection_px_per_arm_joint"] = {
        MEDIAPIPE_LANDMARKS[j]: float(np.nanmedian(tri.error[:, j]))
        if np.isfinite(tri.error[:, j]).any()
        else None
        for j in arm
    }
    out["views_per_arm_joint"] = float(tri.used[:, :, arm].sum(0).mean())
    out["pose_fps"] = {n: k.fps for n, k in zip(calib.names, kps)}
    rate = 1.0 / np.median(np.diff(kps[0].t[:T]))

    def smooth(points):
        return butterworth_filter(points, rate, args.cutoff) if args.cutoff > 0 else points

    out["arms"], out["rmse_deg"], errors, raw_errors = {}, {}, [], []
    halves = {"world": [], "lifted": []}  # (abs error (N, 2), frame (N,)) per view and arm
    visible = []  # lifted abs errors (N, 2) where the arm's three landmarks have visibility >= 0.5
    lifted = [lift_arm_depth(k.pixels[:T], k.world[:T]) for k in kps]
    out["depth_sign_agreement"] = {}
    for c, (name, kp) in enumerate(zip(calib.names, kps)):
        cam = tri.points @ calib.R[c].T + calib.t[c]  # the reference in camera c's frame
        agree = {}
        for seg, (a, b) in (("upper_arm", ("shoulder", "elbow")), ("forearm", ("elbow", "wrist"))):
            ia, ib = [idx(f"{s}_{a}") for s in SIDES], [idx(f"{s}_{b}") for s in SIDES]
            ref_dz, mono_dz = cam[:, ib, 2] - cam[:, ia, 2], kp.world[:T, ib, 2] - kp.world[:T, ia, 2]
            with np.errstate(invalid="ignore"):
                ok = (np.abs(ref_dz) > 0.03) & np.isfinite(mono_dz) & ~other[c][:, None]
            agree[seg] = float(np.mean(np.sign(ref_dz[ok]) == np.sign(mono_dz[ok]))) if ok.any() else None
        out["depth_sign_agreement"][name] = agree
    for side in SIDES:
        reference, reference_raw = arm_angles(smooth(tri.points), side), arm_angles(tri.points, side)
        ok_ref = np.isfinite(reference).all(1)
        if not ok_ref.any():
            missing = [
                j
                for j in ("shoulder", "elbow", "wrist")
                if not np.isfinite(tri.points[:, idx(f"{side}_{j}")]).all(1).any()
            ]
            out["arms"][side] = (
                "not analysable: no frame with both shoulders, both hips, elbow and wrist triangulated "
                f"(never: {', '.join(missing) or 'hips'})"
            )
            continue
        out["arms"][side] = f"measured on {int(ok_ref.sum())} frames"
        for c, (name, kp) in enumerate(zip(calib.names, kps)):
            mono = arm_angles(smooth(kp.world[:T]), side)
            ok = np.isfinite(mono).all(1) & ok_ref & ~other[c]
            raw_errors.append(np.abs(arm_angles(kp.world[:T], side) - reference_raw)[ok])
            if not ok.any():
                out["rmse_deg"][f"{name}_{side}"] = "no frame (the view shows someone else)"
                continue
            diff = mono[ok] - reference[ok]
            errors.append(np.abs(diff))
            frames = np.flatnonzero(ok)
            halves["world"].append((np.abs(diff), frames))
            lift = arm_angles(smooth(lifted[c]), side)
            ok_l = ok & np.isfinite(lift).all(1)
            halves["lifted"].append((np.abs(lift - reference)[ok_l], np.flatnonzero(ok_l)))
            arm_seen = kp.visibility[:T][:, [idx(f"{side}_{j}") for j in ("shoulder", "elbow", "wrist")]].min(
                1
            )
            visible.append(np.abs(lift - reference)[ok_l & (arm_seen >= 0.5)])
            rmse = np.sqrt(np.mean(diff**2, axis=0))
            out["rmse_deg"][f"{name}_{side}"] = {
                "elbow_flexion": float(rmse[0]),
                "shoulder_elevation": float(rmse[1]),
                "frames": int(ok.sum()),
            }
    if errors:
        med = np.median(np.concatenate(errors), axis=0)
        out["monocular_median_abs_deg"] = {
            "elbow_flexion": float(med[0]),
            "shoulder_elevation": float(med[1]),
        }
        med = np.nanmedian(np.concatenate(raw_errors), axis=0)
        out["monocular_median_abs_deg_raw"] = {
            "elbow_flexion": float(med[0]),
            "shoulder_elevation": float(med[1]),
        }
        rms = [
            v[k]
            for v in out["rmse_deg"].values()
            if isinstance(v, dict)
            for k in ("elbow_flexion", "shoulder_elevation")
        ]
        out["median_rmse_deg"] = float(np.median(rms))
        seen = np.concatenate(visible)
        out["monocular_lifted_median_abs_deg_visible_arm"] = {
            "elbow_flexion": float(np.median(seen[:, 0])) if len(seen) else None,
            "shoulder_elevation": float(np.median(seen[:, 1])) if len(seen) else None,
            "samples": int(len(seen)),
        }
        for variant, key in (
            ("lifted", "monocular_lifted_median_abs_deg"),
            ("world", "monocular_halves_median_abs_deg"),
        ):
            err = np.concatenate([e for e, _ in halves[variant]])
            frame = np.concatenate([f for _, f in halves[variant]])
            out[key] = {
                part: dict(zip(("elbow_flexion", "shoulder_elevation"), np.median(err[sel], 0).tolist()))
                for part, sel in (
                    ("all", np.ones(len(frame), bool)),
                    ("validation", frame < T // 2),
                    ("test", frame >= T // 2),
                )
            }
    return out


def main() -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--demo", required=True, type=Path)
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument("--models", default="full", help="comma-separated landmark models: full, heavy")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument(
        "--no-reconcile", action="store_true", help="triangulate the labels as MediaPipe gave them"
    )
    ap.add_argument("--strategy", default="greedy", choices=("subsets", "greedy"))
    ap.add_argument("--max-error-px", type=float, default=20.0)
    ap.add_argument(
        "--cutoff", type=float, default=6.0, help="Hz, low-pass of both before the angles (0: raw)"
    )
    ap.add_argument(
        "--person",
        default=None,
        help="follow one person of several: largest, central, x,y or x0,y0,x1,y1 px in the first frame of --reference",
    )
    ap.add_argument("--reference", type=int, default=0, help="view (index) in which --person is chosen")
    args = ap.parse_args()
    calib = read_calibration(args.demo / "calibration" / "Calib.qca.txt", n_cameras=4)
    if args.cache:
        args.cache.mkdir(parents=True, exist_ok=True)
    result = {}
    for model in args.models.split(","):
        if args.person is None:
            kps = keypoints(args.demo, calib.names, model, args.width, args.cache)
        else:
            choice = (
                args.person
                if args.person in ("largest", "central")
                else [float(v) for v in args.person.split(",")]
            )
            kps = people_keypoints(args.demo, calib, model, args.width, args.cache, choice, args.reference)
        result[model] = evaluate(calib, kps, args)
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
