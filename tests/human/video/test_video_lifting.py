"""lfd.human.video.lifting: a known 3-D arm motion, projected with weak perspective and given with
its depth flattened (as MediaPipe's world landmarks flatten it), is lifted back to the true elbow
angles; the depth's sign comes from the world landmarks, both ways."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.human.video import MEDIAPIPE_LANDMARKS, lifting
from lfd.human.video.lifting import lift_arm_depth

I = {n: i for i, n in enumerate(MEDIAPIPE_LANDMARKS)}
UPPER, FORE = 0.30, 0.25  # m


def _body(T: int = 100) -> np.ndarray:
    """(T, 33, 3) m, camera axes (x right, y down, z away), hips' midpoint at the origin: an upright
    torso facing the camera; for the first 30 frames both arms move in the image plane (the
    clip's side-on views of each segment), then they rise and flex, the right arm towards the
    camera (z < 0) and the left one away from it."""
    t = np.linspace(0.0, 1.0, T)
    p = np.zeros((T, 33, 3))
    for side, x in (("left", 0.2), ("right", -0.2)):
        p[:, I[f"{side}_hip"]] = (x / 2, 0.0, 0.0)
        p[:, I[f"{side}_shoulder"]] = (x, -0.5, 0.0)
    in_plane = np.arange(T) < 30
    flex = np.radians(np.where(in_plane, 10 + 80 * t, 20 + 100 * t))  # elbow flexion
    rise = np.where(in_plane, 0.0, np.radians(70 * t))  # upper arm raised forward/backward
    for side, depth in (("left", 1.0), ("right", -1.0)):
        u = np.stack([np.zeros(T), np.cos(rise), depth * np.sin(rise)], 1)
        f = np.where(
            in_plane[:, None],
            np.stack([np.sin(flex), np.cos(flex), np.zeros(T)], 1),
            np.stack([np.zeros(T), np.cos(rise + flex), depth * np.sin(rise + flex)], 1),
        )
        sh = p[:, I[f"{side}_shoulder"]]
        p[:, I[f"{side}_elbow"]] = sh + UPPER * u
        p[:, I[f"{side}_wrist"]] = p[:, I[f"{side}_elbow"]] + FORE * f
        for k, hand in enumerate(("pinky", "index", "thumb")):
            p[:, I[f"{side}_{hand}"]] = p[:, I[f"{side}_wrist"]] + 0.05 * f + (0.0, 0.0, 0.01 * k)
    return p


def _project(p: np.ndarray, depth: float = 3.0, focal: float = 1000.0) -> np.ndarray:
    """Weak perspective: every point divided by the same depth (the person's)."""
    return focal * p[..., :2] / depth + np.array([320.0, 240.0])


def _flexion(p: np.ndarray, side: str) -> np.ndarray:
    sh, el, wr = (p[:, I[f"{side}_{j}"]] for j in ("shoulder", "elbow", "wrist"))
    a, b = el - sh, wr - el
    cos = (a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def test_lifted_angles_match_the_true_arm_and_flattened_depth_does_not():
    truth = _body()
    world = truth * np.array([1.0, 1.0, 0.4])  # depth flattened, sign kept
    lifted = lift_arm_depth(_project(truth), world, sign_margin=0.0)  # the plain sign: exact
    for side in ("left", "right"):
        true_flex = _flexion(truth, side)
        assert np.abs(_flexion(lifted, side) - true_flex).max() < 0.5
        # The flattened world landmarks are far off: the check can fail.
        assert np.abs(_flexion(world, side) - true_flex).max() > 10
    for side in ("left", "right"):
        for j in ("elbow", "wrist"):  # metric positions relative to the hips, depth included
            np.testing.assert_allclose(lifted[:, I[f"{side}_{j}"]], truth[:, I[f"{side}_{j}"]], atol=2e-3)
        # The hand moves rigidly with the wrist (depth offsets from the world landmarks kept).
        w, h = I[f"{side}_wrist"], I[f"{side}_index"]
        np.testing.assert_allclose(lifted[:, h, 2] - lifted[:, w, 2], world[:, h, 2] - world[:, w, 2])


def test_depth_sign_follows_the_world_landmarks():
    truth = _body()
    pixels = _project(truth)
    world = truth * np.array([1.0, 1.0, 0.4])
    mirrored = world * np.array([1.0, 1.0, -1.0])  # same image, every depth difference flipped
    a, b = lift_arm_depth(pixels, world), lift_arm_depth(pixels, mirrored)
    el, wr = I["right_elbow"], I["right_wrist"]
    moving = np.abs(truth[:, wr, 2] - truth[:, el, 2]) > 0.01
    assert moving.sum() > 50
    # The forearm's depth difference has the true sign (both signs occur), then the mirrored one.
    true_dz = truth[moving, wr, 2] - truth[moving, el, 2]
    assert (true_dz < 0).any() and (true_dz > 0).any()
    np.testing.assert_array_equal(np.sign(a[moving, wr, 2] - a[moving, el, 2]), np.sign(true_dz))
    np.testing.assert_allclose(b[..., 2], -a[..., 2], atol=1e-12)
    np.testing.assert_allclose(_flexion(b, "right"), _flexion(a, "right"), atol=1e-9)


def test_a_segment_never_parallel_to_the_image_keeps_its_world_depth(monkeypatch):
    # The right upper arm points at the camera all clip long (its image length is at most 40 % of
    # its length): the percentile cannot be its true length, so its world depth difference is kept.
    truth = _body()
    sh, el = I["right_shoulder"], I["right_elbow"]
    T = len(truth)
    tilt = np.radians(np.linspace(0.0, 20.0, T))
    u = np.stack([np.zeros(T), np.sin(tilt), -np.cos(tilt)], 1)
    shift = truth[:, sh] + UPPER * u - truth[:, el]
    for j in ("elbow", "wrist", "pinky", "index", "thumb"):
        truth[:, I[f"right_{j}"]] += shift
    world = truth * np.array([1.0, 1.0, 0.4])
    with pytest.warns(UserWarning, match="right_shoulder-right_elbow never lies parallel"):
        lifted = lift_arm_depth(_project(truth), world, sign_margin=0.0)
    np.testing.assert_allclose(lifted[:, el, 2] - lifted[:, sh, 2], world[:, el, 2] - world[:, sh, 2])
    # Without the guard the 85th percentile of a foreshortened length would be taken as the bone
    # and the depth difference would be rebuilt from it (the guard can fail).
    monkeypatch.setattr(lifting, "MIN_LENGTH_RATIO", 0.0)
    unguarded = lift_arm_depth(_project(truth), world, sign_margin=0.0)
    assert np.abs((unguarded - lifted)[:, el, 2]).max() > 0.02
    # The left arm, seen parallel to the image at times, is still lifted to the truth.
    assert np.abs(_flexion(lifted, "left") - _flexion(truth, "left")).max() < 0.5


def test_a_world_depth_wavering_around_zero_does_not_flip_the_lifted_depth():
    # The right forearm is foreshortened throughout (true depth difference 0.15 m towards the
    # camera) while the world landmarks' depth difference wavers +-1 cm around zero, as MediaPipe's
    # does for a segment it sees nearly side-on. The plain sign flips the lifted depth between
    # its full +- size every frame; the default margin (SIGN_MARGIN, 2 cm) halves those jumps.
    truth = _body()
    el, wr = I["right_elbow"], I["right_wrist"]
    world = truth * np.array([1.0, 1.0, 0.4])
    world[:, wr, 2] = world[:, el, 2] + 0.01 * np.where(np.arange(len(truth)) % 2, 1.0, -1.0)
    pixels = _project(truth)
    plain = lift_arm_depth(pixels, world, sign_margin=0.0)
    soft = lift_arm_depth(pixels, world)
    late = np.arange(len(truth)) > 60  # raised and flexed: the forearm is foreshortened
    jump_plain = np.abs(np.diff((plain[:, wr, 2] - plain[:, el, 2])[late])).max()
    jump_soft = np.abs(np.diff((soft[:, wr, 2] - soft[:, el, 2])[late])).max()
    assert jump_plain > 0.15 and jump_soft < 0.6 * jump_plain
    with pytest.raises(ValueError, match="sign_margin"):
        lift_arm_depth(pixels, world, sign_margin=-0.01)


def test_missing_landmarks_stay_missing_and_bad_input_is_refused():
    truth = _body(40)
    pixels, world = _project(truth), truth.copy()
    pixels[5, I["right_elbow"]] = np.nan
    lifted = lift_arm_depth(pixels, world)
    assert np.isnan(lifted[5, I["right_elbow"]]).any() and np.isfinite(lifted[6]).all()
    with pytest.raises(ValueError, match="pixels must have shape"):
        lift_arm_depth(pixels[:, :10], world)
    with pytest.raises(ValueError, match="world must have shape"):
        lift_arm_depth(pixels, world[:-1])
    with pytest.raises(ValueError, match="length_percentile"):
        lift_arm_depth(pixels, world, length_percentile=0.0)


def test_sports2d_skeleton_with_lifted_depth_runs_analyze_arm(sports2d_keypoints):
    from lfd.human import analyze_arm

    kp = sports2d_keypoints
    sk = kp.to_skeleton(lift_depth=True)
    expected = lift_arm_depth(kp.pixels, kp.world)
    j = sk.names.index("elbow_right")
    ok = sk.tracked[:, j]
    np.testing.assert_allclose(sk.positions[ok, j], expected[ok, I["right_elbow"]])
    result = analyze_arm(sk, side="right")
    assert 0.2 < result.segment_lengths["upper_arm"] < 0.4
