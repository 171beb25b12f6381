"""Synthetic depth-camera recordings with known ground truth, for validation and benchmarks.

Known joint trajectories of the human-arm model (ISB angles, sums of sines around a
``motion`` preset: ``"default"`` (arm in front and to the side, 25-115 deg elevation),
``"overhead"`` (raised above the head, up to ~165 deg), ``"behind_back"`` (plane of
elevation behind the frontal plane, internally rotated, hand behind the back) or
``"through_singular"`` (swinging through hanging and straight up, where the plane of
elevation is undefined); exact derivatives) -> forward kinematics on both arms of a swaying trunk -> a Kinect-like
camera frame (person about 2.5 m in front of the sensor, y up, z away), then optional
corruption: white noise (``noise`` m per coordinate), short dropouts (untracked), one long
dropout, an outlier burst on the wrist and one left/right label swap.

Example::

    >>> from lfd.human.synthetic import synthetic_recording
    >>> rec = synthetic_recording(duration=2.0, seed=1)
    >>> rec.skeleton.positions.shape, rec.q["right"].shape
    ((60, 9, 3), (60, 4))
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .arm_ik import arm_fk, canonical_angles, mirror
from .dynamics import arm_model, arm_torques
from .skeleton import Skeleton

__all__ = ["MOTIONS", "SyntheticRecording", "camera_pose", "synthetic_recording"]

JOINTS = (
    "spine_base", "spine_shoulder", "shoulder_left", "elbow_left", "wrist_left",
    "shoulder_right", "elbow_right", "wrist_right", "neck",
)  # fmt: skip
_ARM_JOINTS = ("shoulder", "elbow", "wrist")
# (centre, amplitude) in deg of plane of elevation, elevation, axial rotation, elbow flexion.
MOTIONS = {
    "default": ([45.0, 70.0, 10.0, 70.0], [40.0, 45.0, 28.0, 40.0]),
    "overhead": ([60.0, 135.0, 0.0, 60.0], [40.0, 30.0, 30.0, 40.0]),
    "behind_back": ([-55.0, 45.0, 60.0, 90.0], [25.0, 20.0, 20.0, 30.0]),
    "through_singular": ([60.0, 90.0, 10.0, 70.0], [30.0, 110.0, 28.0, 40.0]),
}


@dataclasses.dataclass
class SyntheticRecording:
    """A synthetic skeleton and its ground truth.

    Attributes:
        skeleton: the (corrupted) recording in the camera frame.
        q, qd, qdd: per side (``"left"``, ``"right"``) (T, 4) rad, rad/s, rad/s^2, ISB angles
            (:mod:`lfd.human.arm_ik`, ISB form: elevation in [0, pi]; with ``through_singular`` the plane
            of elevation jumps by pi where the arm passes through hanging or straight up).
        tau: per side (T, 4) N m for ``body_mass``/``sex`` and gravity in the trunk frame.
        gravity: (T, 3) m/s^2 in the trunk frame. lengths: upper_arm, forearm, hand (m).
        corrupted: description of the corruptions (frame ranges).
    """

    skeleton: Skeleton
    q: dict
    qd: dict
    qdd: dict
    tau: dict
    gravity: np.ndarray
    lengths: dict
    corrupted: dict


def camera_pose(
    yaw_deg: float = 0.0, distance: float = 2.5, height: float = 0.0, pitch_deg: float = 0.0
) -> np.ndarray:
    """(4, 4) pose mapping world points (x forward of the person, y left, z up) into a Kinect-like
    camera frame (x, y up, z away from the sensor) facing the person; ``yaw_deg`` turns the camera
    about the vertical, ``pitch_deg`` tilts it."""
    base = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])  # world -> camera axes
    a, p = np.deg2rad(yaw_deg), np.deg2rad(pitch_deg)
    yaw = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    tilt = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(p), -np.sin(p)], [0.0, np.sin(p), np.cos(p)]])
    pose = np.eye(4)
    pose[:3, :3] = tilt @ base @ yaw.T
    pose[:3, 3] = [0.0, -height, distance]
    return pose


def _sines(t: np.ndarray, centre, amplitude, freq, phase):
    """Sum-of-sines trajectories (T, 4) with exact first and second derivatives."""
    centre, amplitude, freq, phase = (np.asarray(x, float) for x in (centre, amplitude, freq, phase))
    w = 2 * np.pi * freq  # (4, K)
    arg = w[None] * t[:, None, None] + phase[None]
    q = centre + (amplitude[None] * np.sin(arg)).sum(-1)
    qd = (amplitude[None] * w[None] * np.cos(arg)).sum(-1)
    qdd = -(amplitude[None] * w[None] ** 2 * np.sin(arg)).sum(-1)
    return q, qd, qdd


def synthetic_recording(
    duration: float = 20.0,
    rate: float = 30.0,
    seed: int = 0,
    *,
    noise: float = 0.0,
    dropouts: int = 0,
    long_gap: float = 0.0,
    outlier_burst: bool = False,
    swap: bool = False,
    camera: np.ndarray | None = None,
    upper_arm_length: float = 0.30,
    forearm_length: float = 0.26,
    body_mass: float = 75.0,
    sex: str = "male",
    hand_load: float = 0.0,
    motion: str = "default",
) -> SyntheticRecording:
    """Make a synthetic recording (see module docstring); every corruption is reproducible from ``seed``.

    Args:
        duration: s. rate: Hz. noise: m, standard deviation per coordinate.
        dropouts: number of short dropouts (1-5 frames, random arm joints, marked untracked).
        long_gap: s, one dropout of this length on the right wrist (0 = none).
        outlier_burst: 5 frames of the right wrist displaced by 0.25 m.
        swap: one second of left/right arm labels exchanged.
        camera: (4, 4) world -> camera pose (default :func:`camera_pose`).
        motion: one of ``MOTIONS`` (see module docstring).

    Raises:
        ValueError: unknown ``motion``.
    """
    if motion not in MOTIONS:
        raise ValueError(f"motion must be one of {', '.join(MOTIONS)}, got {motion!r}")
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration * rate))) / rate
    q, qd, qdd, tau = {}, {}, {}, {}
    lengths = {
        "upper_arm": upper_arm_length,
        "forearm": forearm_length,
        "hand": 0.19 if sex == "male" else 0.18,
    }
    # Trunk sway (world frame): a slow lean forward/sideways, so gravity moves in the trunk frame.
    lean_f = np.deg2rad(6.0) * np.sin(2 * np.pi * 0.11 * t + rng.uniform(0, 6.3))
    lean_s = np.deg2rad(4.0) * np.sin(2 * np.pi * 0.07 * t + rng.uniform(0, 6.3))
    cf, sf, cs, ss = np.cos(lean_f), np.sin(lean_f), np.cos(lean_s), np.sin(lean_s)
    zero, one = np.zeros_like(t), np.ones_like(t)
    ry = np.stack([cf, zero, sf, zero, one, zero, -sf, zero, cf], -1).reshape(-1, 3, 3)
    rx = np.stack([one, zero, zero, zero, cs, -ss, zero, ss, cs], -1).reshape(-1, 3, 3)
    trunk = rx @ ry  # (T, 3, 3): trunk axes in the world
    base = np.array([0.0, 0.0, 1.0])  # spine_base, world
    spine = 0.5
    gravity = np.einsum("tij,i->tj", trunk, np.array([0.0, 0.0, -9.81]))
    points = {"spine_base": np.zeros((len(t), 3)), "spine_shoulder": np.tile([0.0, 0.0, spine], (len(t), 1)),
              "neck": np.tile([0.0, 0.0, spine + 0.08], (len(t), 1))}  # fmt: skip
    for side, sign in (("right", -1.0), ("left", 1.0)):
        n_freq = 3
        freq = rng.uniform(0.15, 0.6, (4, n_freq))
        phase = rng.uniform(0, 2 * np.pi, (4, n_freq))
        centre = np.deg2rad(MOTIONS[motion][0])
        amplitude = np.deg2rad(np.array(MOTIONS[motion][1]))[:, None] * rng.dirichlet(np.ones(n_freq), 4)
        if motion == "through_singular":  # one slow swing of the elevation from below 0 to beyond 180 deg
            amplitude[1] = np.deg2rad([MOTIONS[motion][1][1], 0.0, 0.0])
            freq[1, 0] = 0.15
        q[side], qd[side], qdd[side] = _sines(t, centre, amplitude, freq, phase)
        shoulder = np.array([0.0, sign * 0.18, spine - 0.03])
        elbow, wrist = arm_fk(q[side], upper_arm_length, forearm_length)
        for name, p in zip(_ARM_JOINTS, (np.zeros_like(elbow), elbow, wrist)):
            points[f"{name}_{side}"] = shoulder + mirror(p, side)
        robot = arm_model(upper_arm_length, forearm_length, lengths["hand"], body_mass, sex, hand_load)
        tau[side] = arm_torques(robot, q[side], qd[side], qdd[side], mirror(gravity, side))
        # the truth in the ISB form (elevation in [0, pi]; changes only "through_singular")
        q[side], qd[side], qdd[side], tau[side] = canonical_angles(q[side], qd[side], qdd[side], tau[side])
    names = JOINTS
    world = np.stack([base + np.einsum("tij,tj->ti", trunk, points[n]) for n in names], 1)  # (T, J, 3)
    pose = camera_pose() if camera is None else np.asarray(camera, float)
    positions = world @ pose[:3, :3].T + pose[:3, 3]
    positions = positions + rng.normal(0.0, noise, positions.shape) if noise > 0 else positions
    tracked = np.ones(positions.shape[:2], bool)
    corrupted: dict = {"dropouts": [], "long_gap": None, "outlier_burst": None, "swap": None}
    arm = [i for i, n in enumerate(names) if n.split("_")[0] in _ARM_JOINTS]
    T = len(t)
    for _ in range(dropouts):
        j = int(rng.choice(arm))
        start, length = int(rng.integers(5, T - 10)), int(rng.integers(1, 6))
        tracked[start : start + length, j] = False
        positions[start : start + length, j] += rng.normal(
            0.0, 0.05, (len(range(start, min(start + length, T))), 3)
        )
        corrupted["dropouts"].append((names[j], start, start + length))
    wrist = names.index("wrist_right")
    if long_gap > 0:
        n = int(round(long_gap * rate))
        start = int(T * 0.6)
        positions[start : start + n, wrist] = np.nan
        corrupted["long_gap"] = (start, start + n)
    if outlier_burst:
        start = int(T * 0.3)
        positions[start : start + 5, wrist] += [0.25, 0.1, -0.1]
        corrupted["outlier_burst"] = (start, start + 5)
    if swap:
        start, stop = int(T * 0.45), int(T * 0.45) + int(rate)
        for part in _ARM_JOINTS:
            li, ri = names.index(f"{part}_left"), names.index(f"{part}_right")
            positions[start:stop, [li, ri]] = positions[start:stop, [ri, li]]
            tracked[start:stop, [li, ri]] = tracked[start:stop, [ri, li]]
        corrupted["swap"] = (start, stop)
    skeleton = Skeleton(
        t, names, positions, tracked, source=f"synthetic(seed={seed})", up=pose[:3, :3] @ [0.0, 0.0, 1.0]
    )
    return SyntheticRecording(skeleton, q, qd, qdd, tau, gravity, lengths, corrupted)
