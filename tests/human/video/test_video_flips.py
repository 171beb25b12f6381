"""lfd.human.video.flips: MediaPipe's front/back relabellings found and undone (synthetic and sports2d)."""

from __future__ import annotations

import numpy as np

from lfd.human.video import MEDIAPIPE_LANDMARKS, VideoKeypoints, estimate_keypoints
from lfd.human.video.landmarks import ALL_LEFT, ALL_RIGHT


def _synthetic_keypoints(x_offset: np.ndarray) -> VideoKeypoints:
    """One person facing the camera: left landmarks at ``+x_offset`` px of the body centre, right at ``-``."""
    T = len(x_offset)
    side = np.array([1.0 if "left" in n else -1.0 if "right" in n else 0.0 for n in MEDIAPIPE_LANDMARKS])
    height = np.linspace(0.0, 300.0, 33)  # px below the head
    centre = np.stack([300.0 + np.arange(T), np.full(T, 100.0)], 1)  # walks 1 px/frame to the right
    pixels = centre[:, None] + np.stack(
        [side[None] * x_offset[:, None], np.broadcast_to(height, (T, 33))], -1
    )
    world = np.stack(
        [
            side[None] * x_offset[:, None] / 400,
            np.broadcast_to(height / 400, (T, 33)),
            np.broadcast_to(np.sin(np.arange(33)) * 0.05, (T, 33)),
        ],
        -1,
    )
    return VideoKeypoints(
        t=np.arange(T) / 30,
        frame_index=np.arange(T),
        pixels=pixels,
        visibility=np.full((T, 33), 0.9),
        world=world,
        detected=np.ones(T, bool),
        other_person=np.zeros(T, bool),
        image_size=(640, 480),
    )


def test_front_back_relabelling_is_found_and_undone():
    truth = _synthetic_keypoints(np.full(40, 40.0))
    assert not truth.front_back_flips().any()
    # MediaPipe decides for frames 10-19 that the person shows their back: labels swapped, depth mirrored.
    seen = _synthetic_keypoints(np.full(40, 40.0))
    for arr in (seen.pixels, seen.world):
        arr[10:20, ALL_LEFT], arr[10:20, ALL_RIGHT] = (
            arr[10:20, ALL_RIGHT].copy(),
            arr[10:20, ALL_LEFT].copy(),
        )
    seen.world[10:20, :, 2] *= -1
    flips = seen.front_back_flips()
    np.testing.assert_array_equal(np.nonzero(flips)[0], np.arange(10, 20))
    fixed = seen.repaired()
    np.testing.assert_allclose(fixed.pixels, truth.pixels)
    np.testing.assert_allclose(fixed.world, truth.world)
    np.testing.assert_allclose(seen.to_skeleton(repair_flips=True).positions, truth.to_skeleton().positions)
    assert not np.allclose(seen.to_skeleton().positions, truth.to_skeleton().positions)
    # A real turn (the shoulders swap sides in the image gradually, through side-on) is no relabelling.
    turning = _synthetic_keypoints(40.0 * np.cos(np.linspace(0, np.pi, 40)))
    assert not turning.front_back_flips().any()


def test_sports2d_front_back_relabelling(sports2d_video, mediapipe_ok):
    # The person faces the camera while waving: their right shoulder is on the image's left.
    # MediaPipe turns them around in frames 4-6, 12 and 67-73 (stride 1, 640 px; checked by eye).
    kp = estimate_keypoints(sports2d_video, width=640, max_frames=80)
    ok = kp.detected
    wrong = lambda k: np.nonzero(ok & (k.pixels[:, 12, 0] > k.pixels[:, 11, 0]))[0]  # noqa: E731
    assert len(wrong(kp)) >= 5
    np.testing.assert_array_equal(np.nonzero(kp.front_back_flips())[0], wrong(kp))
    assert len(wrong(kp.repaired())) == 0
