"""Whole pipeline against synthetic ground truth; invariance to the camera; outputs; public API."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lfd.human import ArmAnalysis, Skeleton, analyze_arm, read_skeleton  # the public API
from lfd.human.synthetic import camera_pose, synthetic_recording

# Test seeds (defaults were chosen on seeds 100-102, see docs/human.md).
SEEDS = (0, 1)


def _rmse(a, b):
    ok = np.isfinite(a).all(1) & np.isfinite(b).all(1)
    return np.sqrt(np.mean((a[ok] - b[ok]) ** 2, axis=0))


@pytest.fixture(scope="module", params=SEEDS)
def corrupted(request):
    return synthetic_recording(
        duration=20.0,
        seed=request.param,
        noise=0.01,
        dropouts=12,
        long_gap=0.5,
        outlier_burst=True,
        swap=True,
    )


@pytest.mark.parametrize("side", ["right", "left"])
def test_synthetic_ground_truth_accuracy(corrupted, side):
    """Angle and torque RMSE against the known trajectories.

    Thresholds: 1 cm white noise per coordinate passes the 6 Hz zero-phase low-pass with about
    sqrt(6 / 15) of its amplitude, 0.63 cm, i.e. 0.63 / 30 cm = 1.2 deg of upper-arm direction
    (x sqrt(2) for the difference of two joints: 1.7 deg) before the CV polynomial smooths further;
    the rotation is amplified by 1 / sin(elbow flexion) <= 2 for the 30-110 deg elbow range.
    So about 2 deg RMSE is the expected error of the shoulder and elbow angles and 4 deg of the
    rotation; the thresholds allow 2x that. Torques: the gravity torque of the arm is at most
    m g l ~ 10 N m and a 2-4 deg angle error changes it by ~ 5 % (0.5 N m); the inertial part is
    small for these motions (< 1 N m), so 1.0 N m at the shoulder and 0.6 N m at the elbow (max
    4 N m) allow 2x the expected error. A wrongly repaired swap, an unfilled outlier burst or a
    branch flip each gives errors of tens of degrees and N m over >= 5 frames, which fails these.
    """
    result = analyze_arm(corrupted.skeleton, side=side)
    angle = np.rad2deg(_rmse(result.q, corrupted.q[side]))
    torque = _rmse(result.tau, corrupted.tau[side])
    assert np.all(angle[[0, 1, 3]] < 4.0), angle
    assert angle[2] < 8.0, angle
    assert np.all(torque[:3] < 1.0) and torque[3] < 0.6, torque
    q = result.quality
    assert q["swap_events"] == 2 and q["swap_frames"] == 30  # one swap of 1 s, detected and undone
    if side == "right":
        assert q["outliers"] >= 5  # the 5-frame wrist burst
        assert len(q["gaps_left"]) == 1 and q["gaps_left"][0]["duration"] == pytest.approx(0.5, abs=0.04)
        assert q["missing_frames"] == 15
    assert q["gaps_filled"] >= 1
    assert result.segment_lengths["upper_arm"] == pytest.approx(0.30, abs=0.01)
    assert result.segment_lengths["forearm"] == pytest.approx(0.26, abs=0.01)


def _wrapped_rmse_deg(a, b, rows):
    d = (a[rows] - b[rows] + np.pi) % (2 * np.pi) - np.pi
    return np.rad2deg(np.sqrt(np.mean(d**2, axis=0)))


@pytest.mark.parametrize("motion", ["overhead", "behind_back", "through_singular"])
@pytest.mark.parametrize("side", ["right", "left"])
def test_full_range_of_motion(motion, side):
    """The same thresholds as the default motions (see above) over the full range: arm raised above the
    head (elevation up to ~165 deg), behind the back (plane of elevation -80..-30 deg, internally
    rotated), and swinging through hanging and straight up, where the plane of elevation and the axial
    rotation are undefined: there they are compared at least 0.5 s away from a flagged frame, and the
    elevation, the elbow and the torques everywhere."""
    rec = synthetic_recording(duration=20.0, seed=7, noise=0.01, dropouts=12, long_gap=0.5, outlier_burst=True,
                              swap=True, motion=motion)  # fmt: skip
    result = analyze_arm(rec.skeleton, side=side)
    truth = rec.q[side]
    ok = np.isfinite(result.q).all(1)
    flagged = result.flags["shoulder_singular"] | result.flags["elbow_singular"]
    far = ok & ~(np.convolve(flagged.astype(float), np.ones(31), "same") > 0)
    assert far.mean() > 0.2
    angle = _wrapped_rmse_deg(result.q, truth, far)
    assert np.all(angle[[0, 1, 3]] < 4.0) and angle[2] < 8.0, angle
    assert np.all(_wrapped_rmse_deg(result.q, truth, ok)[[1, 3]] < 4.0)  # elevation, elbow: everywhere
    torque = _rmse(result.tau, rec.tau[side])
    assert np.all(torque[:3] < 1.0) and torque[3] < 0.6, torque
    peak = np.rad2deg(truth[ok, 1].max())
    assert np.rad2deg(result.q[ok, 1].max()) == pytest.approx(peak, abs=4.0)  # nothing capped
    if motion == "overhead":
        assert peak > 150.0
    if motion == "through_singular":
        assert result.flags["shoulder_singular"].sum() > 50 and np.rad2deg(truth[:, 1]).min() < 5.0


def test_without_swap_repair_the_error_is_large(corrupted):
    """The swap matters: without repair the right-arm angles over that second are the left arm's."""
    result = analyze_arm(corrupted.skeleton, side="right", repair_swaps_=False)
    start, stop = corrupted.corrupted["swap"]
    err = np.rad2deg(np.abs(result.q_ik[start:stop] - corrupted.q["right"][start:stop]))
    assert np.nanmean(err) > 10.0


@pytest.mark.parametrize(
    ("filter_", "fit"), [("median", "polynomial"), ("butterworth", "spline"), ("median", "spline")]
)
def test_other_filters_and_fits_are_accurate_too(filter_, fit):
    rec = synthetic_recording(duration=12.0, seed=3, noise=0.01, dropouts=5)
    result = analyze_arm(rec.skeleton, side="right", filter=filter_, fit=fit, hampel=True)
    assert np.all(np.rad2deg(_rmse(result.q, rec.q["right"]))[[0, 1, 3]] < 5.0)
    assert np.all(_rmse(result.tau, rec.tau["right"]) < 1.5)


def test_invariance_to_camera_pose():
    base = synthetic_recording(duration=6.0, seed=2, noise=0.0)
    moved = synthetic_recording(
        duration=6.0,
        seed=2,
        noise=0.0,
        camera=camera_pose(yaw_deg=35, distance=3.4, height=0.6, pitch_deg=-15),
    )
    assert not np.allclose(base.skeleton.positions, moved.skeleton.positions, atol=0.1)
    for side in ("right", "left"):
        a, b = analyze_arm(base.skeleton, side=side), analyze_arm(moved.skeleton, side=side)
        np.testing.assert_allclose(a.q, b.q, atol=1e-8)
        np.testing.assert_allclose(a.tau, b.tau, atol=1e-7)
        np.testing.assert_allclose(a.positions, b.positions, atol=1e-9)
        # and the noise-free reconstruction is the truth
        assert np.rad2deg(_rmse(a.q, base.q[side])).max() < 0.5


def test_outputs(tmp_path):
    rec = synthetic_recording(duration=3.0, seed=6, noise=0.005, long_gap=0.4)
    result = analyze_arm(rec.skeleton, side="right", body_mass=60.0, sex="female")
    assert isinstance(result, ArmAnalysis) and isinstance(rec.skeleton, Skeleton)
    assert result.q.shape == result.qd.shape == result.qdd.shape == result.tau.shape == (90, 4)
    assert result.positions.shape == result.raw_positions.shape == result.reconstructed.shape == (90, 3, 3)
    csv = result.to_csv(tmp_path / "a.csv")
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:5] == [
        "time_s",
        "plane_of_elevation_deg",
        "elevation_deg",
        "axial_rotation_deg",
        "elbow_flexion_deg",
    ]
    assert {"thesis_abduction_deg", "thesis_flexion_deg", "shoulder_singular", "elbow_singular"} <= set(
        header
    )
    assert "elbow_flexion_torque_Nm" in header and len(csv.read_text().splitlines()) == 91
    data = np.genfromtxt(csv, delimiter=",", skip_header=1)
    np.testing.assert_allclose(data[:, 1:5], np.rad2deg(result.q), rtol=1e-5, atol=1e-4)
    mot = tmp_path / "a.mot"
    result.to_mot(mot)
    lines = mot.read_text().splitlines()
    assert lines[1:6] == ["version=1", "nRows=90", "nColumns=9", "inDegrees=yes", "endheader"]
    assert lines[6].split("\t")[:3] == ["time", "right_plane_of_elevation", "right_elevation"]
    doc = json.loads(result.to_json(tmp_path / "a.json").read_text())
    assert doc["subject"] == {"body_mass": 60.0, "sex": "female", "hand_load": 0.0}
    assert doc["summary"]["frames"] == 90 and doc["quality"]["gaps_left"][0]["joint"] == "wrist_right"
    assert len(doc["frames"]["time_s"]) == 90
    summary = result.summary()
    assert summary["elevation_rom_deg"] > 5 and summary["elevation_peak_torque_Nm"] > 1
    assert summary["abduction_rom_deg"] > 5  # the thesis's angles, derived


def test_forearm_pronation_where_the_skeleton_has_a_thumb(fixtures):
    # KIMORE (Kinect v2, 25 joints) has thumbs: a pronation angle per frame where the arm is seen
    skeleton = read_skeleton(fixtures / "kimore_ex1_excerpt.csv.gz")
    for side in ("right", "left"):
        result = analyze_arm(skeleton, side=side)
        seen = np.isfinite(result.q_ik).all(1)
        assert np.isfinite(result.pronation[seen]).all() and seen.mean() > 0.5
        assert np.all(np.abs(result.pronation[seen]) < np.pi)
        assert 0 < result.summary()["forearm_pronation_rom_deg"] < 180


def test_plots_and_gif(tmp_path):
    rec = synthetic_recording(duration=2.0, seed=6, noise=0.01)
    paths = analyze_arm(rec.skeleton).plot(tmp_path, gif_frames=12)
    names = sorted(p.name for p in paths)
    for expected in (
        "positions.png",
        "angles.png",
        "thesis_angles.png",
        "velocities.png",
        "accelerations.png",
        "torques.png",
        "stick_figure.gif",
    ):
        assert expected in names
    for p in paths:
        assert p.stat().st_size > 2000
    from PIL import Image

    gif = Image.open(tmp_path / "stick_figure.gif")
    assert gif.n_frames == 12


def test_bad_options():
    sk = synthetic_recording(duration=1.0, seed=0).skeleton
    for kwargs, match in [
        ({"side": "both"}, "side must be one of"),
        ({"sex": "x"}, "sex must be one of"),
        ({"filter": "kalman"}, "filter must be one of"),
        ({"fit": "fourier"}, "fit must be one of"),
        ({"body_mass": -3}, "body_mass must be a positive"),
        ({"max_gap": float("nan")}, "max_gap"),
    ]:
        with pytest.raises(ValueError, match=match):
            analyze_arm(sk, **kwargs)
    with pytest.raises(FileNotFoundError):
        analyze_arm("/nonexistent/file.csv")
    with pytest.raises(ValueError, match="strictly increasing"):
        Skeleton(t=[0.0, 0.0], names=("a",), positions=np.zeros((2, 1, 3)))
    with pytest.raises(ValueError, match=r"positions must have shape"):
        Skeleton(t=[0.0, 1.0], names=("a",), positions=np.zeros((2, 2, 3)))
    assert read_skeleton is not None
