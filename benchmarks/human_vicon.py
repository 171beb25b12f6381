"""lfd's arm analysis of UI-PRMD Kinect recordings against the Vicon markers of the same trials.

Per trial (not frame-synchronised, so per-trial summaries, :func:`lfd.human.markers.trial_summary`):
(a) the Vicon marker geometry (ISB thorax from C7/CLAV/STRN/T10, acromion -> epicondyle ->
wrist-marker midpoint; :func:`lfd.human.markers.marker_arm_angles`), (b) ``analyze_arm`` of the
Kinect file (defaults; its summary angles are the filtered per-frame angles ``q_ik``, as in
``ArmAnalysis.summary``), (c) the raw Kinect joint geometry (the same
per-frame IK of the joints as read, no filtering or fitting; :func:`lfd.human.markers.raw_arm_angles`).
Prints, per movement, the mean absolute error of (b) and (c) against (a) for each summary
quantity, the mean marker values, and which arm moved (found from the data: the wrist that
moves more, in each recording separately).

    PYTHONPATH=src python benchmarks/human_vicon.py                       # table of docs/human.md
    PYTHONPATH=src python benchmarks/human_vicon.py --variants            # + filter/fit variants
    PYTHONPATH=src python benchmarks/human_vicon.py --variants --noise 0.02   # + 2 cm of added noise
    PYTHONPATH=src python benchmarks/human_vicon.py --shoulder acromion   # marker humerus from the acromion
    PYTHONPATH=src python benchmarks/human_vicon.py --root ../shared/data/human/ui_prmd --subjects s02 s03

s02-s05 are the subjects with Vicon files: they are validation data (every default of lfd.human
that this touches was chosen on them); no held-out Vicon data exists in this project.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from lfd.human import analyze_arm, read_skeleton
from lfd.human.markers import (
    SUMMARY_KEYS,
    marker_arm_angles,
    moving_side,
    raw_arm_angles,
    trial_summary,
    trunk_marker_shape,
)
from lfd.human.readers.vicon import read_uiprmd_vicon

MOVEMENTS = ("m07", "m08", "m09", "m10")
VARIANTS = {
    "default: Butterworth, cutoff from the recording (auto), per-frame angles": {},
    "Butterworth 6 Hz, per-frame angles": {"cutoff": 6.0},
    "no filter, per-frame angles": {"filter": "none"},
    "median filter, per-frame angles": {"filter": "median"},
    "Butterworth auto + CV polynomial fit (q)": {"use_fit": True},
    "Butterworth auto + spline fit 2 Hz (q)": {"use_fit": True, "fit": "spline"},
}


def subject_shape(vicon_path: Path):
    """The trunk-marker shape of this subject from the first of its Vicon files that has one (a trial whose
    sternum marker is lost throughout, m10_s05_e01, borrows it)."""
    subject = vicon_path.name.split("_")[1]
    for other in sorted(vicon_path.parent.glob(f"m*_{subject}_e*_positions.txt*")):
        shape = trunk_marker_shape(read_uiprmd_vicon(other))
        if shape is not None:
            return shape
    return None


def compare_trial(
    vicon_path: Path,
    kinect_path: Path,
    noise: float = 0.0,
    use_fit: bool = False,
    shoulder: str = "gh",
    **options,
) -> dict:
    """Summaries of one trial: ``{"vicon": ..., "lfd": ..., "raw": ..., "side_vicon", "side_kinect"}``; lfd's
    from the filtered per-frame angles (as ``ArmAnalysis.summary``) or, with ``use_fit``, from the fit;
    ``noise`` m of white noise added to every Kinect coordinate (seeded by the trial name)."""
    markers = read_uiprmd_vicon(vicon_path)
    shape = trunk_marker_shape(markers)
    side_v = moving_side(markers.joint("lwra"), markers.joint("rwra"))
    skeleton = read_skeleton(kinect_path)
    if noise > 0:
        rng = np.random.default_rng(sum(map(ord, kinect_path.name)))
        skeleton = dataclasses.replace(
            skeleton, positions=skeleton.positions + rng.normal(0.0, noise, skeleton.positions.shape)
        )
    side_k = moving_side(skeleton.joint("wrist_left"), skeleton.joint("wrist_right"))
    result = analyze_arm(skeleton, side=side_k, **options)
    return {
        "vicon": trial_summary(
            marker_arm_angles(
                markers,
                side_v,
                shape=shape if shape is not None else subject_shape(vicon_path),
                shoulder=shoulder,
            )
        ),
        "lfd": trial_summary(result.q if use_fit else result.q_ik),
        "raw": trial_summary(raw_arm_angles(skeleton, side_k)),
        "side_vicon": side_v,
        "side_kinect": side_k,
    }


def trials(root: Path, subjects, episodes) -> list[tuple[str, Path, Path]]:
    out = []
    for vicon in sorted((root / "Vicon" / "Positions").glob("m*_s*_e*_positions.txt*")):
        name = vicon.name.split("_positions")[0]
        m, s, e = name.split("_")
        if m in MOVEMENTS and s in subjects and e in episodes:
            kinect = root / "Kinect" / "Positions" / vicon.name
            if kinect.exists():
                out.append((name, vicon, kinect))
    return out


def table(results: dict[str, dict]) -> tuple[list[str], dict]:
    """Markdown lines and {movement: {quantity: (lfd_err, raw_err)}}."""
    head = "| movement | trials | arm (Vicon/Kinect) | " + " | ".join(
        f"{k.replace('_', ' ')}: Vicon mean / lfd err / raw err" for k in SUMMARY_KEYS
    )
    lines = [head + " |", "|---|---:|---|" + "---:|" * len(SUMMARY_KEYS)]
    errors = {}
    for movement in MOVEMENTS:
        rows = [r for name, r in results.items() if name.startswith(movement)]
        if not rows:
            continue
        sides = sorted({f"{r['side_vicon']}/{r['side_kinect']}" for r in rows})
        cells, errors[movement] = [], {}
        for key in SUMMARY_KEYS:
            ref = np.array([r["vicon"][key] for r in rows])
            lfd_err = float(np.mean(np.abs([r["lfd"][key] for r in rows] - ref)))
            raw_err = float(np.mean(np.abs([r["raw"][key] for r in rows] - ref)))
            errors[movement][key] = (lfd_err, raw_err)
            mark = "**" if lfd_err <= raw_err else ""
            cells.append(f"{ref.mean():.1f}° / {mark}{lfd_err:.1f}°{mark} / {raw_err:.1f}°")
        lines.append(f"| {movement} | {len(rows)} | {', '.join(sides)} | " + " | ".join(cells) + " |")
    return lines, errors


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path("../shared/data/human/ui_prmd"))
    parser.add_argument("--subjects", nargs="+", default=["s02", "s03", "s04", "s05"])
    parser.add_argument("--episodes", nargs="+", default=["e01", "e02", "e03"])
    parser.add_argument("--variants", action="store_true", help="also the filter/fit variants (overall)")
    parser.add_argument(
        "--noise", type=float, default=0.0, help="m of white noise added to the Kinect joints"
    )
    parser.add_argument("--shoulder", choices=("gh", "acromion"), default="gh", help="marker humerus origin")
    args = parser.parse_args(argv)
    found = trials(args.root, args.subjects, args.episodes)
    if not found:
        print(f"no Vicon/Kinect trial pairs under {args.root}", file=sys.stderr)
        return 1
    results = {name: compare_trial(v, k, noise=args.noise, shoulder=args.shoulder) for name, v, k in found}
    noise = f", {args.noise * 100:g} cm of white noise added to the Kinect joints" if args.noise else ""
    print(
        f"{len(found)} trials ({', '.join(args.subjects)}; validation data, no held-out Vicon exists){noise}\n"
    )
    lines, errors = table(results)
    print("\n".join(lines))
    worse = [f"{m} {k} (+{a - b:.2f}°)" for m, e in errors.items() for k, (a, b) in e.items() if a > b]
    peak = max(r["lfd"]["peak_elevation"] for r in results.values())
    capped = sum(abs(r["lfd"]["peak_elevation"] - 90.0) < 0.05 for r in results.values())
    print(f"\nlfd worse than raw Kinect on: {worse or 'none'}; highest lfd peak elevation {peak:.1f}°, "
          f"trials with a peak at 90.0°: {capped}")  # fmt: skip
    if args.variants:
        print("\n| lfd variant | " + " | ".join(f"{k.replace('_', ' ')} err" for k in SUMMARY_KEYS) + " |")
        print("|---|" + "---:|" * len(SUMMARY_KEYS))
        raw = [np.mean([abs(r["raw"][k] - r["vicon"][k]) for r in results.values()]) for k in SUMMARY_KEYS]
        print("| raw Kinect geometry (no filter, no fit) | " + " | ".join(f"{e:.1f}°" for e in raw) + " |")
        for label, options in VARIANTS.items():
            res = (
                results
                if not options
                else {
                    n: compare_trial(v, k, args.noise, shoulder=args.shoulder, **options) for n, v, k in found
                }
            )
            err = [np.mean([abs(r["lfd"][k] - r["vicon"][k]) for r in res.values()]) for k in SUMMARY_KEYS]
            print(f"| {label} | " + " | ".join(f"{e:.1f}°" for e in err) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
