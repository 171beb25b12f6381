"""lfd.human.video.estimator: the landmark model choice (full | heavy), the heavy model found in
MediaPipe's module folder or a passed file, checked by its published checksum, and never downloaded."""

from __future__ import annotations

import hashlib
import logging
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from lfd.human.video import estimate_keypoints, iter_frames
from lfd.human.video import estimator as est
from lfd.human.video.keypoints import VideoKeypoints


@pytest.fixture(scope="module")
def installed_heavy(heavy_pose_model):
    """The heavy model the test command provisions (scripts/get_pose_model.py, from npm)."""
    return heavy_pose_model


def test_installed_heavy_model_is_the_published_file(installed_heavy):
    # Independent check of the constants: hashlib over the bytes, the size npm reports.
    data = installed_heavy.read_bytes()
    assert len(data) == 27_709_200
    assert hashlib.sha256(data).hexdigest() == est.HEAVY_MODEL_SHA256
    assert est.install_heavy_model() == installed_heavy


def test_provisioning_script_finds_the_installed_model(installed_heavy):
    root = Path(__file__).resolve().parents[3]
    proc = subprocess.run(
        [sys.executable, str(root / "scripts" / "get_pose_model.py")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-1000:]
    assert f"already installed, verified: {installed_heavy}" in proc.stdout


def test_bad_model_names_and_missing_or_wrong_heavy_files(tmp_path, monkeypatch, mediapipe_ok):
    with pytest.raises(ValueError, match="pose.model must be one of full, heavy, got 'huge'"):
        est.load_pose_estimator(model="huge")
    with pytest.raises(ValueError, match="model is 'full'"):
        est.load_pose_estimator(model="full", heavy_model=tmp_path / "x.tflite")
    target = tmp_path / "mediapipe" / "modules" / "pose_landmark" / "pose_landmark_heavy.tflite"
    monkeypatch.setattr(est, "heavy_model_path", lambda: target)
    # Not installed: one line saying how to get it.
    with pytest.raises(
        FileNotFoundError, match=r"get_pose_model\.py` \(npm pack @mediapipe/pose@0\.5\.1675469404"
    ):
        est.load_pose_estimator(model="heavy")
    with pytest.raises(FileNotFoundError, match="no file at"):
        est.load_pose_estimator(model="heavy", heavy_model=tmp_path / "missing.tflite")
    # A file of the right size but other bytes is refused and not installed.
    fake = tmp_path / "pose_landmark_heavy.tflite"
    fake.write_bytes(b"\0" * 27_709_200)
    with pytest.raises(ValueError, match="is not pose_landmark_heavy.tflite of @mediapipe/pose"):
        est.load_pose_estimator(model="heavy", heavy_model=fake)
    assert not target.exists()
    target.parent.mkdir(parents=True)
    target.write_bytes(b"truncated")
    with pytest.raises(ValueError, match="is not the published heavy model"):
        est.install_heavy_model()


def test_a_passed_heavy_model_is_verified_and_installed(installed_heavy, tmp_path, monkeypatch):
    target = tmp_path / "modules" / "pose_landmark_heavy.tflite"
    monkeypatch.setattr(est, "heavy_model_path", lambda: target)
    assert est.install_heavy_model(installed_heavy) == target
    assert target.read_bytes() == installed_heavy.read_bytes()


def test_heavy_runs_without_network_and_is_recorded(installed_heavy, pose2sim_demo, tmp_path, monkeypatch):
    def offline(*args, **kwargs):
        raise AssertionError("lfd must not download at run time")

    monkeypatch.setattr(urllib.request, "urlopen", offline)
    from mediapipe.python.solutions import download_utils

    original = download_utils.download_oss_model
    # MediaPipe's own downloader is replaced while the estimator is built, and restored after.
    with pytest.raises(FileNotFoundError, match="does not download models at run time"):
        est._no_download("mediapipe/modules/pose_landmark/pose_landmark_lite.tflite")
    video = pose2sim_demo / "videos" / "cam01.mp4"
    kp = estimate_keypoints(video, width=640, max_frames=4, model="heavy")
    assert download_utils.download_oss_model is original
    assert kp.model == "heavy" and kp.detected.all()
    back = VideoKeypoints.load(kp.save(tmp_path / "kp.npz"))
    assert back.model == "heavy"
    # The person stands in the middle of cam01 (1080 x 1920): landmarks inside the frame, shoulders
    # above hips (y down).
    frame = next(iter_frames(video, 640))[2]
    assert frame.shape[1] == 640
    px = kp.pixels
    assert np.all((px > 0) & (px < [1080, 1920]))
    assert np.all(px[:, [11, 12], 1].mean(1) < px[:, [23, 24], 1].mean(1))


# ---------------------------------------------------------------------------- MediaPipe's C++ log lines
#: What MediaPipe 0.10.14 writes on standard error when a pose graph starts (measured on the sports2d demo).
STARTUP_LINES = [
    "INFO: Created TensorFlow Lite XNNPACK delegate for CPU.",
    "WARNING: All log messages before absl::InitializeLog() is called are written to STDERR",
    "W0000 00:00:1796552345.024021   14440 inference_feedback_manager.cc:114] Feedback manager requires a "
    "model with a single signature inference. Disabling support for feedback tensors.",
]


def test_cpp_log_lines_go_to_logging_and_the_rest_is_kept(caplog):
    other_warning = "W1206 10:12:55.123456   14440 calculator_graph.cc:887] a warning that matters"
    error = "E0000 00:00:1796552345.1   14440 graph.cc:12] an error"
    text = "\n".join([*STARTUP_LINES, "a line of someone else", other_warning, error, "\r 10%|#  | 1/10"])
    with caplog.at_level(logging.DEBUG, logger=est.LOGGER.name):
        rest = est.route_cpp_log(text)
    assert rest == "a line of someone else\n\r 10%|#  | 1/10"
    routed = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert routed == [
        *[(logging.DEBUG, line) for line in STARTUP_LINES],
        (logging.WARNING, other_warning),
        (logging.ERROR, error),
    ]


def test_estimating_a_video_prints_no_mediapipe_log_lines(sports2d_video, mediapipe_ok):
    """In a fresh process (MediaPipe logs once per process), a few frames through the tracker write none
    of the start-up lines on standard error; the progress bar is still there."""
    code = (
        "import sys; from lfd.human.video import estimate_keypoints; "
        "kp = estimate_keypoints(sys.argv[1], max_frames=5, progress=True); print(len(kp.t))"
    )
    run = subprocess.run(
        [sys.executable, "-c", code, str(sports2d_video)], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.split() == ["5"]
    for marker in (
        "TensorFlow Lite",
        "absl::InitializeLog",
        "inference_feedback_manager",
        "W0000",
        "gl_context",
    ):
        assert marker not in run.stderr, run.stderr
    assert "5/5" in run.stderr
