"""Fixtures of the lfd.human.video tests: keypoint estimation on the sports2d demo, run once per
session and shared by all tests."""

from __future__ import annotations

import pytest

from lfd.human.video import VideoKeypoints, estimate_keypoints


@pytest.fixture(scope="session")
def sports2d_keypoints(sports2d_video, mediapipe_ok) -> VideoKeypoints:
    return estimate_keypoints(sports2d_video, width=640, stride=2, max_frames=95)
