"""lfd.human.video.lifting: a known 3-D arm motion, projected with weak perspective and given with
its depth flattened (as MediaPipe's world landmarks flatten it), is lifted back to the true elbow
angles; the depth's sign comes from the world landmarks, both ways."""

from __future__ import annotations

import numpy as np
import pytest

from lfd.human.video import MEDIAPIPE_LANDMARKS
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
    lifted = lift_arm_depth(_project(truth), world)
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
