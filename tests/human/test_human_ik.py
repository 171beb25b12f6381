"""ISB arm IK: the Y-X-Y definition (scipy), exact against the catalogue FK over the full range,
both sides, singular poses by continuity (flagged, never clamped); the thesis's derived angles."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from lfd.human.arm_ik import arm_fk, arm_frames, arm_ik, canonical_angles, forearm_pronation, mirror
from lfd.human.thesis_angles import THESIS_RANGE, thesis_fk, thesis_ik
from lfd.robots import load_robot

L1, L2 = 0.31, 0.26
DEG = np.pi / 180


def _wrapped(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture(scope="module")
def robot():
    return load_robot("human_arm", upper_arm_length=L1, forearm_length=L2)


def _random_q(n, seed):
    """Poses over the whole sphere of upper-arm directions, any rotation, elbow 0-170 deg."""
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(-np.pi, np.pi, n), np.arccos(rng.uniform(-1, 1, n)), rng.uniform(-np.pi, np.pi, n),
                     rng.uniform(0, 170 * DEG, n)], 1)  # fmt: skip


def test_frames_are_the_isb_yxy_sequence():
    # ISB thorax axes in the trunk frame (x forward, y left, z up): X = x (anterior), Y = z (up), Z = -y (right).
    to_trunk = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # columns: ISB X, Y, Z in trunk coordinates
    q = _random_q(200, 0)
    isb = Rotation.from_euler("YXY", np.stack([q[:, 0], -q[:, 1], q[:, 2]], 1)).as_matrix()  # intrinsic
    np.testing.assert_allclose(arm_frames(q), to_trunk @ isb @ to_trunk.T, atol=1e-12)


def test_anatomical_meaning_by_hand():
    q = (
        np.array(
            [[0, 90, 0, 0], [90, 90, 0, 0], [-90, 45, 0, 0], [0, 180, 0, 0], [0, 0, 90, 90], [0, 0, 0, 90]]
        )
        * DEG
    )
    elbow, wrist = arm_fk(q, 0.3, 0.25)
    np.testing.assert_allclose(elbow[0], [0, -0.3, 0], atol=1e-12)  # plane 0: abduction, sideways (right: -y)
    np.testing.assert_allclose(elbow[1], [0.3, 0, 0], atol=1e-12)  # plane 90: forward flexion
    assert elbow[2, 0] < -0.2  # negative plane: behind the body (extension)
    np.testing.assert_allclose(elbow[3], [0, 0, 0.3], atol=1e-12)  # elevation 180: straight up
    np.testing.assert_allclose(
        wrist[4] - elbow[4], [0, 0.25, 0], atol=1e-12
    )  # internal rotation: towards the body
    np.testing.assert_allclose(
        wrist[5] - elbow[5], [0.25, 0, 0], atol=1e-12
    )  # elbow flexion: forearm forwards


def test_fk_matches_catalogue_robot(robot):
    q = robot.sample_q(500, torch.Generator().manual_seed(1)).numpy()
    frames = robot.fk(q, all_links=True).numpy()
    elbow, wrist = arm_fk(q, L1, L2)
    np.testing.assert_allclose(elbow, frames[:, 3, :3, 3], atol=1e-12)  # elbow = origin of the forearm link
    np.testing.assert_allclose(wrist, frames[:, 4, :3, 3], atol=1e-12)  # wrist = tool frame
    np.testing.assert_allclose(frames[:, 2, :3, :3], arm_frames(q), atol=1e-12)  # upper-arm orientation


def test_round_trip_exact_over_the_whole_sphere():
    q = _random_q(20000, 2)
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    regular = ~res.elbow_singular & ~res.shoulder_singular
    assert regular.mean() > 0.85
    err = _wrapped(res.q - q)[regular]
    assert np.abs(err).max() < 1e-9
    assert res.q[:, 1].min() >= 0 and res.q[:, 1].max() <= np.pi  # elevation in [0, 180] deg, nothing capped
    assert res.q[:, 1].max() > 175 * DEG
    np.testing.assert_allclose(res.q[:, 1], q[:, 1], atol=1e-9)  # the elevation is exact in every frame
    np.testing.assert_allclose(res.q[:, 3], q[:, 3], atol=1e-9)


def test_raising_the_arm_sideways_to_overhead_is_not_capped():
    # like UI-PRMD m07: abduction to 170 deg with the elbow slightly bent; the thesis model stopped at 90
    t = np.linspace(0, 1, 200)
    q = np.stack([5 * DEG + 0 * t, 155 * DEG * t + 15 * DEG, 20 * DEG + 0 * t, 25 * DEG + 0 * t], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    assert res.q[:, 1].max() == pytest.approx(170 * DEG, abs=1e-9)
    np.testing.assert_allclose(res.q, q, atol=1e-9)
    thesis = thesis_ik(np.zeros_like(elbow), elbow, wrist)
    assert thesis.q[:, 0].max() > 150 * DEG  # derived abduction is not clamped either, but flagged
    assert thesis.outside_range[-1] and not thesis.outside_range[0]


def test_swing_through_hanging_keeps_the_plane_on_the_continuous_branch():
    # forward flexion 60 deg -> hanging -> extension 40 deg in the sagittal plane, elbow bent
    t = np.linspace(0, 1, 301)
    signed = 60 * DEG - 100 * DEG * t
    q = np.stack([90 * DEG + 0 * t, signed, 15 * DEG + 0 * t, 70 * DEG + 0 * t], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    cont = arm_ik(np.zeros_like(elbow), elbow, wrist, canonical=False)
    np.testing.assert_allclose(cont.q, q, atol=1e-9)  # plane kept, elevation through 0: smooth
    assert cont.shoulder_singular.any() and not cont.shoulder_singular[[0, -1]].any()
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)  # ISB form: elevation >= 0, the plane turns at hanging
    np.testing.assert_allclose(res.q[:, 1], np.abs(signed), atol=1e-9)
    assert res.q[0, 0] == pytest.approx(90 * DEG) and _wrapped(res.q[-1, 0] + 90 * DEG) == pytest.approx(
        0, abs=1e-9
    )
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[1], wrist, atol=1e-9)  # the same poses


def test_through_straight_up_and_plane_change_at_hanging():
    # abduction up through straight overhead (elevation 150 -> 200 on the continuous branch)
    t = np.linspace(0, 1, 201)
    q = np.stack([10 * DEG + 0 * t, 150 * DEG + 50 * DEG * t, -20 * DEG + 0 * t, 40 * DEG + 0 * t], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    cont = arm_ik(np.zeros_like(elbow), elbow, wrist, canonical=False)
    np.testing.assert_allclose(cont.q, q, atol=1e-9)
    assert arm_ik(np.zeros_like(elbow), elbow, wrist).q[:, 1].max() <= np.pi
    # arm lowered sideways to hanging, then raised forwards: the plane moves 0 -> 90 deg while hanging
    elev = 30 * DEG * np.abs(2 * t - 1)
    plane = np.where(t < 0.5, 0.0, 90 * DEG)
    q = np.stack([plane, elev, 90 * DEG - plane, 80 * DEG + 0 * t], 1)  # plane + rotation constant
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    assert res.shoulder_singular[100] and np.isfinite(res.q).all()
    assert np.abs(np.diff(res.q, axis=0)).max() < 10 * DEG  # no jumps: the plane is interpolated
    np.testing.assert_allclose(res.q[:, 1], elev, atol=1e-9)
    np.testing.assert_allclose(res.q[:, 0] + res.q[:, 2], 90 * DEG, atol=1 * DEG)  # the forearm is kept
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[0], elbow, atol=0.3 * L1 * np.sin(10 * DEG))


def test_missing_frames_before_a_singular_zone():
    # raised to 95 deg, lost for a while, seen again hanging, then raised to 30 deg: exact elevations
    elev = np.deg2rad([95, 95, 0, 0, 5, 3, 20, 30])
    q = np.stack([np.full(8, 0.5), elev, np.full(8, 0.2), np.full(8, 1.0)], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    elbow[2:4] = np.nan
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    assert np.isnan(res.q[2:4]).all() and res.shoulder_singular[4:6].all()
    keep = np.isfinite(res.q[:, 1])
    np.testing.assert_allclose(res.q[keep, 1], elev[keep], atol=1e-9)


def test_rotation_with_the_arm_hanging():
    # internal/external rotation with the upper arm at the side (UI-PRMD m09): plane undefined the
    # whole time, held at 0, so the axial rotation carries the forearm's swing
    rng = np.random.default_rng(0)
    t = np.linspace(0, 2, 121)
    q = np.stack([0 * t, 4 * DEG + 0 * t, 60 * DEG * np.sin(np.pi * t), 90 * DEG + 0 * t], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    noise = rng.normal(0, 0.002, elbow.shape)
    res = arm_ik(np.zeros_like(elbow), elbow + noise, wrist + noise)
    assert res.shoulder_singular.all()
    assert np.abs(res.q[:, 0]).max() == 0.0
    assert np.abs(res.q[:, 2] - q[:, 2]).max() < 6 * DEG


def test_straight_elbow_rotation_interpolated_and_flagged():
    t = np.linspace(0, 2, 121)
    elbow_flex = 60 * DEG * np.abs(np.cos(np.pi * t / 2))  # straightens at t = 1
    q = np.stack([0.4 + 0 * t, 0.9 + 0 * t, 30 * DEG + 10 * DEG * t, elbow_flex], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    assert res.elbow_singular[60] and not res.elbow_singular[0] and np.isfinite(res.q).all()
    assert np.abs(res.q[:, 2] - q[:, 2]).max() < 1.0 * DEG  # interpolated across: within 1 deg of the truth
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[1], wrist, atol=1e-9)  # wrist still exact
    # starting (and ending) with a straight elbow: the rotation is held from the nearest bent frame
    res = arm_ik(np.zeros_like(elbow[60:]), elbow[60:], wrist[60:])
    assert res.elbow_singular[0] and np.isfinite(res.q).all()
    # the held rotation misses the truth's (slowly changing) one by < 1 deg on a forearm bent < 10 deg
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[1], wrist[60:], atol=L2 * np.sin(10 * DEG) * DEG)


def test_left_arm_is_the_mirror_image():
    q = _random_q(300, 3)
    elbow, wrist = arm_fk(q, L1, L2)
    left = arm_ik(np.zeros_like(elbow), mirror(elbow, "left"), mirror(wrist, "left"), side="left")
    ok = ~left.elbow_singular & ~left.shoulder_singular
    assert np.abs(_wrapped(left.q[ok] - q[ok])).max() < 1e-9
    # a left arm raised sideways moves towards +y: plane of elevation 0, elevation 90 deg
    e = np.array([[0.0, L1, 0.0]])
    res = arm_ik(np.zeros((1, 3)), e, e + [[0.1, 0.0, 0.0]], side="left")
    assert res.q[0, :2] == pytest.approx([0.0, np.pi / 2])
    with pytest.raises(ValueError, match="side must be"):
        arm_ik(np.zeros((1, 3)), e, e, side="middle")


def test_canonical_form_keeps_the_dynamics(robot):
    # (phi + pi, -theta, psi + pi) is the same motion: RNEA gives the same torques but the elevation's sign
    rng = np.random.default_rng(4)
    q = _random_q(50, 4)
    q[:, 1] *= -1  # negative elevations: all flipped by canonical_angles
    qd, qdd = rng.normal(0, 2, q.shape), rng.normal(0, 10, q.shape)
    tau = robot.inverse_dynamics(q, qd, qdd).numpy()
    cq, cqd, cqdd, ctau = canonical_angles(q, qd, qdd, tau)
    assert (cq[:, 1] >= 0).all()
    np.testing.assert_allclose(robot.inverse_dynamics(cq, cqd, cqdd).numpy(), ctau, atol=1e-9)
    np.testing.assert_allclose(arm_frames(cq), arm_frames(q), atol=1e-12)


def test_thesis_angles_round_trip_and_gimbal_lock():
    rng = np.random.default_rng(5)
    q = THESIS_RANGE[0] + rng.uniform(size=(2000, 4)) * (THESIS_RANGE[1] - THESIS_RANGE[0])
    elbow, wrist = thesis_fk(q, L1, L2)
    res = thesis_ik(np.zeros_like(elbow), elbow, wrist, continuity=0.0)
    ok = ~res.elbow_singular & ~res.gimbal_lock
    np.testing.assert_allclose(res.q[ok], q[ok], atol=1e-9)
    # the thesis's gimbal lock is the arm pointing forwards (ISB: plane 90, elevation 90): flagged
    e, w = arm_fk(np.array([[90 * DEG, 90 * DEG, 0.0, 1.0]]), L1, L2)
    assert thesis_ik(np.zeros((1, 3)), e, w).gimbal_lock[0]


def test_forearm_pronation_by_hand():
    # arm hanging, elbow bent 90 deg forwards: thumb up = mid-position, medial = pronation, lateral = supination
    s, e = np.zeros((4, 3)), np.tile([0.0, 0.0, -L1], (4, 1))
    w = e + [L2, 0.0, 0.0]
    thumb = w + 0.05 * np.array([[0, 0, 1], [0, 1, 0], [0, -1, 0], [0, -0.5, 0.5]])  # right arm: medial = +y
    angle, interpolated = forearm_pronation(s, e, w, thumb)
    np.testing.assert_allclose(np.rad2deg(angle), [0, 90, -90, -45], atol=1e-9)
    assert not interpolated.any()
    left, _ = forearm_pronation(*(mirror(x, "left") for x in (s, e, w, thumb)), side="left")
    np.testing.assert_allclose(left, angle, atol=1e-12)  # the same anatomical sign on either side
    # a straightening elbow: the reference is undefined there, the angle is held and flagged
    bend = np.deg2rad([60, 30, 5, 2, 30])
    w = e[:1] + L2 * np.stack([np.sin(bend), 0 * bend, -np.cos(bend)], 1)
    f = (w - e[:1]) / L2
    up = np.stack([-np.cos(bend), 0 * bend, -np.sin(bend)], 1) * -1  # -u minus its forearm component, unit
    thumb = w + 0.05 * np.cross(up, f)  # pronated 90 deg throughout
    angle, interpolated = forearm_pronation(np.zeros((5, 3)), np.tile(e[:1], (5, 1)), w, thumb)
    assert interpolated.tolist() == [False, False, True, True, False]
    np.testing.assert_allclose(np.rad2deg(angle), 90.0, atol=1e-9)


def test_bad_input():
    with pytest.raises(ValueError, match=r"elbow must have shape \(T, 3\)"):
        arm_ik(np.zeros((2, 3)), np.zeros((2, 2)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="singular_deg"):
        arm_ik(np.zeros((2, 3)), np.ones((2, 3)), np.ones((2, 3)), singular_deg=60.0)
