"""The result type of :func:`lfd.human.analyze_arm`: :class:`ArmAnalysis` (angles, derivatives, torques,
derived angles, flags) and its files (CSV, OpenSim .mot, JSON, figures); docs/human.md."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import numpy as np

from lfd.io.files import write_text_atomic

__all__ = ["JOINT_NAMES", "THESIS_NAMES", "ArmAnalysis"]

JOINT_NAMES = ("plane_of_elevation", "elevation", "axial_rotation", "elbow_flexion")
THESIS_NAMES = ("abduction", "flexion", "rotation")
_FLAGS = (
    "shoulder_singular",
    "elbow_singular",
    "thesis_gimbal_lock",
    "thesis_outside_range",
    "pronation_interpolated",
)


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
        side: the arm analysed. subject: body_mass, sex, hand_load. settings, source: as given.
        thesis: (T, 3) rad, the thesis's abduction, flexion, rotation of the fitted pose
            (derived; gimbal lock with the upper arm along x, see :mod:`lfd.human.thesis_angles`).
        pronation: (T,) rad forearm pronation (:func:`lfd.human.arm_ik.forearm_pronation`, filtered
            per-frame) when the skeleton has the side's thumb joint, else None.
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
    pronation: np.ndarray | None = None
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
        for name, values in self._derived().items():  # thesis angles (keys without "thesis_"), pronation
            col, key = values[np.isfinite(values)], name.removeprefix("thesis_")
            out[f"{key}_min_deg"] = float(col.min()) if col.size else float("nan")
            out[f"{key}_max_deg"] = float(col.max()) if col.size else float("nan")
            out[f"{key}_rom_deg"] = float(col.max() - col.min()) if col.size else float("nan")
        for key in ("gaps_filled", "gaps_left", "swap_frames", "elbow_singular_frames", "shoulder_singular_frames",
                    "thesis_gimbal_lock_frames", "outliers", "missing_frames"):  # fmt: skip
            out[key] = self.quality.get(key)
        return out

    def _derived(self) -> dict[str, np.ndarray]:
        """Degrees per frame of the thesis's angles (``thesis_<name>``) and the forearm pronation (NaN if none)."""
        nan = np.full(len(self.t), np.nan)
        out = {
            f"thesis_{n}": nan if self.thesis is None else self.thesis[:, j]
            for j, n in enumerate(THESIS_NAMES)
        }
        out["forearm_pronation"] = nan if self.pronation is None else self.pronation
        return {k: np.rad2deg(v) for k, v in out.items()}

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
        for name, values in self._derived().items():
            cols[f"{name}_deg"] = values
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
