"""lfd.dmp.ProMP on real repeated demonstrations: a ProMP of one person's first six correct repetitions of a
UI-PRMD exercise ranks that person's other correct repetitions above their incorrect ones by log-likelihood.

Subject s04, m07 (standing shoulder abduction), Kinect v2: a test subject of benchmarks/promp_uiprmd.py
(its settings n_basis=10, cov_reg=0.01, noise=0.1 were chosen on subject s02 only). Features: the right
arm's upper-arm and forearm unit vectors in the trunk frame, each repetition resampled to 50 phases."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lfd.dmp import ProMP
from lfd.human import read_skeleton
from lfd.human.trunk import to_trunk, trunk_frames

UIPRMD = Path(__file__).resolve().parents[1] / "fixtures" / "human" / "ui_prmd"


def _arm_vectors(folder: str, repetition: int) -> np.ndarray:
    suffix = "_inc" if folder.endswith("incorrect") else ""
    name = f"m07_s04_e{repetition:02d}_%s{suffix}.txt.gz"
    skeleton = read_skeleton(
        UIPRMD / folder / "Positions" / (name % "positions"),
        format="uiprmd",
        angles_path=UIPRMD / folder / "Angles" / (name % "angles"),
    )
    rotation, origin = trunk_frames(skeleton)
    points = to_trunk(skeleton.positions, rotation, origin)
    s, e, w = (points[:, skeleton.index(f"{j}_right")] for j in ("shoulder", "elbow", "wrist"))
    vectors = np.concatenate([(e - s) / np.linalg.norm(e - s, axis=-1, keepdims=True),
                              (w - e) / np.linalg.norm(w - e, axis=-1, keepdims=True)], axis=-1)  # fmt: skip
    phase, grid = np.linspace(0.0, 1.0, len(vectors)), np.linspace(0.0, 1.0, 50)
    return np.stack([np.interp(grid, phase, vectors[:, d]) for d in range(6)], axis=-1)


def test_promp_of_six_correct_repetitions_ranks_correct_above_incorrect():
    correct = np.stack([_arm_vectors("Kinect", e) for e in range(1, 11)])
    incorrect = np.stack([_arm_vectors("Kinect_incorrect", e) for e in range(1, 11)])
    t = np.linspace(0.0, 1.0, 50)
    promp = ProMP(n_basis=10, cov_reg=0.01).fit(t, correct[:6])
    held_out = promp.log_likelihood(t, correct[6:], noise=0.1)
    wrong = promp.log_likelihood(t, incorrect, noise=0.1)
    auc = np.mean((held_out[:, None] > wrong[None, :]) + 0.5 * (held_out[:, None] == wrong[None, :]))
    assert auc >= 0.9, (held_out, wrong)
    # the ranking is not an artefact of the repetition's length: the training repetitions score like the held-out
    assert np.median(promp.log_likelihood(t, correct[:6], noise=0.1)) > np.median(wrong)
