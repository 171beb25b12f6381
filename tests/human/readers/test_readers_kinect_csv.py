"""Kinect v2 CSV (KIMORE excerpt): blank rows and tracking states; malformed rows name line and field."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from lfd.human import SkeletonFormatError, read_skeleton

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"
KIMORE = FIXTURES / "kimore_ex1_excerpt.csv.gz"


def test_kimore_blank_rows_and_tracking_state():
    sk = read_skeleton(KIMORE)
    assert sk.n_frames == 120
    assert np.isnan(sk.positions[:24]).all() and not sk.tracked[:24].any()  # blank rows = no body
    assert np.isfinite(sk.positions[24:]).all()
    inferred = ~sk.tracked[24:]
    assert 0 < inferred.mean() < 0.5  # state 1 (inferred) is kept as position but not as tracked


def _kimore_lines():
    return gzip.decompress((KIMORE).read_bytes()).decode().splitlines()


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_kimore_wrong_column_count(tmp_path):
    lines = _kimore_lines()
    lines[30] = ",".join(lines[30].split(",")[:-5])
    with pytest.raises(SkeletonFormatError, match=r"bad\.csv, line 31, field columns: expected 100 values"):
        read_skeleton(_write(tmp_path, "bad.csv", lines), format="kinect_csv")


def test_kimore_bad_number_names_joint_field(tmp_path):
    lines = _kimore_lines()
    fields = lines[40].split(",")
    fields[4 * 9 + 1] = "abc"  # ElbowRight y
    lines[40] = ",".join(fields)
    with pytest.raises(
        SkeletonFormatError, match=r"line 41, field elbow_right\.y: expected a number, got 'abc'"
    ):
        read_skeleton(_write(tmp_path, "bad.csv", lines), format="kinect_csv")


def test_kimore_bad_tracking_state(tmp_path):
    lines = _kimore_lines()
    fields = lines[50].split(",")
    fields[4 * 2 + 3] = "7"
    lines[50] = ",".join(fields)
    with pytest.raises(SkeletonFormatError, match=r"line 51, field neck\.tracking_state"):
        read_skeleton(_write(tmp_path, "bad.csv", lines), format="kinect_csv")
