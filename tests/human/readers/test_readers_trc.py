"""OpenSim .trc: agrees with the generic CSV layouts and the synthetic ground truth;
malformed files name line and field."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lfd.human import SkeletonFormatError, analyze_arm, read_skeleton
from lfd.human.arm_ik import arm_ik
from lfd.human.thesis_angles import thesis_fk

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"


def test_trc_and_generic_csv_agree():
    truth = np.load(FIXTURES / "synthetic_truth.npz")
    trc = read_skeleton(FIXTURES / "synthetic.trc")
    long = read_skeleton(FIXTURES / "synthetic_long.csv")
    wide = read_skeleton(FIXTURES / "synthetic_wide.csv")
    assert trc.names == long.names == wide.names
    assert "wrist_right" in trc.names and "spine_shoulder" in trc.names
    np.testing.assert_allclose(trc.t, truth["t"], atol=1e-5)
    np.testing.assert_allclose(long.positions, wide.positions, atol=1e-9)
    finite = np.isfinite(trc.positions)
    assert not finite[10, trc.index("wrist_right")].any()  # blank marker cells -> NaN
    np.testing.assert_allclose(
        trc.positions[finite], long.positions[finite], atol=6e-6
    )  # mm -> m (both rounded to 5 µm)
    # the fixture's truth is in the thesis's angles: its poses in the ISB angles are the reference
    elbow, wrist = thesis_fk(truth["q_right"], 0.3, 0.26)
    reference = arm_ik(np.zeros_like(elbow), elbow, wrist).q
    for sk in (trc, long, wide):
        q = analyze_arm(sk, side="right").q
        assert np.rad2deg(np.sqrt(np.nanmean((q - reference) ** 2))) < 4.0


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_trc_errors(tmp_path):
    lines = (FIXTURES / "synthetic.trc").read_text().splitlines()
    bad = list(lines)
    bad[2] = bad[2].replace("\tmm\t", "\tinch\t")
    with pytest.raises(SkeletonFormatError, match=r"line 3, field Units"):
        read_skeleton(_write(tmp_path, "u.trc", bad))
    bad = list(lines)
    bad[12] = "\t".join(bad[12].split("\t")[:-3])
    with pytest.raises(SkeletonFormatError, match=r"line 13, field columns"):
        read_skeleton(_write(tmp_path, "c.trc", bad))
    bad = list(lines)
    bad[10], bad[11] = bad[11], bad[10]
    with pytest.raises(SkeletonFormatError, match=r"line 12, field Time: time must increase"):
        read_skeleton(_write(tmp_path, "t.trc", bad))
