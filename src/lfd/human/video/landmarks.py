"""MediaPipe Pose's 33 landmarks (BlazePose topology): their names, the canonical joint names of
:mod:`lfd.human` they map to, the left/right pairs, and the torso used to follow one person."""

from __future__ import annotations

import numpy as np

from ..skeleton import canonical_joint_name

__all__ = ["ARM_EDGES", "CANONICAL_NAMES", "LEFT_RIGHT_GROUPS", "MEDIAPIPE_LANDMARKS", "torso"]

#: MediaPipe Pose landmark order (BlazePose topology, 33 points).
MEDIAPIPE_LANDMARKS = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye", "right_eye_outer",
    "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder", "right_shoulder", "left_elbow",
    "right_elbow", "left_wrist", "right_wrist", "left_pinky", "right_pinky", "left_index", "right_index",
    "left_thumb", "right_thumb", "left_hip", "right_hip", "left_knee", "right_knee", "left_ankle",
    "right_ankle", "left_heel", "right_heel", "left_foot_index", "right_foot_index",
)  # fmt: skip
_CANONICAL_OVERRIDES = {"left_index": "hand_tip_left", "right_index": "hand_tip_right", "nose": "head"}
#: Canonical joint name of each landmark (``left_shoulder`` -> ``shoulder_left``, ``nose`` -> ``head``).
CANONICAL_NAMES = tuple(_CANONICAL_OVERRIDES.get(n, canonical_joint_name(n)) for n in MEDIAPIPE_LANDMARKS)
#: Left/right trunk landmarks (shoulders, hips; indices into the 33) that decide a front/back
#: relabelling: arms move fast and legs cross in a side view of a walk.
TRUNK_LEFT = [MEDIAPIPE_LANDMARKS.index(f"left_{n}") for n in ("shoulder", "hip")]
TRUNK_RIGHT = [MEDIAPIPE_LANDMARKS.index(MEDIAPIPE_LANDMARKS[i].replace("left", "right")) for i in TRUNK_LEFT]
#: Every left landmark and its right counterpart, in the same order.
ALL_LEFT = [i for i, n in enumerate(MEDIAPIPE_LANDMARKS) if "left" in n]
ALL_RIGHT = [MEDIAPIPE_LANDMARKS.index(MEDIAPIPE_LANDMARKS[i].replace("left", "right")) for i in ALL_LEFT]
#: Left/right pairs decided together when a multi-view recording's labels are reconciled
#: (:func:`lfd.human.multiview.reconcile_left_right`): the upper body (shoulders, hips, arms; the
#: anchor that also decides which views show the person) and the legs. The arms are not decided on
#: their own: seen by two views only (the Pose2Sim multi-person demo), an arm group alone swapped
#: an occluded arm wrongly (right elbow 80 px instead of 10 px). The face's pairs are left as
#: given: its points lie too close together (and are guessed in back views) for reprojection to
#: tell them apart.
_PAIR = {n[5:]: (i, MEDIAPIPE_LANDMARKS.index(n.replace("left", "right")))
         for i, n in enumerate(MEDIAPIPE_LANDMARKS) if n.startswith("left_")}  # fmt: skip
LEFT_RIGHT_GROUPS = tuple(
    tuple(_PAIR[n] for n in names)
    for names in (
        ("shoulder", "hip", "elbow", "wrist", "pinky", "index", "thumb"),
        ("knee", "ankle", "heel", "foot_index"),
    )
)
#: Shoulders then hips.
TORSO = [MEDIAPIPE_LANDMARKS.index(n) for n in ("left_shoulder", "right_shoulder", "left_hip", "right_hip")]
#: Landmark pairs drawn on a video frame (arms and torso).
ARM_EDGES = (
    (11, 13),
    (13, 15),
    (12, 14),
    (14, 16),
    (11, 12),
    (11, 23),
    (12, 24),
    (23, 24),
    (15, 19),
    (16, 20),
)


def torso(px: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (2,) px and length (px, at least 1) of the torso of one frame's landmarks ``px`` (33, 2):
    the mean of shoulders and hips, and the distance from the shoulders' to the hips' midpoint."""
    pts = px[TORSO]
    centre = pts.mean(0)
    length = float(np.linalg.norm(pts[:2].mean(0) - pts[2:].mean(0)))
    return centre, max(length, 1.0)
