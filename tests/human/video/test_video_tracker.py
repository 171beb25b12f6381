"""lfd.human.video.tracker: following one person in real videos (sports2d demo) and in composed
videos with known content (no person, a second person, variable frame times)."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest

from lfd.human.video import estimate_keypoints, iter_frames, video_info

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


def test_sports2d_follows_one_person_with_real_frame_times(sports2d_keypoints, sports2d_video):
    kp = sports2d_keypoints
    info = video_info(sports2d_video)
    assert kp.image_size == (info.width, info.height) == (1768, 994)
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
