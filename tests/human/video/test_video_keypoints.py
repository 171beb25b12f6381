"""lfd.human.video.keypoints: the container of the sports2d estimate as a Skeleton (analyze_arm runs
on it), as CSV and through the .npz cache."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.human import analyze_arm
from lfd.human.video import VideoKeypoints


def test_sports2d_skeleton_runs_analyze_arm(sports2d_keypoints, tmp_path):
    sk = sports2d_keypoints.to_skeleton()
    assert {"shoulder_right", "elbow_right", "wrist_right", "hip_left", "hand_tip_right"} <= set(sk.names)
    result = analyze_arm(sk, side="right")
    summary = result.summary()
    assert summary["frames"] == sports2d_keypoints.n_frames
    # The person raises the arms overhead and waves: large abduction and elbow motion.
    assert summary["abduction_rom_deg"] > 40 and summary["elbow_flexion_rom_deg"] > 20
    assert 0.2 < result.segment_lengths["upper_arm"] < 0.4
    path = sports2d_keypoints.to_csv(tmp_path / "kp.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:4] == ["time_s", "frame", "detected", "other_person"] and "wrist_right_px" in header
    back = VideoKeypoints.load(sports2d_keypoints.save(tmp_path / "kp.npz"))
    np.testing.assert_array_equal(back.world, sports2d_keypoints.world)


def test_cache_load_refuses_corrupt_and_pickled_files(sports2d_keypoints, tmp_path):
    good = sports2d_keypoints.save(tmp_path / "kp.npz").read_bytes()
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(good[: len(good) // 2])
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, t=np.array([{"a": 1}], dtype=object))
    (tmp_path / "text.npz").write_text("not a cache")
    for path in (truncated, pickled, tmp_path / "text.npz"):
        with pytest.raises(ValueError, match="not a keypoint cache written by lfd"):
            VideoKeypoints.load(path)
