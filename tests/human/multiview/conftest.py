"""Fixtures of the lfd.human.multiview tests: MediaPipe (full model) on the first frames of the four
synchronised Pose2Sim demo views, run once per session; Pose2Sim's multi-person demo (same wheel)."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from lfd.human.multiview import read_calibration
from lfd.human.video import estimate_keypoints


@pytest.fixture(scope="session")
def pose2sim_views(pose2sim_demo, mediapipe_ok):
    """(calibration, pixels (4, 10, 33, 2), visibility (4, 10, 33)) of the first 10 frames of each view."""
    calib = read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt", n_cameras=4)
    kps = [
        estimate_keypoints(pose2sim_demo / "videos" / f"{n}.mp4", width=640, max_frames=10)
        for n in calib.names
    ]
    return calib, np.stack([k.pixels for k in kps]), np.stack([k.visibility for k in kps])


@pytest.fixture(scope="session")
def pose2sim_multiperson(pose2sim_demo, tmp_path_factory):
    """Pose2Sim's Demo_MultiPerson (four views, two people), extracted from the wheel the
    single-person demo came from (``pose2sim_demo`` fetched it)."""
    folder = next(p for p in pose2sim_demo.parents if p.name.startswith("pose2sim-"))
    wheel = folder.parent / f"{folder.name}.whl"
    root = tmp_path_factory.mktemp("pose2sim_multiperson")
    prefix = "Pose2Sim/Demo_MultiPerson/"
    with zipfile.ZipFile(wheel) as zf:
        for name in zf.namelist():
            if name.startswith(prefix) and (name.endswith(".mp4") or name.endswith(".qca.txt")):
                zf.extract(name, root)
    return root / prefix
