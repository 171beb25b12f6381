"""The arm-analysis pipeline (docs/human.md) and its result type :class:`ArmAnalysis`.

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
import json
import os
from pathlib import Path

import numpy as np

from lfd.io.files import write_text_atomic

from .arm_ik import arm_fk, arm_ik, canonical_angles, mirror
from .cleaning import fill_gaps, repair_swaps
from .dynamics import arm_model, arm_torques
from .filters import FILTERS, filter_positions, hampel_filter
from .fit import FITS, fit_derivatives
from .plausibility import check_body_mass
from .readers import read_skeleton
from .skeleton import Skeleton
from .thesis_angles import thesis_ik
from .trunk import to_trunk, trunk_frames

__all__ = ["JOINT_NAMES", "THESIS_NAMES", "ArmAnalysis", "analyze_arm"]

JOINT_NAMES = ("plane_of_elevation", "elevation", "axial_rotation", "elbow_flexion")
THESIS_NAMES = ("abduction", "flexion", "rotation")
_FLAGS = ("shoulder_singular", "elbow_singular", "thesis_gimbal_lock", "thesis_outside_range")
_GRAVITY = 9.81
_DEFAULT_HAND_LENGTH = {"male": 0.19, "female": 0.18}


@dataclasses.dataclass(eq=False)
class ArmAnalysis:
    """Result of :func:`analyze_arm` for one arm.

    Attributes:
        t: (T,) s.
        q: (T, 4) rad, fitted joint angles (``JOINT_NAMES``: ISB plane of elevation, elevation,
            axial rotation, then elbow flexion; plane and rotation unwrapped, see :mod:`lfd.human.arm_ik`).
        qd: (T, 4) rad/s. qdd: (T, 4) rad/s^2 (derivatives of the fit).
        tau: (T, 4) N m, joint torques (Newton-Euler, gravity in the trunk frame).
        q_ik: (T, 4) rad, the per-frame IK solution before the fit.
        positions: (T, 3, 3) m, filtered shoulder, elbow, wrist in the trunk frame.
        raw_positions: (T, 3, 3) m, the same joints as read (after swap repair), trunk frame.
        reconstructed: (T, 3, 3) m, shoulder, elbow, wrist of the model at ``q`` (FK).
        gravity: (T, 3) m/s^2, gravity in the trunk frame.
        segment_lengths: upper_arm, forearm, hand (m; median bone lengths of the data).
        quality: counts and frame lists: gaps filled / left, swaps repaired, singular frames,
            outliers.
        side, subject (body_mass, sex, hand_load), settings, source.
        thesis: (T, 3) rad, the thesis's abduction, flexion, rotation of the fitted pose
            (derived; gimbal lock with the upper arm along x, see :mod:`lfd.human.thesis_angles`).
        flags: per-frame (T,) bool arrays: ``shoulder_singular`` (arm hanging or straight up,
            plane interpolated), ``elbow_singular`` (straight elbow, rotation interpolated),
            ``thesis_gimbal_lock``, ``thesis_outside_range`` (thesis angles beyond the thesis's range).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    q_ik: np.ndarray
    positions: np.ndarray
    raw_positions: np.ndarray
    reconstructed: np.ndarray
    gravity: np.ndarray
    segment_lengths: dict
    quality: dict
    side: str
    subject: dict
    settings: dict
    source: str = ""
    thesis: np.ndarray | None = None
    flags: dict = dataclasses.field(default_factory=dict)

    # ------------------------------------------------------------------ summaries
    def summary(self) -> dict:
        """Per ISB joint min, max, range of motion and mean (deg) of the filtered per-frame angles ``q_ik``
        and peak absolute torque (N m); min, max, range of the derived thesis angles (deg); quality counts.

        The angle statistics are those of ``q_ik``, not of the fit ``q``: the fit exists for the
        derivatives, and on short repetitions that hold the arm up a CV polynomial overshoots the
        plateau (docs/human.md, validation against Vicon markers).
        """
        out: dict = {"source": self.source, "side": self.side, "frames": int(len(self.t)),
                     "duration_s": float(self.t[-1] - self.t[0]) if len(self.t) else 0.0}  # fmt: skip
        deg = np.rad2deg(self.q_ik)
        for j, name in enumerate(JOINT_NAMES):
            col = deg[:, j][np.isfinite(deg[:, j])]
            tau = np.abs(self.tau[:, j])[np.isfinite(self.tau[:, j])]
            out[f"{name}_min_deg"] = float(col.min()) if col.size else float("nan")
            out[f"{name}_max_deg"] = float(col.max()) if col.size else float("nan")
            out[f"{name}_rom_deg"] = float(col.max() - col.min()) if col.size else float("nan")
            out[f"{name}_mean_deg"] = float(col.mean()) if col.size else float("nan")
            out[f"{name}_peak_torque_Nm"] = float(tau.max()) if tau.size else float("nan")
        thesis = np.rad2deg(self._thesis())
        for j, name in enumerate(THESIS_NAMES):
            col = thesis[:, j][np.isfinite(thesis[:, j])]
            out[f"{name}_min_deg"] = float(col.min()) if col.size else float("nan")
            out[f"{name}_max_deg"] = float(col.max()) if col.size else float("nan")
            out[f"{name}_rom_deg"] = float(col.max() - col.min()) if col.size else float("nan")
        for key in ("gaps_filled", "gaps_left", "swap_frames", "elbow_singular_frames", "shoulder_singular_frames",
                    "thesis_gimbal_lock_frames", "outliers", "missing_frames"):  # fmt: skip
            out[key] = self.quality.get(key)
        return out

    def _thesis(self) -> np.ndarray:
        return np.full((len(self.t), 3), np.nan) if self.thesis is None else self.thesis

    def table(self) -> dict[str, np.ndarray]:
        """Per-frame columns (degrees at this edge): ISB angles, velocities, accelerations, torques, the
        derived thesis angles, the singular-pose flags (0/1) and positions."""
        cols: dict[str, np.ndarray] = {"time_s": self.t}
        for j, name in enumerate(JOINT_NAMES):
            cols[f"{name}_deg"] = np.rad2deg(self.q[:, j])
        for j, name in enumerate(JOINT_NAMES):
            cols[f"{name}_vel_deg_s"] = np.rad2deg(self.qd[:, j])
        for j, name in enumerate(JOINT_NAMES):
            cols[f"{name}_acc_deg_s2"] = np.rad2deg(self.qdd[:, j])
        for j, name in enumerate(JOINT_NAMES):
            cols[f"{name}_torque_Nm"] = self.tau[:, j]
        for j, name in enumerate(THESIS_NAMES):
            cols[f"thesis_{name}_deg"] = np.rad2deg(self._thesis()[:, j])
        for name in _FLAGS:
            cols[name] = np.asarray(self.flags.get(name, np.zeros(len(self.t), bool)), float)
        for i, joint in enumerate(("shoulder", "elbow", "wrist")):
            for k, axis in enumerate("xyz"):
                cols[f"{joint}_{axis}_m"] = self.positions[:, i, k]
        return cols

    # ------------------------------------------------------------------ files
    def to_csv(self, path: str | os.PathLike) -> Path:
        """Write :meth:`table` as CSV (header line, one row per frame, NaN as empty). Returns the path."""
        cols = self.table()
        lines = [",".join(cols)]
        data = np.column_stack(list(cols.values()))
        for row in data:
            lines.append(",".join("" if not np.isfinite(v) else f"{v:.6g}" for v in row))
        return write_text_atomic(path, "\n".join(lines) + "\n")

    def to_mot(self, path: str | os.PathLike) -> Path:
        """Write an OpenSim motion file: time, the four ISB angles (deg) and the joint moments (N m)."""
        names = [f"{self.side}_{n}" for n in JOINT_NAMES] + [f"{self.side}_{n}_moment" for n in JOINT_NAMES]
        data = np.column_stack([self.t, np.rad2deg(self.q), self.tau])
        header = [Path(path).stem, "version=1", f"nRows={len(data)}", f"nColumns={data.shape[1]}",
                  "inDegrees=yes", "endheader", "\t".join(["time", *names])]  # fmt: skip
        rows = ["\t".join("nan" if not np.isfinite(v) else f"{v:.8g}" for v in row) for row in data]
        return write_text_atomic(path, "\n".join(header + rows) + "\n")

    def to_json(self, path: str | os.PathLike) -> Path:
        """Write summary, segment lengths, quality, settings and the per-frame table as JSON."""

        def clean(x):
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items()}
            if isinstance(x, (list, tuple)):
                return [clean(v) for v in x]
            if isinstance(x, np.ndarray):
                return clean(x.tolist())
            if isinstance(x, (float, np.floating)):
                return float(x) if np.isfinite(x) else None
            if isinstance(x, (np.integer, np.bool_)):
                return x.item()
            return x

        doc = {
            "summary": self.summary(),
            "segment_lengths_m": self.segment_lengths,
            "subject": self.subject,
            "settings": self.settings,
            "quality": self.quality,
            "units": {
                "angles": "deg",
                "velocities": "deg/s",
                "accelerations": "deg/s^2",
                "torques": "N m",
                "positions": "m, trunk frame (x forward, y left, z up, origin spine_shoulder)",
            },
            "frames": self.table(),
        }
        return write_text_atomic(path, json.dumps(clean(doc), indent=1) + "\n")

    def plot(self, out_dir: str | os.PathLike, gif: bool = True, gif_frames: int = 150) -> list[Path]:
        """Figures like the thesis' 3.6-3.9 (positions, angles, velocities, accelerations, torques) and a
        stick-figure GIF of at most ``gif_frames`` frames (see :mod:`lfd.human.plots`)."""
        from .plots import plot_analysis

        return plot_analysis(self, out_dir, gif=gif, max_gif_frames=gif_frames)

    def save(self, out_dir: str | os.PathLike, stem: str = "arm", plots: bool = True, gif: bool = True,
             gif_frames: int = 150) -> list[Path]:  # fmt: skip
        """All outputs (CSV, MOT, JSON, and figures) into ``out_dir``; returns the paths."""
        out = Path(out_dir)
        paths = [
            self.to_csv(out / f"{stem}.csv"),
            self.to_mot(out / f"{stem}.mot"),
            self.to_json(out / f"{stem}.json"),
        ]
        if plots:
            paths += self.plot(out, gif=gif, gif_frames=gif_frames)
        return paths


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
    cutoff: float = 6.0,
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
) -> ArmAnalysis:
    """Joint angles, velocities, accelerations and torques of one arm from a skeleton.

    Args:
        skeleton: a :class:`Skeleton` or a path for :func:`read_skeleton` (which refuses a file
            whose upper arm or frame rate is implausible).
        side: ``"right"`` or ``"left"``.
        body_mass: kg, 20-250. sex: ``"male"``/``"female"`` (de Leva segment fractions).
        filter: one of ``butterworth`` (zero-phase, ``cutoff`` Hz, ``filter_order`` per pass),
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

    Returns:
        :class:`ArmAnalysis`.

    Raises:
        ValueError: bad option (a body mass outside 20-250 kg, with a hint when it reads as grams)
        or a skeleton without the needed joints; FileNotFoundError.
    """
    if not isinstance(skeleton, Skeleton):
        skeleton = read_skeleton(skeleton)
    _check_choice("side", side, ("left", "right"))
    _check_choice("sex", sex, ("male", "female"))
    _check_choice("filter", filter, FILTERS)
    _check_choice("fit", fit, FITS)
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
    if skeleton.n_frames < 2:
        raise ValueError(f"{skeleton.source or 'skeleton'}: need at least 2 frames, got {skeleton.n_frames}")
    names, t = skeleton.names, skeleton.t
    rate = skeleton.rate
    quality: dict = {}

    valid = np.isfinite(skeleton.positions).all(2) if use_inferred else skeleton.tracked.copy()
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
    )
    return ArmAnalysis(
        t=t, q=q, qd=qd, qdd=qdd, tau=tau, q_ik=canonical_angles(ik.q)[0], positions=positions,
        raw_positions=raw_positions,
        reconstructed=recon, gravity=mirror(g_trunk, side), segment_lengths=lengths, quality=quality, side=side,
        subject={"body_mass": body_mass, "sex": sex, "hand_load": hand_load}, settings=settings, source=skeleton.source,
        thesis=thesis, flags=flags,
    )  # fmt: skip
