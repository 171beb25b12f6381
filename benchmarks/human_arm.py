"""Speed and accuracy of the arm-analysis pipeline (lfd.human), on synthetic recordings with ground truth.

Run::

    PYTHONPATH=src python benchmarks/human_arm.py            # speed (10 min at 30 Hz) + accuracy table
    PYTHONPATH=src python benchmarks/human_arm.py --quick    # shorter, for a smoke test

1. Speed: the whole pipeline (swap repair, gap filling, filter, trunk frame, IK, fit,
   Newton-Euler torques; no plots) on a 10-minute 30 Hz recording with noise and dropouts,
   as frames per second and as a multiple of real time (target >= 50x on 2 CPU cores); and
   the torque step alone against Pinocchio's RNEA called frame by frame (same process).
2. Accuracy: joint-angle and torque RMSE against the known trajectories for every filter x
   fit combination, on test seeds 10-14 (the defaults were chosen on seeds 100-102), 20 s
   each, Kinect-like noise (1 cm), 12 dropouts, a 0.5 s gap, an outlier burst and a swap.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lfd.human import JOINT_NAMES, analyze_arm
from lfd.human.dynamics import arm_model, arm_torques
from lfd.human.synthetic import synthetic_recording


def speed(minutes: float, repeats: int) -> None:
    rec = synthetic_recording(
        duration=60.0 * minutes, seed=0, noise=0.01, dropouts=200, swap=True, outlier_burst=True
    )
    frames = rec.skeleton.n_frames
    analyze_arm(rec.skeleton)  # warm-up (imports, torch constants)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = analyze_arm(rec.skeleton)
        times.append(time.perf_counter() - start)
    best = min(times)
    duration = rec.skeleton.t[-1] - rec.skeleton.t[0] + 1 / rec.skeleton.rate
    print(f"## Speed: {minutes:g} min at 30 Hz = {frames} frames (best of {repeats})")
    print(
        f"whole pipeline: {best:.2f} s = {frames / best:,.0f} frames/s = {duration / best:.0f}x real time "
        "(target >= 50x)"
    )
    robot = arm_model()
    q, qd, qdd, g = result.q, result.qd, result.qdd, result.gravity * [1, 1, 1]
    ok = np.isfinite(q).all(1) & np.isfinite(qd).all(1) & np.isfinite(qdd).all(1)
    q, qd, qdd, g = q[ok], qd[ok], qdd[ok], g[ok]
    start = time.perf_counter()
    ours = arm_torques(robot, q, qd, qdd, g)
    t_ours = time.perf_counter() - start
    try:
        import pinocchio as pin
    except ImportError:
        print("torques: pinocchio not installed, no reference timing")
        return
    model = pin.buildModelFromXML(robot.to_urdf())
    data = model.createData()
    start = time.perf_counter()
    ref = np.empty_like(ours)
    for i in range(len(q)):
        model.gravity.linear = g[i]
        ref[i] = pin.rnea(model, data, q[i], qd[i], qdd[i])
    t_pin = time.perf_counter() - start
    print(
        f"torques of {len(q)} frames: lfd batched RNE {t_ours * 1e3:.0f} ms, "
        f"Pinocchio RNEA per frame {t_pin * 1e3:.0f} ms "
        f"(ratio {t_pin / t_ours:.2f}x), max difference {np.abs(ours - ref).max():.1e} N m"
    )


def accuracy(seeds, duration: float) -> None:
    filters = {  # label -> analyze_arm options: the default cut-off chosen from each recording, and 6 Hz
        "butterworth (auto cut-off)": {"filter": "butterworth"},
        "butterworth 6 Hz": {"filter": "butterworth", "cutoff": 6.0},
        "median": {"filter": "median"},
        "none": {"filter": "none"},
    }
    combos = [(f, fit) for f in filters for fit in ("polynomial", "spline")]
    print(
        f"\n## Accuracy on synthetic ground truth (seeds {seeds[0]}-{seeds[-1]}, {duration:g} s each, both arms)"
    )
    print("noise 1 cm, 12 dropouts, a 0.5 s gap, a 5-frame outlier burst, a 1 s left/right swap\n")
    print(
        "| filter | fit | angle RMSE (deg) "
        + " / ".join(JOINT_NAMES)
        + " | torque RMSE (N m) "
        + " / ".join(JOINT_NAMES)
        + " |"
    )
    print("|---|---|---|---|")
    recs = [
        synthetic_recording(
            duration=duration, seed=s, noise=0.01, dropouts=12, long_gap=0.5, outlier_burst=True, swap=True
        )
        for s in seeds
    ]
    peak = np.max([np.abs(r.tau[side]).max(0) for r in recs for side in ("left", "right")], axis=0)
    for filt, fit in combos:
        angle, torque = [], []
        for rec in recs:
            for side in ("right", "left"):
                res = analyze_arm(rec.skeleton, side=side, fit=fit, **filters[filt])
                ok = np.isfinite(res.q).all(1)
                angle.append(np.rad2deg(np.sqrt(np.mean((res.q[ok] - rec.q[side][ok]) ** 2, 0))))
                torque.append(np.sqrt(np.mean((res.tau[ok] - rec.tau[side][ok]) ** 2, 0)))
        a, t = np.mean(angle, 0), np.mean(torque, 0)
        print(
            f"| {filt} | {fit} | "
            + " / ".join(f"{v:.2f}" for v in a)
            + " | "
            + " / ".join(f"{v:.2f}" for v in t)
            + " |"
        )
    print("\npeak |torque| of the truth (N m): " + " / ".join(f"{v:.1f}" for v in peak))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="1-minute recording, 2 seeds of 10 s")
    args = parser.parse_args()
    if args.quick:
        speed(1.0, 1)
        accuracy((10, 11), 10.0)
    else:
        speed(10.0, 3)
        accuracy(tuple(range(10, 15)), 20.0)


if __name__ == "__main__":
    main()
