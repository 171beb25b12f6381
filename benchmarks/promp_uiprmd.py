"""UI-PRMD ranking by ProMP log-likelihood: correct repetitions above incorrect ones, per subject and movement.

For each subject with ten correct and ten incorrect Kinect repetitions (s02-s05) and each movement
(m07-m10), a :class:`lfd.dmp.ProMP` is fitted to the subject's first six correct repetitions
(e01-e06); the other four correct ones (e07-e10) and the ten incorrect ones are scored by
``log_likelihood`` and the ROC AUC (correct ranked above incorrect) is reported.

Features (D = 6): the right (exercising) arm's upper-arm and forearm unit vectors,
shoulder->elbow and elbow->wrist, expressed in the trunk frame of :mod:`lfd.human.trunk`
(x forward, y left, z up): positions and vectors only, no joint angles. Each repetition is
time-normalised (phase 0..1) and resampled to ``--samples`` points before fitting and scoring.

Held-out discipline: the settings (``--n-basis``, ``--cov-reg``, ``--noise``) were chosen on the
validation subject s02 (all four movements); s03-s05 are the test split, reported once.

    python benchmarks/promp_uiprmd.py                      # the table in docs/dmp.md
    python benchmarks/promp_uiprmd.py --subjects s02 --grid   # the validation sweep
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path

import numpy as np

from lfd.dmp import ProMP
from lfd.human import read_skeleton
from lfd.human.trunk import to_trunk, trunk_frames

#: The UI-PRMD folder of the shared data beside the repository (``--root`` to use another).
ROOT = Path(__file__).resolve().parents[2] / "shared" / "data" / "human" / "ui_prmd"
MOVEMENTS = ("m07", "m08", "m09", "m10")
SUBJECTS = ("s02", "s03", "s04", "s05")
VALIDATION = ("s02",)


def arm_vectors(path: Path, incorrect: bool) -> np.ndarray:
    """``(T, 6)`` upper-arm and forearm unit vectors of the right arm in the trunk frame."""
    suffix = "_inc" if incorrect else ""
    angles = path.parent.parent / "Angles" / path.name.replace(f"_positions{suffix}", f"_angles{suffix}")
    skeleton = read_skeleton(path, format="uiprmd", angles_path=angles)
    rotation, origin = trunk_frames(skeleton)
    points = to_trunk(skeleton.positions, rotation, origin)
    shoulder, elbow, wrist = (
        points[:, skeleton.index(name)] for name in ("shoulder_right", "elbow_right", "wrist_right")
    )
    upper, fore = elbow - shoulder, wrist - elbow
    return np.concatenate(
        [
            upper / np.linalg.norm(upper, axis=-1, keepdims=True),
            fore / np.linalg.norm(fore, axis=-1, keepdims=True),
        ],
        axis=-1,
    )


def resample(y: np.ndarray, samples: int) -> np.ndarray:
    """``(samples, D)`` linear resampling of ``y`` ``(T, D)`` on the phase ``0..1``."""
    phase, grid = np.linspace(0.0, 1.0, y.shape[0]), np.linspace(0.0, 1.0, samples)
    return np.stack([np.interp(grid, phase, y[:, d]) for d in range(y.shape[1])], axis=-1)


def load(movement: str, subject: str, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Correct ``(10, samples, 6)`` and incorrect ``(10, samples, 6)`` repetitions."""
    out = []
    for folder, suffix in (("Kinect", ""), ("Kinect_incorrect", "_inc")):
        paths = [
            ROOT / folder / "Positions" / f"{movement}_{subject}_e{e:02d}_positions{suffix}.txt.gz"
            for e in range(1, 11)
        ]
        out.append(np.stack([resample(arm_vectors(p, bool(suffix)), samples) for p in paths]))
    return out[0], out[1]


def auc(positive: np.ndarray, negative: np.ndarray) -> float:
    """Probability that a positive scores above a negative (ties count one half)."""
    diff = positive[:, None] - negative[None, :]
    return float(np.mean((diff > 0) + 0.5 * (diff == 0)))


def score(data, n_basis: int, cov_reg: float, noise: float, n_train: int = 6) -> float:
    correct, incorrect = data
    t = np.linspace(0.0, 1.0, correct.shape[1])
    promp = ProMP(n_basis=n_basis, cov_reg=cov_reg).fit(t, correct[:n_train])
    return auc(
        promp.log_likelihood(t, correct[n_train:], noise=noise),
        promp.log_likelihood(t, incorrect, noise=noise),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", nargs="+", default=list(SUBJECTS))
    parser.add_argument("--movements", nargs="+", default=list(MOVEMENTS))
    parser.add_argument("--samples", type=int, default=50)
    parser.add_argument("--n-basis", type=int, default=10)
    parser.add_argument("--cov-reg", type=float, default=0.01)
    parser.add_argument("--noise", type=float, default=0.1, help="observation noise std (unit-vector units)")
    parser.add_argument("--grid", action="store_true", help="sweep n_basis x cov_reg x noise (validation)")
    args = parser.parse_args()
    data = {(m, s): load(m, s, args.samples) for m in args.movements for s in args.subjects}
    if args.grid:
        for n_basis, cov_reg, noise in itertools.product(
            (5, 10, 15, 20), (0.0, 0.01, 0.1, 1.0), (0.02, 0.05, 0.1, 0.2)
        ):
            aucs = [score(d, n_basis, cov_reg, noise) for d in data.values()]
            print(
                f"n_basis={n_basis:2d} cov_reg={cov_reg:<5} noise={noise:<5} "
                f"mean AUC {np.mean(aucs):.3f} min {np.min(aucs):.3f}"
            )
        return
    print(
        f"settings: n_basis={args.n_basis} cov_reg={args.cov_reg} noise={args.noise} samples={args.samples}"
    )
    print("| subject | split | " + " | ".join(args.movements) + " | mean |")
    print("|---|---|" + "---|" * (len(args.movements) + 1))
    table = {}
    for s in args.subjects:
        row = [score(data[m, s], args.n_basis, args.cov_reg, args.noise) for m in args.movements]
        table[s] = row
        split = "validation" if s in VALIDATION else "test"
        print(f"| {s} | {split} | " + " | ".join(f"{a:.3f}" for a in row) + f" | {np.mean(row):.3f} |")
    test = [a for s, row in table.items() if s not in VALIDATION for a in row]
    every = [a for row in table.values() for a in row]
    if test:
        print(f"test mean AUC {np.mean(test):.3f} ({len(test)} subject-movement pairs)")
    print(f"all mean AUC {np.mean(every):.3f} ({len(every)} pairs)")


if __name__ == "__main__":
    main()
