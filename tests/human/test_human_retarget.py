"""Retargeting on synthetic human motions with known joint angles (human FK -> retarget -> robot FK)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.human.arm_ik import arm_fk, mirror
from lfd.human.retarget import retarget_wam4, retarget_wrist_path, time_scale
from lfd.human.synthetic import _sines
from lfd.robots import load_robot


def human_motion(seed: int, duration: float = 4.0, rate: float = 30.0, side: str = "right"):
    """Known human-arm angles (ISB, sums of sines around the arm raised 50 deg in front of the frontal
    plane) -> trunk-frame shoulder, elbow, wrist."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(duration * rate)) / rate
    freq = rng.uniform(0.15, 0.5, (4, 2))
    phase = rng.uniform(0, 2 * np.pi, (4, 2))
    amp = np.deg2rad([[15, 10], [20, 15], [20, 10], [25, 15]])
    q, _, _ = _sines(t, np.deg2rad([40.0, 50.0, 10.0, 70.0]), amp, freq, phase)
    elbow, wrist = arm_fk(q, 0.30, 0.26)
    shoulder = np.array([0.0, -0.18 if side == "right" else 0.18, 0.0])
    pts = [shoulder + mirror(p, side) for p in (np.zeros_like(elbow), elbow, wrist)]
    return t, q, pts


@pytest.mark.parametrize("side", ["right", "left"])
def test_wam_reproduces_the_posture(side):
    t, q_h, (s, e, w) = human_motion(1, side=side)
    res = retarget_wam4(s, e, w, side=side)
    robot = load_robot("wam4")
    assert robot.within_limits(torch.from_numpy(res.q)).all()
    assert not res.clamped.any()
    # Elbow angle: the WAM elbow equals the human elbow flexion.
    np.testing.assert_allclose(res.q[:, 3], q_h[:, 3], atol=1e-9)
    # Upper-arm and forearm directions (robot FK, back in the trunk frame) equal the person's.
    frames = robot.fk(torch.from_numpy(res.q), all_links=True).numpy()
    rot = res.base_rotation
    upper = frames[:, 2, :3, 2] @ rot.T
    fore = frames[:, 4, :3, 2] @ rot.T

    def unit(v):
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    assert np.degrees(np.arccos(np.clip((upper * unit(e - s)).sum(1), -1, 1))).max() < 0.01
    # The forearm within 0.05 deg: the twist smoother (TWIST_CUTOFF_HZ, 6 Hz) moves it by 0.02 deg here
    assert np.degrees(np.arccos(np.clip((fore * unit(w - e)).sum(1), -1, 1))).max() < 0.05
    # Continuous: no joint jumps more than 0.1 rad between frames at 30 Hz.
    assert np.abs(np.diff(res.q, axis=0)).max() < 0.1


def test_wam_twist_ignores_noise_near_a_straight_elbow(monkeypatch):
    # The elbow straightens to 3 deg and bends again while the wrist jitters by 2 mm: near the
    # straight elbow the twist q3 (the forearm's direction about the upper arm) is ill-defined
    # and follows the jitter (up to 4.8 deg per frame here). The smoother (weights sin(q4)^2)
    # cuts those steps 5x while the forearm direction moves by under a degree.
    import lfd.human.retarget as retarget

    t = np.arange(150) / 30.0
    q = np.zeros((150, 4))
    q[:, 0], q[:, 1] = np.deg2rad(40.0), np.deg2rad(50.0)
    q[:, 2] = np.deg2rad(10.0 + 20.0 * np.sin(0.8 * t))
    q[:, 3] = np.deg2rad(3.0 + 60.0 * (1 - np.cos(2 * np.pi * t / 5.0)) / 2)  # 3 deg at both ends
    elbow, wrist = arm_fk(q, 0.30, 0.26)
    wrist = wrist + np.random.default_rng(0).normal(0.0, 0.002, wrist.shape)
    shoulder = np.zeros_like(elbow) + np.array([0.0, -0.18, 0.0])
    elbow, wrist = shoulder + elbow, shoulder + wrist
    smooth = retarget_wam4(shoulder, elbow, wrist, t=t)
    monkeypatch.setattr(retarget, "TWIST_CUTOFF_HZ", None)
    raw = retarget_wam4(shoulder, elbow, wrist, t=t)
    straight = q[:, 3] < np.deg2rad(15.0)
    jump_raw = np.abs(np.diff(raw.q[:, 2]))[straight[1:]].max()
    jump_smooth = np.abs(np.diff(smooth.q[:, 2]))[straight[1:]].max()
    assert jump_raw > 0.06 and jump_smooth < 0.25 * jump_raw  # rad per frame
    np.testing.assert_array_equal(smooth.q[:, 3], raw.q[:, 3])  # the elbow is untouched
    assert np.degrees(np.abs(smooth.error - raw.error)).max() < 1.0  # forearm within a degree
    with pytest.raises(ValueError, match="t must be finite and strictly increasing"):
        retarget_wam4(shoulder, elbow, wrist, t=t[::-1].copy())


def test_wam_clamps_unreachable_postures():
    # Upper arm pointing across the body and backwards: outside the WAM's |q2| <= 2 rad cone.
    s = np.zeros((1, 3))
    e = np.array([[-0.1, 0.28, 0.0]])
    w = e + np.array([[0.2, 0.0, 0.1]])
    res = retarget_wam4(s, e, w)
    assert res.clamped.all() and load_robot("wam4").within_limits(torch.from_numpy(res.q)).all()
    with pytest.raises(ValueError, match="shoulder must have shape"):
        retarget_wam4(np.zeros((3, 2)), e, w)
    with pytest.raises(ValueError, match="NaN"):
        retarget_wam4(np.full((1, 3), np.nan), e, w)


@pytest.mark.parametrize("robot", ["sawyer", "pr2_right_arm"])
def test_seven_dof_follows_the_scaled_wrist_path(robot):
    t, _, (s, e, w) = human_motion(2, duration=3.0)
    res = retarget_wrist_path(s, e, w, robot=robot)
    model = load_robot(robot)
    q = torch.from_numpy(res.q)
    assert model.within_limits(q).all()
    tool = model.fk(q).numpy()[:, :3, 3]
    err = np.linalg.norm(tool - res.target, axis=1)
    assert err.max() < 0.01, err.max()  # within 1 cm everywhere
    # The target is the person's wrist path, scaled and placed at the robot's shoulder.
    rel = (res.target - res.target[0]) / res.scale
    np.testing.assert_allclose(rel, w - w[0], atol=1e-12)
    # Continuous in joint space: no joint moves more than 0.15 rad between frames (30 Hz).
    assert np.abs(np.diff(res.q, axis=0)).max() < 0.15


def test_time_scale_respects_velocity_limits():
    t = np.linspace(0, 1, 101)
    q = np.c_[np.sin(2 * np.pi * t) * 2.0, t]
    ts, factor = time_scale(t, q, [2.0, 2.0])
    assert factor > 1
    qd = np.gradient(q, ts, axis=0)
    assert np.abs(qd).max() <= 2.0 + 1e-9
    assert time_scale(t, 0.1 * q, [2.0, 2.0])[1] == 1.0


def test_wam_auto_mount_avoids_the_side_mounts_singularity():
    # Jumping-jack-like sweep in the frontal plane: the upper arm goes from overhead, through
    # straight out sideways (the side mount's singular axis), to hanging, elbow bent 30 deg.
    t = np.arange(60) / 30.0
    a = np.linspace(0.2, np.pi - 0.2, len(t))  # angle from straight up
    upper = np.stack([np.zeros_like(a), -np.sin(a), np.cos(a)], 1) * 0.3
    fore_dir = np.stack([np.full_like(a, np.sin(np.pi / 6)), -np.sin(a) * np.cos(np.pi / 6),
                         np.cos(a) * np.cos(np.pi / 6)], 1)  # fmt: skip
    s = np.tile([0.0, -0.18, 0.0], (len(t), 1))
    e = s + upper
    w = e + 0.26 * fore_dir / np.linalg.norm(fore_dir, axis=1, keepdims=True)
    robot = load_robot("wam4")
    vmax = robot.velocity_limits.numpy()
    side = retarget_wam4(s, e, w)
    auto = retarget_wam4(s, e, w, mount="auto", t=t)
    f_side, f_auto = time_scale(t, side.q, vmax)[1], time_scale(t, auto.q, vmax)[1]
    assert f_auto < 0.5 * f_side, (f_auto, f_side)
    assert f_auto < 2.0 and not auto.clamped.any() and not auto.singular.any()
    rot = auto.base_rotation
    np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=1e-9)
    assert np.linalg.det(rot) > 0
    frames = robot.fk(torch.from_numpy(auto.q), all_links=True).numpy()
    up_dir = frames[:, 2, :3, 2] @ rot.T
    assert np.degrees(np.arccos(np.clip((up_dir * upper / 0.3).sum(1), -1, 1))).max() < 0.01
    with pytest.raises(ValueError, match="mount must be"):
        retarget_wam4(s, e, w, mount="upside")
    with pytest.raises(ValueError, match="rotation matrix"):
        retarget_wam4(s, e, w, mount=np.eye(3) * 2)
