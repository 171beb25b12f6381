"""read_skeleton: formats inferred from real excerpts give plausible bones and angles in the ISB ranges;
corrupt gzip, missing files, unknown formats and options give clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lfd.human import SkeletonFormatError, analyze_arm, read_skeleton

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures" / "human"
REAL_FILES = {
    "kinect_csv": "kimore_ex1_excerpt.csv.gz",
    "ntu": "ntu_S001C001P001R001A001_excerpt.skeleton.gz",
    "uiprmd": "ui_prmd/Kinect/Positions/m10_s05_e02_positions.txt.gz",
}


def _bone(sk, a, b):
    """Median bone length over frames where the camera tracked both joints (None if < 10 such frames)."""
    both = sk.tracked[:, sk.index(a)] & sk.tracked[:, sk.index(b)]
    return np.median(np.linalg.norm(sk.joint(b) - sk.joint(a), axis=1)[both]) if both.sum() >= 10 else None


@pytest.mark.parametrize("fmt", sorted(REAL_FILES))
def test_real_excerpt_plausible(fmt):
    sk = read_skeleton(FIXTURES / REAL_FILES[fmt])  # format inferred from the name
    assert f"({fmt}" in sk.source
    assert sk.positions.shape[1:] in {(25, 3), (22, 3)} and sk.rate == pytest.approx(30.0)
    tested = 0
    for side in ("left", "right"):
        upper, fore = (
            _bone(sk, f"shoulder_{side}", f"elbow_{side}"),
            _bone(sk, f"elbow_{side}", f"wrist_{side}"),
        )
        if upper is None or fore is None:
            continue  # e.g. NTU "drink water": the left arm is occluded (only inferred) in most frames
        tested += 1
        assert 0.2 <= upper <= 0.4  # upper arm, m
        assert 0.15 <= fore <= 0.35  # forearm, m
        result = analyze_arm(sk, side=side)
        q = result.q[np.isfinite(result.q).all(1)]
        assert len(q) > 20
        # the fit of the elevation may overshoot [0, 180] deg by a little where the arm hangs
        assert np.all(q[:, 1] >= np.deg2rad(-5)) and np.all(q[:, 1] <= np.pi)
        assert np.all((q[:, 3] >= np.deg2rad(-5)) & (q[:, 3] <= np.deg2rad(175)))  # elbow flexion
        assert 0.2 <= result.segment_lengths["upper_arm"] <= 0.4
    assert tested >= 1
    # Kinect labels: the person's left shoulder is on the trunk's +y side, i.e. facing the sensor
    # the trunk x axis points towards the camera (negative z for Kinect, the origin for UI-PRMD).
    from lfd.human.trunk import trunk_frames

    rot, origin = trunk_frames(sk)
    forward = np.nanmedian(rot[:, :, 0], axis=0)
    towards_camera = -np.nanmedian(origin, axis=0)
    assert forward @ towards_camera / np.linalg.norm(towards_camera) > 0.7


def _write(tmp_path, name, lines):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def test_gzip_corrupt(tmp_path):
    path = tmp_path / "x.csv.gz"
    path.write_bytes(b"\x1f\x8b\x08\x00garbage")
    with pytest.raises(SkeletonFormatError, match="x.csv.gz, field gzip"):
        read_skeleton(path, format="kinect_csv")


def test_missing_file_and_unknown_format(tmp_path):
    with pytest.raises(FileNotFoundError, match="nowhere.csv"):
        read_skeleton(tmp_path / "nowhere.csv")
    path = _write(tmp_path, "a.xyz", ["1"])
    with pytest.raises(ValueError, match="cannot infer"):
        read_skeleton(path)
    with pytest.raises(ValueError, match="unknown skeleton format 'bvh'"):
        read_skeleton(path, format="bvh")
    with pytest.raises(ValueError, match=r"has no option\(s\) \['body'\]"):
        read_skeleton(FIXTURES / "synthetic.trc", body=1)
    assert read_skeleton(FIXTURES / "synthetic.trc", up=(0, 0, 2)).up.tolist() == [0.0, 0.0, 1.0]
