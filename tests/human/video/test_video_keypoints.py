"""lfd.human.video on real videos (sports2d demo) and on composed videos with known content."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest

from lfd.human import analyze_arm
from lfd.human.video import VideoKeypoints, estimate_keypoints, iter_frames, video_info

WIDE = 600  # px width of each person's view on the composed canvas


def write_video(path: Path, frames, times=None, rate: int = 30) -> Path:
    """Write RGB frames to an MP4; ``times`` (s) become the presentation timestamps (ms clock)."""
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=rate)
        stream.width, stream.height = frames[0].shape[1], frames[0].shape[0]
        stream.pix_fmt = "yuv420p"
        stream.codec_context.time_base = stream.time_base = __import__("fractions").Fraction(1, 1000)
        for i, img in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(img), format="rgb24")
            frame.pts = int(round((times[i] if times is not None else i / rate) * 1000))
            frame.time_base = stream.time_base
            for packet in stream.encode(frame):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    return path


@pytest.fixture(scope="module")
def sports2d_keypoints(sports2d_video, mediapipe_ok) -> VideoKeypoints:
    return estimate_keypoints(sports2d_video, width=640, stride=2, max_frames=95)


def test_sports2d_follows_one_person_with_real_frame_times(sports2d_keypoints, sports2d_video):
    kp = sports2d_keypoints
    info = video_info(sports2d_video)
    assert kp.image_size == (info["width"], info["height"]) == (1768, 994)
    # Real clock: frame index / 30 fps (the stream's pts), every second frame processed.
    np.testing.assert_allclose(kp.t, kp.frame_index / 30.0, atol=1e-6)
    assert np.all(np.diff(kp.frame_index) == 2)
    early = kp.frame_index < 160  # the person on the roof waves; a second person walks below
    assert kp.detected[early].mean() > 0.9
    centre_y = kp.pixels[:, [11, 12, 23, 24], 1].mean(axis=1)  # NaN where not detected
    assert np.all(centre_y[early & kp.detected] < 0.45 * 994), (
        "followed the walker instead of the person on the roof"
    )
    # When the roof person jumps off, the estimator's follow jumps to the walker: those frames are flagged.
    assert kp.other_person[kp.frame_index >= 160].any()
    assert not kp.detected[kp.other_person].any()
    # Pixels lie in the frame, visibility in [0, 1], world landmarks metric (shoulder width 0.2-0.5 m).
    ok = kp.detected
    assert np.all((kp.pixels[ok] >= -200) & (kp.pixels[ok] <= 2000))
    assert np.all((kp.visibility >= 0) & (kp.visibility <= 1))
    width = np.linalg.norm(kp.world[ok, 11] - kp.world[ok, 12], axis=1)
    assert 0.2 < np.median(width) < 0.5


def test_sports2d_skeleton_runs_analyze_arm(sports2d_keypoints, tmp_path):
    sk = sports2d_keypoints.to_skeleton()
    assert {"shoulder_right", "elbow_right", "wrist_right", "hip_left", "hand_tip_right"} <= set(sk.names)
    result = analyze_arm(sk, side="right")
    summary = result.summary()
    assert summary["frames"] == sports2d_keypoints.n_frames
    # The person raises the arms overhead and waves: large abduction and elbow motion.
    assert summary["abduction_rom_deg"] > 40 and summary["elbow_flexion_rom_deg"] > 20
    assert 0.2 < result.segment_lengths["upper_arm"] < 0.4
    path = sports2d_keypoints.to_csv(tmp_path / "kp.csv")
    header = path.read_text().splitlines()[0].split(",")
    assert header[:4] == ["time_s", "frame", "detected", "other_person"] and "wrist_right_px" in header
    back = VideoKeypoints.load(sports2d_keypoints.save(tmp_path / "kp.npz"))
    np.testing.assert_array_equal(back.world, sports2d_keypoints.world)


@pytest.fixture(scope="module")
def two_people(pose2sim_demo):
    """Person A (cam03 view) on the left, person B (cam04 view) on the right of a 1280x720 canvas."""
    import cv2

    views = {}
    for cam in ("cam03", "cam04"):
        img = next(iter_frames(pose2sim_demo / "videos" / f"{cam}.mp4", max_frames=1))[2]
        views[cam] = cv2.resize(img[100:1400], (WIDE, 720))
    grey = np.full((720, 1280, 3), 127, np.uint8)

    def canvas(left: bool, right: bool) -> np.ndarray:
        img = grey.copy()
        if left:
            img[:, :WIDE] = views["cam03"]
        if right:
            img[:, -WIDE:] = views["cam04"]
        return img

    return canvas


def test_no_person_frames_and_variable_frame_times(two_people, tmp_path, mediapipe_ok):
    frames = [two_people(True, False)] * 6 + [two_people(False, False)] * 5 + [two_people(True, False)] * 6
    times = np.cumsum(np.r_[0.0, np.tile([0.030, 0.045], 8)])  # variable frame rate
    path = write_video(tmp_path / "gap.mp4", frames, times)
    kp = estimate_keypoints(path, width=640)
    np.testing.assert_allclose(kp.t, times, atol=1.5e-3)
    expected = np.r_[np.ones(6), np.zeros(5), np.ones(6)].astype(bool)
    assert np.array_equal(kp.detected, expected)
    sk = kp.to_skeleton()
    assert np.isnan(sk.positions[6:11]).all() and not sk.tracked[6:11].any()
    blank = write_video(tmp_path / "blank.mp4", [two_people(False, False)] * 4)
    with pytest.raises(ValueError, match="no person found"):
        estimate_keypoints(blank).to_skeleton()


def test_second_person_is_not_taken_for_the_followed_one(two_people, tmp_path, mediapipe_ok):
    # A alone, then only B (A left the picture), then both again: B's frames must not be A's.
    frames = [two_people(True, False)] * 6 + [two_people(False, True)] * 5 + [two_people(True, True)] * 6
    kp = estimate_keypoints(write_video(tmp_path / "two.mp4", frames), width=640)
    centre_x = kp.pixels[:, [11, 12, 23, 24], 0].mean(axis=1)
    assert kp.detected[:6].all() and (centre_x[:6] < WIDE).all()
    assert not kp.detected[6:11].any()  # B is never taken for A ...
    assert kp.other_person[6:11].sum() >= 3  # ... but flagged (the first frame after A left may be empty)
    both = slice(11, 17)
    assert kp.detected[both].all() and (centre_x[both] < WIDE).all(), centre_x


def test_bad_videos_give_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="video file not found"):
        list(iter_frames(tmp_path / "missing.mp4"))
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 100)
    with pytest.raises(ValueError, match="cannot be decoded"):
        video_info(junk)
    with pytest.raises(ValueError, match="stride"):
        list(iter_frames(junk, stride=0))


def _synthetic_keypoints(x_offset: np.ndarray) -> VideoKeypoints:
    """One person facing the camera: left landmarks at ``+x_offset`` px of the body centre, right at ``-``."""
    from lfd.human.video import MEDIAPIPE_LANDMARKS

    T = len(x_offset)
    side = np.array([1.0 if "left" in n else -1.0 if "right" in n else 0.0 for n in MEDIAPIPE_LANDMARKS])
    height = np.linspace(0.0, 300.0, 33)  # px below the head
    centre = np.stack([300.0 + np.arange(T), np.full(T, 100.0)], 1)  # walks 1 px/frame to the right
    pixels = centre[:, None] + np.stack(
        [side[None] * x_offset[:, None], np.broadcast_to(height, (T, 33))], -1
    )
    world = np.stack([side[None] * x_offset[:, None] / 400, np.broadcast_to(height / 400, (T, 33)),
                      np.broadcast_to(np.sin(np.arange(33)) * 0.05, (T, 33))], -1)  # fmt: skip
    return VideoKeypoints(t=np.arange(T) / 30, frame_index=np.arange(T), pixels=pixels, visibility=np.full((T, 33), 0.9),
                          world=world, detected=np.ones(T, bool), other_person=np.zeros(T, bool),
                          image_size=(640, 480))  # fmt: skip


def test_front_back_relabelling_is_found_and_undone():
    from lfd.human.video import _ALL_LEFT, _ALL_RIGHT

    truth = _synthetic_keypoints(np.full(40, 40.0))
    assert not truth.front_back_flips().any()
    # MediaPipe decides for frames 10-19 that the person shows their back: labels swapped, depth mirrored.
    seen = _synthetic_keypoints(np.full(40, 40.0))
    for arr in (seen.pixels, seen.world):
        arr[10:20, _ALL_LEFT], arr[10:20, _ALL_RIGHT] = (
            arr[10:20, _ALL_RIGHT].copy(),
            arr[10:20, _ALL_LEFT].copy(),
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
