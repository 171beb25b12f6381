"""The arm-analysis pipeline (docs/human.md); its result type :class:`ArmAnalysis` is in :mod:`lfd.human.result`.

skeleton -> left/right swap repair -> (Hampel) -> bone-length outliers -> short-gap
interpolation -> filter (Butterworth or median) -> trunk frame -> closed-form IK in the ISB
convention (plane of elevation, elevation, axial rotation, elbow flexion; no clamping,
singular poses by continuity) -> smooth fit (spline or CV polynomial) -> velocities,
accelerations -> Newton-Euler torques; the thesis's abduction/flexion/rotation are derived
from the fitted pose (:mod:`lfd.human.thesis_angles`).

Example (runnable)::

    >>> from lfd.human import analyze_arm
    >>> from lfd.human.synthetic import synthetic_recording
    >>> rec = synthetic_recording(duration=4.0, seed=0)
    >>> result = analyze_arm(rec.skeleton, side="right", body_mass=75.0, sex="male")
    >>> result.q.shape, result.tau.shape
    ((120, 4), (120, 4))
"""

from __future__ import annotations

import dataclasses
import logging
import os

import numpy as np

from .arm_ik import arm_fk, arm_ik, canonical_angles, forearm_pronation, mirror
from .cleaning import fill_gaps, repair_swaps
from .dynamics import arm_model, arm_torques
from .filters import FILTERS, auto_cutoff, filter_positions, hampel_filter
from .fit import FITS, MIN_SAMPLES, fit_derivatives
from .plausibility import check_body_mass, check_frames, implausible_frames
from .readers import read_skeleton
from .result import JOINT_NAMES, THESIS_NAMES, ArmAnalysis
from .skeleton import Skeleton
from .thesis_angles import thesis_ik
from .trunk import to_trunk, trunk_frames

__all__ = ["JOINT_NAMES", "MIN_FRAMES", "THESIS_NAMES", "ArmAnalysis", "analyze_arm"]

log = logging.getLogger(__name__)

#: Fewest frames analysed: the smooth fit needs this many samples for velocities and accelerations
#: (fewer would give a result without torques).
MIN_FRAMES = MIN_SAMPLES

_GRAVITY = 9.81
_DEFAULT_HAND_LENGTH = {"male": 0.19, "female": 0.18}


def _bone_outliers(pos: np.ndarray, names: tuple[str, ...], side: str, tolerance: float) -> np.ndarray:
    """(T, J) mask of elbow/wrist samples whose bone length is off the median by > ``tolerance`` (fraction)."""
    bad = np.zeros(pos.shape[:2], bool)
    chain = [f"shoulder_{side}", f"elbow_{side}", f"wrist_{side}"]
    for parent, child in zip(chain[:-1], chain[1:]):
        if parent in names and child in names:
            length = np.linalg.norm(pos[:, names.index(child)] - pos[:, names.index(parent)], axis=1)
            median = np.nanmedian(length) if np.isfinite(length).any() else np.nan
            off = np.abs(length - median) > tolerance * median
            bad[:, names.index(child)] |= off
    return bad


def _check_choice(name: str, value, choices) -> None:
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(str, choices))}, got {value!r}")


def analyze_arm(
    skeleton: Skeleton | str | os.PathLike,
    side: str = "right",
    body_mass: float = 75.0,
    sex: str = "male",
    filter: str = "butterworth",
    *,
    cutoff: float | str = "auto",
    filter_order: int = 2,
    median_kernel: int = 5,
    hampel: bool = False,
    hampel_window: int = 7,
    hampel_sigma: float = 3.0,
    max_gap: float = 0.2,
    use_inferred: bool = False,
    repair_swaps_: bool = True,
    bone_tolerance: float = 0.3,
    fit: str = "polynomial",
    poly_max_order: int = 12,
    poly_window: float = 4.0,
    spline_cutoff: float | None = 2.0,
    hand_load: float = 0.0,
    hand_length: float | None = None,
    singular_deg: float = 10.0,
    gravity: float = _GRAVITY,
    repair_frames: bool = False,
) -> ArmAnalysis:
    """Joint angles, velocities, accelerations and torques of one arm from a skeleton.

    Args:
        skeleton: a :class:`Skeleton` or a path for :func:`read_skeleton` (which refuses a file
            whose upper arm or frame rate is implausible).
        side: ``"right"`` or ``"left"``.
        body_mass: kg, 20-250. sex: ``"male"``/``"female"`` (de Leva segment fractions).
        filter: one of ``butterworth`` (zero-phase, ``cutoff`` Hz, ``filter_order`` per pass; ``cutoff="auto"``:
            chosen from the arm's joints by :func:`lfd.human.filters.auto_cutoff`, reported as
            ``quality["cutoff_hz"]``),
            ``median`` (``median_kernel`` samples) or ``none``.
        hampel: apply a Hampel outlier filter (``hampel_window`` samples, ``hampel_sigma``) first.
        max_gap: s, longest gap of missing/untracked samples that is interpolated.
        use_inferred: keep joints the camera marked as inferred (default: treat as missing).
        repair_swaps_: detect and undo left/right label swaps.
        bone_tolerance: elbow/wrist samples whose bone length differs from the median by more
            than this fraction are treated as missing (outlier bursts).
        fit: ``spline`` (smoothing spline, GCV) or ``polynomial`` (CV-chosen order, windows of
            ``poly_window`` s, orders up to ``poly_max_order``); the spline is -3 dB at
            ``spline_cutoff`` Hz (``None``: generalised cross-validation).
        hand_load: kg held in the hand. hand_length: m (default: median wrist to hand tip
            from the data when that is plausible, 0.12-0.25 m, else 0.19 m male / 0.18 m female).
        singular_deg: threshold of the singular poses (deg): arm hanging or straight up (plane
            of elevation undefined), straight elbow (axial rotation undefined).
        gravity: m/s^2, magnitude along ``-skeleton.up``.
        repair_frames: frames that cannot be a person's motion (rows in another length unit,
            single-frame spikes: :func:`lfd.human.plausibility.implausible_frames`) are dropped
            (treated as missing: short gaps are interpolated, longer ones reported) and logged,
            with their count in ``quality["repaired_frames"]``; ``False``: such a recording is refused.

    Returns:
        :class:`ArmAnalysis`.

    Raises:
        ValueError: bad option (a body mass outside 20-250 kg, with a hint when it reads as grams),
            a skeleton without the needed joints, fewer than :data:`MIN_FRAMES` frames, or
            (without ``repair_frames``) implausible frames
            (:class:`~lfd.human.plausibility.ImplausibleFrames`, naming the file and the frames).
        FileNotFoundError: a missing file.
    """
    if not isinstance(skeleton, Skeleton):
        skeleton = read_skeleton(skeleton)
    _check_choice("side", side, ("left", "right"))
    _check_choice("sex", sex, ("male", "female"))
    _check_choice("filter", filter, FILTERS)
    _check_choice("fit", fit, FITS)
    if cutoff != "auto" and not (
        isinstance(cutoff, (int, float))
        and not isinstance(cutoff, bool)
        and np.isfinite(cutoff)
        and cutoff > 0
    ):
        raise ValueError(f"cutoff must be 'auto' or a positive number of Hz, got {cutoff!r}")
    for key, value in (
        ("body_mass", body_mass),
        ("max_gap", max_gap),
        ("bone_tolerance", bone_tolerance),
        ("gravity", gravity),
    ):
        if not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0) or (
            key == "body_mass" and value <= 0
        ):
            raise ValueError(
                f"{key} must be a {'positive' if key == 'body_mass' else 'non-negative'} number, got {value!r}"
            )
    check_body_mass(body_mass)
    needed = [f"shoulder_{side}", f"elbow_{side}", f"wrist_{side}", "shoulder_left", "shoulder_right"]
    missing = [n for n in dict.fromkeys(needed) if n not in skeleton.names]
    if missing:
        raise ValueError(
            f"{skeleton.source or 'skeleton'}: missing joint(s) {missing} for the {side} arm; has {skeleton.names}"
        )
    where = skeleton.source or "skeleton"
    if skeleton.n_frames < MIN_FRAMES:
        raise ValueError(
            f"{where}: {skeleton.n_frames} frame(s); the analysis needs at least {MIN_FRAMES} "
            "(velocities and accelerations come from a smooth fit over them)"
        )
    names, t = skeleton.names, skeleton.t
    rate = skeleton.rate
    quality: dict = {}

    scale, spike = implausible_frames(skeleton)
    drop = scale | spike
    if drop.any() and not repair_frames:
        check_frames(skeleton, where)  # raises, naming the frames
    quality["repaired_frames"] = int(drop.sum())
    if drop.any():
        log.warning(
            "%s: repair_frames: dropped %d frame(s) (%d in another length unit, %d spikes); "
            "short gaps interpolated (max_gap=%g s)",
            where, int(drop.sum()), int(scale.sum()), int(spike.sum()), max_gap,
        )  # fmt: skip
    valid = np.isfinite(skeleton.positions).all(2) if use_inferred else skeleton.tracked.copy()
    valid[drop] = False
    pos = np.where(valid[..., None], skeleton.positions, np.nan)
    swapped = np.zeros((len(t), 1), bool)
    if repair_swaps_:
        pos, swapped = repair_swaps(pos, names)
        # The raw (inferred) values travel with their labels too.
    quality["swap_frames"] = int(swapped.any(1).sum())
    quality["swap_events"] = int(
        (np.diff(swapped.astype(np.int8), axis=0) != 0).any(1).sum() + swapped[0].any()
    )
    raw = pos.copy()
    outliers = 0
    if hampel:
        pos, mask = hampel_filter(pos, hampel_window, hampel_sigma)
        outliers += int(mask.any(2).sum())
    bone_bad = _bone_outliers(pos, names, side, bone_tolerance)
    outliers += int(bone_bad.sum())
    quality["outliers"] = outliers
    valid = np.isfinite(pos).all(2) & ~bone_bad
    pos, gaps = fill_gaps(t, pos, valid, names, max_gap)
    arm_joints = {f"shoulder_{side}", f"elbow_{side}", f"wrist_{side}", "shoulder_left", "shoulder_right",
                  "spine_shoulder", "spine_base"}  # fmt: skip
    quality["gaps_filled"] = sum(g.filled for g in gaps if g.joint in arm_joints)
    quality["gaps_left"] = [dataclasses.asdict(g) for g in gaps if g.joint in arm_joints and not g.filled]
    if filter == "butterworth":
        if cutoff == "auto":
            arm = [
                names.index(f"{j}_{side}") for j in ("shoulder", "elbow", "wrist") if f"{j}_{side}" in names
            ]
            cutoff = auto_cutoff(pos[:, arm], rate, filter_order)
        quality["cutoff_hz"] = float(cutoff)
    smooth = filter_positions(pos, rate, filter, cutoff=cutoff, order=filter_order, kernel=median_kernel)

    rotation, origin = trunk_frames(skeleton, smooth)
    chain = [names.index(f"{j}_{side}") for j in ("shoulder", "elbow", "wrist")]
    positions = to_trunk(smooth[:, chain], rotation, origin)
    raw_positions = to_trunk(raw[:, chain], rotation, origin)
    upper = np.linalg.norm(positions[:, 1] - positions[:, 0], axis=1)
    fore = np.linalg.norm(positions[:, 2] - positions[:, 1], axis=1)
    if not np.isfinite(upper).any() or not np.isfinite(fore).any():
        raise ValueError(
            f"{skeleton.source or 'skeleton'}: the {side} arm has no frame with shoulder, elbow and wrist"
        )
    lengths = {"upper_arm": float(np.nanmedian(upper)), "forearm": float(np.nanmedian(fore))}
    if hand_length is None and skeleton.has(f"hand_tip_{side}", f"wrist_{side}"):
        hand = np.linalg.norm(smooth[:, names.index(f"hand_tip_{side}")] - smooth[:, chain[2]], axis=1)
        hand_length = float(np.nanmedian(hand)) if np.isfinite(hand).any() else None
        # Kinect's hand tip is often wrong (fingers curled, self-occlusion): keep plausible values only.
        if hand_length is not None and not 0.12 <= hand_length <= 0.25:
            hand_length = None
    lengths["hand"] = float(hand_length) if hand_length is not None else _DEFAULT_HAND_LENGTH[sex]

    model_pos = mirror(positions - positions[:, :1], side)  # right-arm model, shoulder at the origin
    ik = arm_ik(
        model_pos[:, 0], model_pos[:, 1], model_pos[:, 2], "right", singular_deg=singular_deg, canonical=False
    )
    missing_frames = ~np.isfinite(ik.q).all(1)
    options = (
        {"max_order": poly_max_order, "window": poly_window}
        if fit == "polynomial"
        else {"cutoff": spline_cutoff}
    )
    q, qd, qdd = fit_derivatives(t, ik.q, fit, **options)

    g_source = -gravity * skeleton.up
    g_trunk = mirror(np.einsum("tij,i->tj", rotation, g_source), side)
    robot = arm_model(lengths["upper_arm"], lengths["forearm"], lengths["hand"], body_mass, sex, hand_load)
    tau = arm_torques(robot, q, qd, qdd, g_trunk)
    # fitted on the continuous branch (smooth through hanging / straight up), reported in the ISB form
    q, qd, qdd, tau = canonical_angles(q, qd, qdd, tau)

    elbow, wrist = arm_fk(np.nan_to_num(q), lengths["upper_arm"], lengths["forearm"])
    recon = mirror(np.stack([np.zeros_like(elbow), elbow, wrist], 1), side) + positions[:, :1]
    recon[missing_frames | ~np.isfinite(q).all(1)] = np.nan
    fitted_ok = np.isfinite(q).all(1)
    thesis = np.full((len(t), 3), np.nan)
    derived = thesis_ik(
        np.zeros_like(elbow[fitted_ok]), elbow[fitted_ok], wrist[fitted_ok], singular_deg=singular_deg
    )
    thesis[fitted_ok] = derived.q[:, :3]
    flags = {"shoulder_singular": ik.shoulder_singular & ~missing_frames,
             "elbow_singular": ik.elbow_singular & ~missing_frames,
             "thesis_gimbal_lock": np.zeros(len(t), bool), "thesis_outside_range": np.zeros(len(t), bool)}  # fmt: skip
    flags["thesis_gimbal_lock"][fitted_ok] = derived.gimbal_lock
    flags["thesis_outside_range"][fitted_ok] = derived.outside_range
    pronation = None
    if skeleton.has(f"thumb_{side}"):  # Kinect v2's thumb: the radial side of the hand (noisy)
        thumb = to_trunk(smooth[:, names.index(f"thumb_{side}")], rotation, origin)
        pronation, flags["pronation_interpolated"] = forearm_pronation(
            *positions.transpose(1, 0, 2), thumb, side
        )

    quality.update(
        elbow_singular_frames=int(flags["elbow_singular"].sum()),
        shoulder_singular_frames=int(flags["shoulder_singular"].sum()),
        thesis_gimbal_lock_frames=int(flags["thesis_gimbal_lock"].sum()),
        missing_frames=int(missing_frames.sum()),
    )
    settings = dict(
        filter=filter,
        cutoff=cutoff,
        filter_order=filter_order,
        median_kernel=median_kernel,
        hampel=hampel,
        max_gap=max_gap,
        use_inferred=use_inferred,
        repair_swaps=repair_swaps_,
        bone_tolerance=bone_tolerance,
        fit=fit,
        poly_max_order=poly_max_order,
        poly_window=poly_window,
        spline_cutoff=spline_cutoff,
        singular_deg=singular_deg,
        rate_hz=rate,
        repair_frames=repair_frames,
    )
    return ArmAnalysis(
        t=t, q=q, qd=qd, qdd=qdd, tau=tau, q_ik=canonical_angles(ik.q)[0], positions=positions,
        raw_positions=raw_positions,
        reconstructed=recon, gravity=mirror(g_trunk, side), segment_lengths=lengths, quality=quality, side=side,
        subject={"body_mass": body_mass, "sex": sex, "hand_load": hand_load}, settings=settings, source=skeleton.source,
        thesis=thesis, flags=flags, pronation=pronation,
    )  # fmt: skip
