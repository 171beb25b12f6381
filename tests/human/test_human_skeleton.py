"""Canonical joint names from the naming schemes of Kinect, OpenPose/MediaPipe, OpenSim and short forms."""

from __future__ import annotations

import pytest

from lfd.human import canonical_joint_name


@pytest.mark.parametrize(
    ("name", "canonical"),
    [("ShoulderRight", "shoulder_right"), ("right_shoulder", "shoulder_right"), ("RShoulder", "shoulder_right"),
     ("L.Elbow", "elbow_left"), ("HandTipLeft", "hand_tip_left"), ("SpineShoulder", "spine_shoulder"),
     ("wrist_l", "wrist_left"), ("Neck", "neck")],
)  # fmt: skip
def test_canonical_names(name, canonical):
    assert canonical_joint_name(name) == canonical
