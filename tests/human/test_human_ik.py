"""Closed-form 4-DoF arm IK: exact against the catalogue FK, both sides, limits, continuity, singular cases."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.human.arm_ik import LIMITS, arm_fk, arm_ik, mirror
from lfd.robots import load_robot

L1, L2 = 0.31, 0.26


@pytest.fixture(scope="module")
def robot():
    return load_robot("human_arm", upper_arm_length=L1, forearm_length=L2)


def test_fk_matches_catalogue_robot(robot):
    q = robot.sample_q(500, torch.Generator().manual_seed(1)).numpy()
    frames = robot.fk(q, all_links=True).numpy()
    elbow, wrist = arm_fk(q, L1, L2)
    np.testing.assert_allclose(elbow, frames[:, 3, :3, 3], atol=1e-12)  # elbow = origin of the forearm link
    np.testing.assert_allclose(wrist, frames[:, 4, :3, 3], atol=1e-12)  # wrist = tool frame
    assert np.allclose(LIMITS, [robot.spec.lower, robot.spec.upper])


def test_round_trip_exact_on_random_in_limit_poses(robot):
    q = robot.sample_q(20000, torch.Generator().manual_seed(2)).numpy()
    elbow, wrist = arm_fk(q, L1, L2)
    # independent samples: no continuity to keep
    res = arm_ik(np.zeros_like(elbow), elbow, wrist, continuity=0.0)
    regular = ~res.elbow_singular & ~res.shoulder_singular
    assert regular.mean() > 0.8
    np.testing.assert_allclose(res.q[regular], q[regular], atol=1e-9)
    # Both shoulder branches occur among in-limit poses (flexion beyond -90 deg needs branch B).
    assert 0.05 < res.branch.mean() < 0.5


def test_elbow_flexion_is_angle_between_segment_directions():
    # Thesis-style law of cosines on the shoulder-wrist distance gives the *interior* angle;
    # the model's elbow flexion is pi minus it (0 = straight). Check against a hand-made pose.
    shoulder = np.zeros((1, 3))
    elbow = np.array([[0.0, 0.0, -L1]])
    for bend in np.deg2rad([0.5, 30.0, 90.0, 140.0]):
        wrist = elbow + L2 * np.array([[np.sin(bend), 0.0, -np.cos(bend)]])  # forearm forwards by `bend`
        res = arm_ik(shoulder, elbow, wrist)
        assert res.q[0, 3] == pytest.approx(bend, abs=1e-12)
        if bend > np.deg2rad(10):
            assert res.q[0, :3] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)


def test_shoulder_terms_signs():
    shoulder = np.zeros((3, 3))
    # arm raised sideways (right arm: towards -y), forwards (+x), backwards (-x), all at 40 deg
    a = np.deg2rad(40)
    elbow = L1 * np.array(
        [[0, -np.sin(a), -np.cos(a)], [np.sin(a), 0, -np.cos(a)], [-np.sin(a), 0, -np.cos(a)]]
    )
    wrist = elbow + np.array([[L2 * 0.6, 0, -L2 * 0.8]] * 3)
    q = arm_ik(shoulder, elbow, wrist).q
    assert q[0, 0] == pytest.approx(a) and q[0, 1] == pytest.approx(0.0, abs=1e-12)  # abduction
    assert q[1, 1] == pytest.approx(-a) and q[1, 0] == pytest.approx(0.0, abs=1e-12)  # flexion forwards < 0
    assert q[2, 1] == pytest.approx(a)  # extension backwards > 0


def test_left_arm_is_the_mirror_image(robot):
    q = robot.sample_q(300, torch.Generator().manual_seed(3)).numpy()
    elbow, wrist = arm_fk(q, L1, L2)
    left = arm_ik(
        np.zeros_like(elbow), mirror(elbow, "left"), mirror(wrist, "left"), side="left", continuity=0
    )
    ok = ~left.elbow_singular & ~left.shoulder_singular
    np.testing.assert_allclose(left.q[ok], q[ok], atol=1e-9)
    # a left arm raised sideways moves towards +y and has positive abduction
    e = np.array([[0.0, L1, 0.0]]) * 0.9 + np.array([[0.0, 0.0, -0.1]])
    assert arm_ik(np.zeros((1, 3)), e, e + [[0.1, 0.0, -0.1]], side="left").q[0, 0] > 1.0
    with pytest.raises(ValueError, match="side must be"):
        arm_ik(np.zeros((1, 3)), e, e, side="middle")


def test_continuity_through_branch_change():
    # Raise the arm forwards from hanging to 125 deg flexion (beyond horizontal: branch B) with a
    # slight outward tilt and a bent elbow: the angles must change smoothly, no jump of ~pi.
    t = np.linspace(0, 1, 400)
    q = np.stack([np.deg2rad(10) * np.ones_like(t), -np.deg2rad(125) * t, np.deg2rad(20) * np.ones_like(t),
                  np.deg2rad(60) * np.ones_like(t)], 1)  # fmt: skip
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    assert np.abs(np.diff(res.q, axis=0)).max() < np.deg2rad(3)
    assert not res.clamped.any()
    e2, w2 = arm_fk(res.q, L1, L2)
    np.testing.assert_allclose(w2, wrist, atol=1e-9)
    assert res.branch[0] == 0 and res.branch[-1] == 1 and (np.diff(res.branch) != 0).sum() == 1


def test_no_jumps_when_dithering_at_the_branch_boundary():
    # Flexion dithering around -90 deg (arm pointing forwards: where the two branches meet)
    # with noisy elbow positions: no angle may jump (a branch flip would move q1 and q3 by pi).
    rng = np.random.default_rng(0)
    t = np.linspace(0, 4, 240)
    q = np.stack([0.3 + 0 * t, -np.pi / 2 + 0.3 * np.sin(3 * t), 0.2 + 0 * t, 1.0 + 0 * t], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    noise = rng.normal(0, 0.002, elbow.shape)
    res = arm_ik(np.zeros_like(elbow), elbow + noise, wrist + noise)
    # 2 mm noise on a 0.31 m arm is 0.4 deg of direction, amplified up to 1/cos(q2) ~ 6x near the
    # singular direction for abduction and rotation: steps of a few degrees, but no jump of ~180.
    assert np.abs(np.diff(res.q, axis=0)).max() < np.deg2rad(10)
    assert np.abs(res.q - q).max() < np.deg2rad(8)


def test_straight_arm_rotation_interpolated_and_flagged():
    t = np.linspace(0, 2, 121)
    elbow_flex = np.deg2rad(60) * np.abs(np.cos(np.pi * t / 2))  # straightens at t = 1
    q = np.stack([0.4 + 0 * t, -0.3 + 0 * t, np.deg2rad(30) + np.deg2rad(10) * t, elbow_flex], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    singular = res.elbow_singular
    assert singular.any() and singular[60] and not singular[0]
    assert np.isfinite(res.q).all()
    # rotation is interpolated across the straight-arm frames: within 1 deg of the (linear) truth
    assert np.abs(res.q[:, 2] - q[:, 2]).max() < np.deg2rad(1.0)
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[1], wrist, atol=1e-9)  # wrist still exact


def test_gimbal_lock_abduction_interpolated():
    t = np.linspace(0, 2, 121)
    flex = -np.pi / 2 + np.deg2rad(30) * (t - 1)  # passes through -90 deg (arm pointing forwards)
    q = np.stack([np.deg2rad(20) * np.ones_like(t), flex, 0.3 + 0 * t, 1.2 + 0 * t], 1)
    elbow, wrist = arm_fk(q, L1, L2)
    res = arm_ik(np.zeros_like(elbow), elbow, wrist)
    assert res.shoulder_singular[60] and not res.shoulder_singular[0]
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[0], elbow, atol=1e-9)
    np.testing.assert_allclose(arm_fk(res.q, L1, L2)[1], wrist, atol=1e-9)
    assert np.abs(np.diff(res.q, axis=0)).max() < np.deg2rad(5)


def test_limits_clamped_and_flagged():
    # arm raised sideways above horizontal (abduction 120 deg): outside the model's range
    a = np.deg2rad(120)
    elbow = L1 * np.array([[0.0, -np.sin(a), -np.cos(a)]])
    res = arm_ik(np.zeros((1, 3)), elbow, elbow + [[0.2, 0.0, 0.0]])
    assert res.clamped[0]
    assert np.all(res.q >= LIMITS[0]) and np.all(res.q <= LIMITS[1])


def test_bad_shapes():
    with pytest.raises(ValueError, match=r"elbow must have shape \(T, 3\)"):
        arm_ik(np.zeros((2, 3)), np.zeros((2, 2)), np.zeros((2, 3)))
