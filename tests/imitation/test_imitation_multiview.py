"""The multiview source (several calibrated videos -> triangulated skeleton -> robot) on the 4-view
Pose2Sim demo, the sports2d video through ``source=``, and the multiview input errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

import lfd.imitation
from lfd.imitation import ImitationSettings
from lfd.imitation.multiview import match_views
from lfd.imitation.sources import detect_source_type

ROOT = Path(__file__).resolve().parents[2]


def _cfg(overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return ImitationSettings.from_mapping(compose(config_name="imitate", overrides=overrides))


@pytest.mark.slow
def test_four_calibrated_views_to_a_robot(pose2sim_demo, mediapipe_ok, tmp_path):
    videos = pose2sim_demo / "videos"
    # given out of the calibration's order: matched to the cameras by file name
    order = ["cam03", "cam01", "cam04", "cam02"]
    source = "[" + ",".join(str(videos / f"{n}.mp4") for n in order) + "]"
    calibration = pose2sim_demo / "calibration" / "Calib.qca.txt"
    cfg = _cfg(
        [f"source={source}", f"calibration={calibration}", "robot=wam4", "side=right", "pose.stride=2"]
    )
    summary = lfd.imitation.run(cfg, tmp_path)
    for name in ("dmp.json", "robot_trajectory.csv", "robot_trajectory.bag", "summary.json", "arm.csv",
                 "keypoints_cam01.npz", "keypoints_cam04.npz"):  # fmt: skip
        assert (tmp_path / name).is_file(), name
    assert json.loads((tmp_path / "summary.json").read_text())["source_type"] == "multiview"
    views = summary["multiview"]
    assert views["cameras"] == ["cam01", "cam02", "cam03", "cam04"]
    assert [Path(v).stem for v in views["videos"]] == views["cameras"]
    # views matched to the wrong cameras would not reproject within a few tens of pixels
    assert views["reprojection_px_median"] < 20.0
    assert views["views_per_landmark_mean"] >= 2.5
    assert summary["frames"] >= 40  # 100 frames at stride 2, the arm seen in nearly all
    assert summary["limit_violations"] == 0
    assert summary["dmp_vs_reference_rmse_rad"] <= 0.05
    assert summary["executed_vs_dmp_rmse_rad"] <= 0.1


def test_sports2d_video_through_source(sports2d_video, mediapipe_ok, tmp_path):
    cfg = _cfg([f"source={sports2d_video}", "robot=sawyer", "side=right", "pose.max_frames=40", "pose.stride=2",
                "outputs.video=false", "outputs.gif=false"])  # fmt: skip
    summary = lfd.imitation.run(cfg, tmp_path)
    assert summary["source_type"] == "video" and summary["source"] == str(sports2d_video)
    for name in ("keypoints.csv", "dmp.json", "robot_trajectory.csv", "robot_trajectory.bag", "summary.json"):
        assert (tmp_path / name).is_file(), name
    assert summary["limit_violations"] == 0
    assert summary["executed_vs_dmp_rmse_rad"] <= 0.1
    assert np.isfinite(summary["end_tool_position_m"]).all()


def test_multiview_input_errors(tmp_path, pose2sim_demo):
    a, b, junk = tmp_path / "a.mp4", tmp_path / "b.mp4", tmp_path / "c.csv"
    for p in (a, b, junk):
        p.write_bytes(b"")
    assert detect_source_type([a, b]) == "multiview"
    with pytest.raises(ValueError, match="must hold videos"):
        detect_source_type([a, junk])
    with pytest.raises(FileNotFoundError, match="no video"):
        detect_source_type([a, tmp_path / "none.mp4"])
    with pytest.raises(ValueError, match="calibration: a multiview source needs"):
        lfd.imitation.run(_cfg([f"source=[{a},{b}]"]), tmp_path / "run")
    calibration = pose2sim_demo / "calibration" / "Calib.qca.txt"
    with pytest.raises(ValueError, match="2 videos for the 4 cameras"):
        lfd.imitation.run(_cfg([f"source=[{a},{b}]", f"calibration={calibration}"]), tmp_path / "run")
    with pytest.raises(ValueError, match="a list of paths is a multiview source"):
        lfd.imitation.run(_cfg([f"source=[{a},{b}]", "source_type=bag"]), tmp_path / "run")
    with pytest.raises(ValueError, match="at least 2 videos"):
        match_views([a], ["cam01"])
    # stems naming every camera reorder; otherwise the given order stays
    assert match_views([b, a], ["a", "b"]) == [a, b]
    assert match_views([b, a], ["cam1", "cam2"]) == [b, a]
