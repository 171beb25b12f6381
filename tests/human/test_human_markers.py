"""Marker geometry (ISB thorax, marker arm) against hand-made marker sets with known angles, and the
comparison of lfd with Vicon markers on real UI-PRMD trials (validation subjects, docs/human.md)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from lfd.human import Skeleton, analyze_arm, read_skeleton
from lfd.human.arm_ik import arm_fk
from lfd.human.markers import (
    isb_thorax_frames,
    marker_arm_angles,
    moving_side,
    raw_arm_angles,
    trial_summary,
    trunk_marker_shape,
)
from lfd.human.readers.vicon import read_uiprmd_vicon

UIPRMD = Path(__file__).resolve().parents[1] / "fixtures" / "human" / "ui_prmd"
DEG = np.pi / 180
# upright thorax facing +x: IJ, PX in front, C7, T8 behind, IJ/C7 and PX/T8 at equal heights
TRUNK = {
    "clav": (0.10, 0.0, 1.40),
    "strn": (0.12, 0.0, 1.20),
    "c7": (-0.06, 0.0, 1.40),
    "t10": (-0.08, 0.0, 1.20),
}


def _markers(q, turn=None, width=0.36):
    """Marker set of a person whose right arm has ISB angles ``q (T, 4)``; ``turn``: a Rotation of the whole
    body in the lab. The acromion marker sits 17 % of the acromion distance above the humeral head."""
    T = len(q)
    gh = np.array([0.0, -width / 2, 1.36 - 0.17 * width])
    elbow, wrist = arm_fk(q, 0.3, 0.25)
    points = {name: np.tile(p, (T, 1)) for name, p in TRUNK.items()}
    points["rsho"] = np.tile(gh + [0, 0, 0.17 * width], (T, 1))
    points["lsho"] = points["rsho"] * [1, -1, 1]
    points["relb"], points["rwra"], points["rwrb"] = (
        gh + elbow,
        gh + wrist + [0, 0.02, 0],
        gh + wrist - [0, 0.02, 0],
    )
    names = tuple(points)
    pos = np.stack([points[n] for n in names], 1)
    if turn is not None:
        pos = turn.apply(pos.reshape(-1, 3)).reshape(pos.shape) + [2.0, -1.0, 0.0]
    return Skeleton(t=np.arange(T) / 100.0, names=names, positions=pos, up=np.array([0.0, 0.0, 1.0]))


def _close(a, b):
    np.testing.assert_allclose((a - b + np.pi) % (2 * np.pi) - np.pi, 0.0, atol=1e-9)  # angles modulo turns


def _q(n=50, seed=0):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(-80, 150, n) * DEG, rng.uniform(15, 170, n) * DEG, rng.uniform(-60, 60, n) * DEG,
                     rng.uniform(15, 140, n) * DEG], 1)  # fmt: skip


def test_isb_thorax_frame_by_hand_and_rotation_invariant():
    rot, origin = isb_thorax_frames(_markers(_q(3)))
    np.testing.assert_allclose(rot[0], np.eye(3), atol=1e-12)  # x forward, y left, z up for this trunk
    np.testing.assert_allclose(origin[0], TRUNK["clav"])
    turn = Rotation.from_euler("zyx", [70, 10, -5], degrees=True)
    moved, _ = isb_thorax_frames(_markers(_q(3), turn))
    np.testing.assert_allclose(moved, np.broadcast_to(turn.as_matrix(), moved.shape), atol=1e-12)


def test_marker_arm_angles_recover_known_poses_anywhere_in_the_lab():
    q = _q(200)
    turn = Rotation.from_euler("zyx", [-120, 8, 4], degrees=True)
    _close(marker_arm_angles(_markers(q, turn), "right"), q)
    # the acromion marker itself reads a raised arm lower (it sits above the humeral head)
    acromion = marker_arm_angles(_markers(q), "right", shoulder="acromion")
    raised = q[:, 1] > 100 * DEG
    assert np.all(acromion[raised, 1] < q[raised, 1])


def test_lost_trunk_marker_filled_as_rigid_body():
    q = _q(40, 1)
    sk = _markers(q)
    shape = trunk_marker_shape(sk)
    pos = sk.positions.copy()
    pos[10:30, sk.index("strn")] = np.nan
    lost = Skeleton(sk.t, sk.names, pos, up=sk.up)
    _close(marker_arm_angles(lost, "right"), q)  # its own shape
    pos[:, sk.index("strn")] = np.nan  # lost throughout: borrow the shape (e.g. another trial)
    lost_all = Skeleton(sk.t, sk.names, pos, up=sk.up)
    assert trunk_marker_shape(lost_all) is None
    _close(marker_arm_angles(lost_all, "right", shape=shape), q)


def test_summary_side_and_bad_input():
    q = np.zeros((5, 4))
    q[:, 1] = np.deg2rad([10, 50, 120, 60, 20])
    q[:, 3] = np.deg2rad([10, 20, 30, 20, 10])
    s = trial_summary(q)
    assert s["peak_elevation"] == pytest.approx(120) and s["elevation_range"] == pytest.approx(110)
    assert s["mean_elbow_flexion"] == pytest.approx(18) and s["peak_elbow_flexion"] == pytest.approx(30)
    still, moving = np.zeros((20, 3)), np.linspace(0, 1, 60).reshape(20, 3)
    assert moving_side(still, moving) == "right" and moving_side(moving, still) == "left"
    with pytest.raises(ValueError, match=r"q must have shape \(T, 4\)"):
        trial_summary(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="no finite frame"):
        trial_summary(np.full((3, 4), np.nan))
    sk = _markers(_q(3))
    with pytest.raises(ValueError, match="missing marker"):
        marker_arm_angles(sk, "left")
    with pytest.raises(ValueError, match="side must be"):
        marker_arm_angles(sk, "both")
    with pytest.raises(ValueError, match="shoulder must be"):
        marker_arm_angles(sk, "right", shoulder="clavicle")


@pytest.mark.parametrize("name", ["m07_s02_e01", "m08_s03_e02", "m10_s05_e02"])
def test_lfd_against_vicon_markers_on_real_trials(name):
    """Per-trial summaries (the recordings are not frame-synchronised). Measured on these trials: lfd's peak
    elevation error 5.8 / 0.8 / 3.6 deg (48 validation trials: 4.8 deg mean, docs/human.md); the bound 8 deg
    leaves room for the marker model's own uncertainty. On every summary (peak elevation, elevation range,
    mean and peak elbow flexion) lfd must not be worse than the raw Kinect geometry by more than 0.2 deg:
    the cleaning, filtering and IK chain may not lose range of motion (with the former fixed 6 Hz
    cut-off m08's elevation range was 0.29 deg worse), and nothing may stop at 90 deg: the thesis model
    reported m07's 131-146 deg peak as 90.0."""
    markers = read_uiprmd_vicon(UIPRMD / "Vicon" / "Positions" / f"{name}_positions.txt.gz")
    kinect = read_skeleton(UIPRMD / "Kinect" / "Positions" / f"{name}_positions.txt.gz")
    assert moving_side(markers.joint("lwra"), markers.joint("rwra")) == "right"
    assert moving_side(kinect.joint("wrist_left"), kinect.joint("wrist_right")) == "right"
    vicon = trial_summary(marker_arm_angles(markers, "right"))
    result = analyze_arm(kinect, side="right")
    lfd = trial_summary(result.q_ik)
    raw = trial_summary(raw_arm_angles(kinect, "right"))
    error = {k: abs(lfd[k] - vicon[k]) for k in vicon}
    assert error["peak_elevation"] < 8.0, (lfd, vicon)
    assert error["mean_elbow_flexion"] < 6.0, (lfd, vicon)
    for key in ("peak_elevation", "elevation_range", "mean_elbow_flexion", "peak_elbow_flexion"):
        assert error[key] <= abs(raw[key] - vicon[key]) + 0.2, (key, error[key], abs(raw[key] - vicon[key]))
    assert result.summary()["elevation_max_deg"] == pytest.approx(lfd["peak_elevation"])
    if name.startswith("m07"):
        assert vicon["peak_elevation"] > 120 and lfd["peak_elevation"] > 120  # no cap at 90
        assert np.rad2deg(np.nanmax(result.q[:, 1])) > 120  # the fit is not capped either
