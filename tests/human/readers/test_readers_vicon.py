"""UI-PRMD Vicon marker files: layout, units, lost markers, malformed rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lfd.human import SkeletonFormatError
from lfd.human.readers.vicon import PLUG_IN_GAIT_MARKERS, read_uiprmd_vicon

VICON = Path(__file__).resolve().parents[2] / "fixtures" / "human" / "ui_prmd" / "Vicon" / "Positions"


def test_real_file_layout_and_units():
    sk = read_uiprmd_vicon(VICON / "m07_s02_e01_positions.txt.gz")
    assert sk.positions.shape == (233, 39, 3) and len(PLUG_IN_GAIT_MARKERS) == 39
    assert sk.rate == pytest.approx(100.0) and np.allclose(sk.up, [0, 0, 1])
    assert sk.tracked.all()
    # metres, z up: the head markers above the shoulders above the knees; the two acromia 0.3-0.45 m apart
    z = {n: np.median(sk.joint(n)[:, 2]) for n in ("lfhd", "rsho", "rkne")}
    assert 1.5 < z["lfhd"] < 2.0 and z["lfhd"] > z["rsho"] > z["rkne"] > 0.3
    width = np.median(np.linalg.norm(sk.joint("lsho") - sk.joint("rsho"), axis=1))
    assert 0.3 < width < 0.45
    # mm -> m exactly: the first number of the file is LFHD x = 1038.55 mm
    assert sk.joint("lfhd")[0, 0] == pytest.approx(1.03855)


def test_lost_markers_are_missing_not_zero():
    sk = read_uiprmd_vicon(VICON / "m10_s05_e02_positions.txt.gz")
    lost = ~sk.tracked
    assert lost[:, sk.index("lwrb")].all() and lost[:, sk.index("strn")].sum() == 30
    assert np.isnan(sk.joint("lwrb")).all() and np.isfinite(sk.joint("rwra")).all()


def test_malformed_files(tmp_path):
    bad = tmp_path / "m07_s02_e01_positions.txt"
    bad.write_text(",".join(["1.0"] * 117) + "\n" + ",".join(["1.0"] * 116) + "\n")
    with pytest.raises(SkeletonFormatError, match=r"line 2.*expected 117"):
        read_uiprmd_vicon(bad)
    bad.write_text(",".join(["1.0"] * 116 + ["x"]) + "\n")
    with pytest.raises(SkeletonFormatError, match="RTOE.z"):
        read_uiprmd_vicon(bad)
    bad.write_text("\n")
    with pytest.raises(SkeletonFormatError, match="empty"):
        read_uiprmd_vicon(bad)
    with pytest.raises(FileNotFoundError):
        read_uiprmd_vicon(tmp_path / "missing.txt")
    with pytest.raises(ValueError, match="rate"):
        read_uiprmd_vicon(VICON / "m07_s02_e01_positions.txt.gz", rate=-1.0)
