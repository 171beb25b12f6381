"""benchmarks/video_multiview.py on synthetic views of a known skeleton: the angles from keypoint
geometry, and an arm that cannot be analysed is reported while the other is still measured."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np

from lfd.human.multiview import read_calibration
from lfd.human.video import MEDIAPIPE_LANDMARKS, VideoKeypoints

ROOT = Path(__file__).resolve().parents[3]


def load_benchmark():
    spec = importlib.util.spec_from_file_location(
        "video_multiview", ROOT / "benchmarks" / "video_multiview.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def skeleton(T: int) -> np.ndarray:
    """(T, 33, 3) m, z up: a person at the lab origin, right elbow flexing 10..100 deg with the upper
    arm 30 deg from the trunk's down axis in the frontal plane; left arm hanging straight."""
    X = np.zeros((T, 33, 3))
    at = {n: i for i, n in enumerate(MEDIAPIPE_LANDMARKS)}
    for side, x in (("left", -0.2), ("right", 0.2)):
        X[:, at[f"{side}_shoulder"]] = [x, 0, 1.45]
        X[:, at[f"{side}_hip"]] = [x * 0.6, 0, 0.95]
    flex = np.radians(np.linspace(10, 100, T))
    elev = np.radians(30)
    upper = 0.3 * np.array([np.sin(elev), 0, -np.cos(elev)])
    X[:, at["right_elbow"]] = X[:, at["right_shoulder"]] + upper
    fore = 0.25 * np.stack([np.sin(elev) * np.cos(flex), -np.sin(flex), -np.cos(elev) * np.cos(flex)], 1)
    X[:, at["right_wrist"]] = X[:, at["right_elbow"]] + fore
    X[:, at["left_elbow"]] = X[:, at["left_shoulder"]] + [0, 0, -0.3]
    X[:, at["left_wrist"]] = X[:, at["left_elbow"]] + [0, 0, -0.25]
    rest = [
        i
        for i, n in enumerate(MEDIAPIPE_LANDMARKS)
        if not any(k in n for k in ("shoulder", "hip", "elbow", "wrist"))
    ]
    X[:, rest] = [0, 0.05, 1.6]  # head and feet: one point, far from the arms
    return X


def test_geometry_angles_and_an_arm_that_cannot_be_analysed(pose2sim_demo):
    bench = load_benchmark()
    calib = read_calibration(pose2sim_demo / "calibration" / "Calib.qca.txt")
    T = 40
    X = skeleton(T)
    angles = bench.arm_angles(X, "right")
    np.testing.assert_allclose(angles[:, 0], np.linspace(10, 100, T), atol=1e-9)  # elbow flexion
    np.testing.assert_allclose(angles[:, 1], 30.0, atol=1e-9)  # elevation from the trunk's down axis
    px = calib.project(X)
    vis = np.ones((4, T, 33))
    vis[:, :, MEDIAPIPE_LANDMARKS.index("left_wrist")] = 0.0  # never seen: the left arm has no wrist
    # Monocular "world" landmarks: the same skeleton, rotated and shifted (angles are invariant).
    c, s = np.cos(0.7), np.sin(0.7)
    world = X @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + [0.1, -0.2, 0.3]
    kps = [
        VideoKeypoints(t=np.arange(T) / 60.0, frame_index=np.arange(T), pixels=px[i], visibility=vis[i], world=world,
                       detected=np.ones(T, bool), other_person=np.zeros(T, bool), image_size=(1088, 1920))
        for i in range(4)
    ]  # fmt: skip
    args = argparse.Namespace(no_reconcile=False, strategy="greedy", max_error_px=20.0, cutoff=0.0)
    out = bench.evaluate(calib, kps, args)
    assert out["arms"]["left"].startswith("not analysable") and "wrist" in out["arms"]["left"]
    assert out["arms"]["right"] == f"measured on {T} frames"
    assert (
        out["reprojection_px_median_arm"] < 1e-6
        and out["reprojection_px_per_arm_joint"]["left_wrist"] is None
    )
    assert out["monocular_median_abs_deg"]["elbow_flexion"] < 1e-6
    assert set(out["rmse_deg"]) == {f"cam0{i}_right" for i in range(1, 5)}
    assert out["other_person_frames"] == dict.fromkeys(calib.names, 0)
