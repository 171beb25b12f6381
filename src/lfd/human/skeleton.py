"""The :class:`Skeleton` type: 3-D joint positions over time, with canonical joint names.

Any source (a depth camera's joint file, a marker file, a video pose estimator) produces a
``Skeleton``; everything downstream (gap handling, filters, arm IK) only sees this type.

Canonical joint names are ``<part>_<side>`` for paired joints (``shoulder_right``,
``elbow_left``, ``wrist_right``, ``hand_tip_left``, ``hip_right``, ...) and plain names for
midline joints (``spine_base``, ``spine_mid``, ``spine_shoulder``, ``neck``, ``head``).
:func:`canonical_joint_name` maps common spellings (Kinect ``ShoulderRight``, COCO
``right_shoulder``, ``RShoulder``, ``R.Shoulder``) onto them.

Example::

    >>> import numpy as np
    >>> from lfd.human import Skeleton
    >>> sk = Skeleton(t=np.arange(3) / 30.0, names=("shoulder_right", "elbow_right"),
    ...               positions=np.zeros((3, 2, 3)))
    >>> sk.joint("elbow_right").shape
    (3, 3)
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

__all__ = ["KINECT_V2_JOINTS", "Skeleton", "canonical_joint_name"]

# Kinect v2 SDK JointType order (KIMORE CSV, NTU RGB+D .skeleton), canonical names.
KINECT_V2_JOINTS = (
    "spine_base", "spine_mid", "neck", "head",
    "shoulder_left", "elbow_left", "wrist_left", "hand_left",
    "shoulder_right", "elbow_right", "wrist_right", "hand_right",
    "hip_left", "knee_left", "ankle_left", "foot_left",
    "hip_right", "knee_right", "ankle_right", "foot_right",
    "spine_shoulder", "hand_tip_left", "thumb_left", "hand_tip_right", "thumb_right",
)  # fmt: skip

_SIDES = {"left": "left", "l": "left", "right": "right", "r": "right"}
_PART_ALIASES = {
    "handtip": "hand_tip",
    "hand_tip": "hand_tip",
    "upperarm": "shoulder",
    "forearm": "elbow",
    "spinebase": "spine_base",
    "spinemid": "spine_mid",
    "spineshoulder": "spine_shoulder",
    "spine_shoulder": "spine_shoulder",
    "spine_base": "spine_base",
    "spine_mid": "spine_mid",
}


def canonical_joint_name(name: str) -> str:
    """Map a joint name from a file onto the canonical ``<part>_<side>`` spelling.

    Splits camelCase and separators, recognises a side token (``left``/``right``/``l``/``r``)
    at either end and joins the rest with underscores, lower case. Unknown names stay in this
    normalised form, so they are still addressable.

    >>> canonical_joint_name("ShoulderRight"), canonical_joint_name("left_wrist"), canonical_joint_name("RElbow")
    ('shoulder_right', 'wrist_left', 'elbow_right')
    >>> canonical_joint_name("HandTipLeft"), canonical_joint_name("SpineShoulder")
    ('hand_tip_left', 'spine_shoulder')
    """
    text = str(name).strip()
    # "RShoulder"/"LElbow" (OpenPose) -> "R Shoulder"; camelCase -> words.
    text = re.sub(r"^([LR])(?=[A-Z][a-z])", r"\1 ", text)
    text = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", " ", text)
    tokens = [tok for tok in re.split(r"[^A-Za-z0-9]+", text.lower()) if tok]
    if not tokens:
        return text.lower()
    side = None
    if len(tokens) > 1 and tokens[0] in _SIDES:
        side, tokens = _SIDES[tokens[0]], tokens[1:]
    elif len(tokens) > 1 and tokens[-1] in _SIDES:
        side, tokens = _SIDES[tokens[-1]], tokens[:-1]
    part = "_".join(tokens)
    part = _PART_ALIASES.get(part, _PART_ALIASES.get(part.replace("_", ""), part))
    return f"{part}_{side}" if side else part


@dataclasses.dataclass(eq=False)
class Skeleton:
    """Joint positions of one person over time.

    Attributes:
        t: (T,) seconds, strictly increasing.
        names: J canonical joint names (unique).
        positions: (T, J, 3) metres in the source's frame (camera or lab); NaN = missing.
        tracked: (T, J) bool, False where the source marked the joint as not tracked or
            only inferred (and wherever the position is NaN). Defaults to "finite".
        source: where the data came from, e.g. ``"recording.csv (kinect_csv)"``.
        up: (3,) unit vector of "up" (against gravity) in the source frame, e.g. ``(0, 1, 0)``
            for a Kinect camera; used to express gravity in the trunk frame.
    """

    t: np.ndarray
    names: tuple[str, ...]
    positions: np.ndarray
    tracked: np.ndarray | None = None
    source: str = ""
    up: np.ndarray = dataclasses.field(default_factory=lambda: np.array([0.0, 1.0, 0.0]))

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=float)
        self.names = tuple(str(n) for n in self.names)
        self.positions = np.asarray(self.positions, dtype=float)
        where = f" ({self.source})" if self.source else ""
        if self.t.ndim != 1 or len(self.t) < 1:
            raise ValueError(f"Skeleton.t must have shape (T,) with T >= 1, got {self.t.shape}{where}")
        if not np.all(np.isfinite(self.t)):
            raise ValueError(f"Skeleton.t contains NaN or inf{where}")
        if np.any(np.diff(self.t) <= 0):
            bad = int(np.argmax(np.diff(self.t) <= 0)) + 1
            raise ValueError(
                f"Skeleton.t must be strictly increasing; frame {bad} has t={self.t[bad]}{where}"
            )
        if len(set(self.names)) != len(self.names):
            raise ValueError(f"Skeleton.names must be unique, got {self.names}{where}")
        shape = (len(self.t), len(self.names), 3)
        if self.positions.shape != shape:
            raise ValueError(
                f"Skeleton.positions must have shape (T, J, 3) = {shape}, got {self.positions.shape}{where}"
            )
        finite = np.isfinite(self.positions).all(axis=2)
        if self.tracked is None:
            self.tracked = finite
        else:
            self.tracked = np.asarray(self.tracked, dtype=bool)
            if self.tracked.shape != shape[:2]:
                raise ValueError(
                    f"Skeleton.tracked must have shape (T, J) = {shape[:2]}, got {self.tracked.shape}{where}"
                )
            self.tracked = self.tracked & finite
        up = np.asarray(self.up, dtype=float)
        if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-9:
            raise ValueError(f"Skeleton.up must be a non-zero 3-vector, got {self.up!r}{where}")
        self.up = up / np.linalg.norm(up)

    @property
    def n_frames(self) -> int:
        return len(self.t)

    @property
    def rate(self) -> float:
        """Median frame rate, Hz (0 for a single frame)."""
        return float(1.0 / np.median(np.diff(self.t))) if len(self.t) > 1 else 0.0

    def index(self, name: str) -> int:
        """Column of joint ``name`` (canonical spelling accepted too)."""
        for candidate in (name, canonical_joint_name(name)):
            if candidate in self.names:
                return self.names.index(candidate)
        raise KeyError(f"joint {name!r} not in skeleton {self.source or ''}; joints: {', '.join(self.names)}")

    def has(self, *names: str) -> bool:
        """True when every joint in ``names`` is present."""
        return all(n in self.names for n in names)

    def joint(self, name: str) -> np.ndarray:
        """(T, 3) positions of one joint, metres."""
        return self.positions[:, self.index(name)]

    def replace(self, **changes) -> Skeleton:
        """A copy with some fields replaced (validated again)."""
        return dataclasses.replace(self, **changes)

    def __repr__(self) -> str:
        return f"Skeleton(T={self.n_frames}, J={len(self.names)}, rate={self.rate:.1f} Hz, source={self.source!r})"
