"""lfd.human.multiview: calibration readers (real Pose2Sim/Sports2D files), DLT triangulation, outlier views."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lfd.human.multiview import read_calibration, triangulate

ROOT = Path(__file__).resolve().parents[3]


def test_qualisys_calibration_of_the_pose2sim_demo(pose2sim_demo):
    calib = read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt", n_cameras=4)
    assert calib.names == ("cam01", "cam02", "cam03", "cam04")
    np.testing.assert_allclose(calib.size[0], [1088, 1920])
    assert calib.K[0, 0, 0] == pytest.approx(107599.671875 / 64) and calib.K[0, 0, 2] == pytest.approx(
        34110.316406 / 64
    )
    for r in calib.R:
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-6)
    # The lab origin (on the floor, where the person walks) is in front of every camera and in its image.
    centre = calib.project(np.array([0.0, 0.0, 1.0]))
    cam = np.einsum("cij,j->ci", calib.R, [0.0, 0.0, 1.0]) + calib.t
    assert (cam[:, 2] > 0).all()
    assert ((centre > 0) & (centre < calib.size)).all()
    with pytest.raises(ValueError, match="has 4 cameras .* expected 2"):
        read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt", n_cameras=2)


def test_toml_and_json_calibrations(sports2d_video, tmp_path):
    calib = read_calibration(sports2d_video.parent / "Calib_demo.toml")
    assert calib.names == ("demo",) and calib.K[0, 0, 0] == pytest.approx(2520.0897058227038)
    doc = {
        "cameras": [
            {
                "name": n,
                "matrix": k.tolist(),
                "distortions": d.tolist(),
                "rotation": r.tolist(),
                "translation": t.tolist(),
                "size": s.tolist(),
            }
            for n, k, d, r, t, s in zip(calib.names, calib.K, calib.dist, calib.R, calib.t, calib.size)
        ]
    }
    path = tmp_path / "calib.json"
    path.write_text(json.dumps(doc))
    back = read_calibration(path)
    np.testing.assert_allclose(back.R, calib.R)
    X = np.array([[0.5, 0.2, 1.0]])
    np.testing.assert_allclose(back.project(X), calib.project(X))
    with pytest.raises(FileNotFoundError):
        read_calibration(tmp_path / "missing.toml")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"cameras": [{"name": "a", "matrix": [1, 2]}]}))
    with pytest.raises(ValueError, match="camera 'a'"):
        read_calibration(bad)


def test_triangulation_exact_and_rejects_a_wrong_view(pose2sim_demo):
    calib = read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt")
    rng = np.random.default_rng(0)
    X = rng.uniform([-0.5, -0.5, 0.5], [0.5, 0.5, 1.7], (20, 5, 3))  # (T, J, 3) m
    px = calib.project(X)  # (C, T, J, 2) with distortion
    conf = np.full(px.shape[:3], 0.9)
    tri = triangulate(calib, px, conf)
    np.testing.assert_allclose(tri.points, X, atol=1e-6)
    assert np.nanmax(tri.error) < 1e-3
    # One camera sees a different person at joint 2: that view is rejected, the point stays right.
    wrong = px.copy()
    wrong[1, :, 2] += 150.0
    tri = triangulate(calib, wrong + rng.normal(0, 1.0, px.shape), conf)
    assert not tri.used[1, :, 2].any() and tri.used[:, :, [0, 1, 3, 4]].all()
    assert np.abs(tri.points[:, 2] - X[:, 2]).max() < 0.01
    with pytest.raises(ValueError, match="pixels must have shape"):
        triangulate(calib, px[:2], conf[:2])


def run_benchmark(*args: str) -> dict:
    proc = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "video_multiview.py"), *args],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout[proc.stdout.index("{") :])


@pytest.mark.slow
def test_full_and_heavy_against_four_views_on_the_pose2sim_demo(pose2sim_demo, heavy_pose_model, tmp_path):
    out = run_benchmark("--demo", str(pose2sim_demo), "--cache", str(tmp_path), "--models", "full,heavy")
    as_given = run_benchmark("--demo", str(pose2sim_demo), "--cache", str(tmp_path), "--models", "full,heavy",
                             "--no-reconcile")  # fmt: skip
    full, heavy = out["full"], out["heavy"]
    # Measured (docs/video.md): full flips cam02's labels front/back in 45 of 100 frames, heavy in none.
    assert full["flips"]["cam02"] > 20 and heavy["flips"]["cam02"] <= 2
    # The honest targets of issue 33 with heavy: <= 10 px, <= 11 px with every view kept (10.5).
    assert heavy["reprojection_px_median_arm"] <= 10.0
    assert heavy["reprojection_px_median_arm_all_views"] <= 11.0
    assert full["reprojection_px_median_arm"] <= 10.0
    # Reconciling cam02's labels brings full's all-views error from 15.7 px to 11.6 px.
    assert (
        full["reprojection_px_median_arm_all_views"]
        < as_given["full"]["reprojection_px_median_arm_all_views"] - 2
    )
    assert full["relabelled_frames"]["cam02"] > 10 and heavy["relabelled_frames"]["cam02"] <= 2
    for model in (full, heavy):
        assert set(model["arms"]) == {"left", "right"} and all(
            v.startswith("measured") for v in model["arms"].values()
        )
        # Shoulder elevation from one camera: 7 deg (heavy), 9.5 deg (full); elbow flexion 14-16 deg
        # (target 12 deg not met, docs/video.md). Bounds against regressions.
        assert model["monocular_median_abs_deg"]["shoulder_elevation"] < 12.0
        assert model["monocular_median_abs_deg"]["elbow_flexion"] < 20.0


@pytest.mark.slow
def test_two_people_seen_by_two_views_each_do_not_abort(pose2sim_multiperson, mediapipe_ok, tmp_path):
    # MediaPipe follows one person in cam01/cam02 and another in cam03/cam04: the views showing the
    # other person are left out, the arms are still measured, nothing aborts.
    out = run_benchmark("--demo", str(pose2sim_multiperson), "--cache", str(tmp_path), "--models", "full")[
        "full"
    ]
    others = sorted(out["other_person_frames"].values())
    assert others[:2] == [0, 0] and others[2] >= 90
    assert out["reprojection_px_median_arm"] < 10 and out["reprojection_px_median_arm_all_views"] > 100
    assert all(isinstance(v, str) for v in out["arms"].values())
    assert any(v.startswith("measured") for v in out["arms"].values())


@pytest.mark.slow
def test_the_chosen_person_of_two_is_followed_in_all_four_views(pose2sim_multiperson, mediapipe_ok, tmp_path):
    # Followed as one person per view (above), the four views never agree: 2 views' arms, 24-55
    # frames. With everyone found and the man (the largest person in cam03) followed across the
    # views, the arms are measured on almost every frame and all four views fit together.
    out = run_benchmark(
        "--demo", str(pose2sim_multiperson), "--cache", str(tmp_path), "--models", "full",
        "--person", "largest", "--reference", "2",
    )["full"]  # fmt: skip
    assert all(v.startswith("measured on") and int(v.split()[2]) >= 90 for v in out["arms"].values())
    assert out["reprojection_px_median_arm_all_views"] < 20 and out["reprojection_px_median_arm"] < 10
    assert out["monocular_median_abs_deg"]["shoulder_elevation"] < 12.0
    assert sum(n == 0 for n in out["other_person_frames"].values()) >= 3
