"""Generic CSV (long and wide): time order, missing and extra columns; a file missing an arm's joints."""

from __future__ import annotations

from pathlib import Path

import pytest

from lfd.human import SkeletonFormatError, analyze_arm, read_skeleton

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_csv_non_monotonic_time_and_missing_column(tmp_path):
    lines = (FIXTURES / "synthetic_wide.csv").read_text().splitlines()
    lines[5], lines[6] = lines[6], lines[5]
    with pytest.raises(SkeletonFormatError, match=r"line 7, field time: time must increase strictly"):
        read_skeleton(_write(tmp_path, "w.csv", lines))
    long = (FIXTURES / "synthetic_long.csv").read_text().splitlines()
    long = long[:1] + long[20:] + long[1:20]
    with pytest.raises(SkeletonFormatError, match=r"field t: time must not decrease"):
        read_skeleton(_write(tmp_path, "l.csv", long))
    wide = (FIXTURES / "synthetic_wide.csv").read_text().splitlines()
    header = wide[0].split(",")
    cut = [",".join(line.split(",")[:-1]) for line in wide]  # drops neck_z
    assert header[-1] == "neck_z"
    with pytest.raises(SkeletonFormatError, match=r"line 1, field neck_z: missing column"):
        read_skeleton(_write(tmp_path, "c.csv", cut))
    wide[3] = wide[3] + ",1.0"
    with pytest.raises(SkeletonFormatError, match=r"line 4, field columns"):
        read_skeleton(_write(tmp_path, "n.csv", wide))


def test_missing_joints_for_the_arm(tmp_path):
    wide = (FIXTURES / "synthetic_wide.csv").read_text().splitlines()
    header = wide[0].split(",")
    keep = [i for i, h in enumerate(header) if not h.startswith("elbow_right")]
    path = _write(tmp_path, "noelbow.csv", [",".join(line.split(",")[i] for i in keep) for line in wide])
    sk = read_skeleton(path)
    with pytest.raises(ValueError, match=r"noelbow.csv.*missing joint\(s\) \['elbow_right'\]"):
        analyze_arm(sk, side="right")
    analyze_arm(sk, side="left")  # the other arm is still fine


def test_written_csv_reads_back_with_gaps_and_tracking(tmp_path):
    import numpy as np

    from lfd.human.readers.generic_csv import write_csv
    from lfd.human.synthetic import synthetic_recording

    sk = synthetic_recording(duration=1.0, seed=3, noise=0.002, dropouts=2).skeleton
    sk.positions[4, 2] = np.nan  # a missing joint: an empty cell, read back as NaN and untracked
    path = write_csv(sk, tmp_path / "recording.csv")
    assert path.read_text().splitlines()[0] == "t,joint,x,y,z,tracked"
    back = read_skeleton(path)
    assert back.names == sk.names and back.n_frames == sk.n_frames
    np.testing.assert_allclose(back.t, sk.t, atol=1e-6)
    np.testing.assert_allclose(back.positions, sk.positions, atol=1e-6)  # NaN where NaN
    expected = sk.tracked & np.isfinite(sk.positions).all(axis=2)
    np.testing.assert_array_equal(back.tracked, expected)
    assert not back.tracked[4, 2] and not sk.tracked.all()  # the gap and the dropouts
