"""Figures of an :class:`~lfd.human.analysis.ArmAnalysis` (like the thesis' figures 3.6-3.9) and a stick-figure GIF.

* ``positions.png``: raw vs filtered shoulder, elbow and wrist coordinates in the trunk frame;
* ``angles.png``, ``velocities.png``, ``accelerations.png``: the four ISB joint angles (plane of
  elevation, elevation, axial rotation, elbow flexion; per-frame IK vs fit, frames with the arm
  hanging or straight up shaded), their velocities and accelerations;
* ``thesis_angles.png``: the thesis's abduction, flexion and rotation derived from the fit (gimbal-lock
  frames shaded);
* ``torques.png``: the four joint torques;
* ``stick_figure.gif``: 3-D animation of the raw (grey) and the reconstructed (model FK, blue)
  arm in the trunk frame.

matplotlib runs with the Agg backend (no display needed); GIFs are written with Pillow.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["plot_analysis", "stick_figure_gif"]

_LABELS = ("plane of elevation", "elevation", "axial rotation", "elbow flexion")
_THESIS_LABELS = ("abduction (thesis)", "flexion (thesis)", "rotation (thesis)")


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _four_panels(plt, t, series, ylabel: str, title: str, path: Path, labels=("fit",), names=_LABELS,
                 shade=None) -> Path:  # fmt: skip
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 2 * len(names)), sharex=True)
    for j, ax in enumerate(axes):
        for values, label, style in zip(series, labels, ("-", ":")):
            ax.plot(t, values[:, j], style, label=label, lw=1.2)
        if shade is not None and shade.any():
            ax.fill_between(t, 0, 1, where=shade, color="0.85", transform=ax.get_xaxis_transform(), lw=0)
        ax.set_ylabel(f"{names[j]}\n{ylabel}")
        ax.grid(alpha=0.3)
    if len(series) > 1:
        axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_analysis(
    result, out_dir: str | os.PathLike, gif: bool = True, max_gif_frames: int = 150
) -> list[Path]:
    """Write the figures (and the GIF) of ``result`` into ``out_dir``; returns their paths."""
    plt = _plt()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t = result.t
    paths = []
    fig, axes = plt.subplots(3, 3, figsize=(11, 8), sharex=True)
    for i, joint in enumerate(("shoulder", "elbow", "wrist")):
        for k, axis in enumerate("xyz"):
            ax = axes[i, k]
            ax.plot(t, result.raw_positions[:, i, k], color="0.6", lw=0.8, label="raw")
            ax.plot(t, result.positions[:, i, k], color="C0", lw=1.2, label="filtered")
            ax.set_title(f"{joint} {axis}", fontsize=9)
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    for ax in axes[:, 0]:
        ax.set_ylabel("m (trunk frame)")
    fig.suptitle(f"{result.side} arm: raw vs filtered joint positions")
    fig.tight_layout()
    fig.savefig(out / "positions.png", dpi=100)
    plt.close(fig)
    paths.append(out / "positions.png")
    deg = np.rad2deg
    singular = result.flags.get("shoulder_singular")
    paths.append(_four_panels(plt, t, [deg(result.q), deg(result.q_ik)], "deg",
                              f"{result.side} arm joint angles (ISB; shaded: arm hanging or straight up)",
                              out / "angles.png", labels=("fit", "per-frame IK"), shade=singular))  # fmt: skip
    if result.thesis is not None:
        paths.append(_four_panels(plt, t, [deg(result.thesis)], "deg",
                                  "the thesis's angles, derived (shaded: gimbal lock)", out / "thesis_angles.png",
                                  names=_THESIS_LABELS, shade=result.flags.get("thesis_gimbal_lock")))  # fmt: skip
    paths.append(_four_panels(plt, t, [deg(result.qd)], "deg/s", "joint velocities", out / "velocities.png"))
    paths.append(
        _four_panels(plt, t, [deg(result.qdd)], "deg/s²", "joint accelerations", out / "accelerations.png")
    )
    paths.append(
        _four_panels(
            plt,
            t,
            [result.tau],
            "N m",
            f"joint torques (Newton-Euler, {result.subject['body_mass']:g} kg {result.subject['sex']})",
            out / "torques.png",
        )
    )
    if gif:
        paths.append(stick_figure_gif(result, out / "stick_figure.gif", max_frames=max_gif_frames))
    return paths


def stick_figure_gif(
    result, path: str | os.PathLike, max_frames: int = 150, fps: float | None = None
) -> Path:
    """3-D stick figure of raw vs reconstructed shoulder-elbow-wrist, at most ``max_frames`` frames."""
    plt = _plt()
    from PIL import Image

    frames = np.linspace(0, len(result.t) - 1, min(max_frames, len(result.t))).round().astype(int)
    pts = np.concatenate([result.raw_positions, result.reconstructed]).reshape(-1, 3)
    pts = pts[np.isfinite(pts).all(1)]
    centre = pts.mean(0) if len(pts) else np.zeros(3)
    half = max(float(np.abs(pts - centre).max()) if len(pts) else 0.5, 0.1)
    images = []
    fig = plt.figure(figsize=(4, 4), dpi=72)
    ax = fig.add_subplot(projection="3d")
    for f in frames:
        ax.cla()
        for data, colour, label in (
            (result.raw_positions, "0.55", "raw"),
            (result.reconstructed, "C0", "model"),
        ):
            p = data[f]
            if np.isfinite(p).all():
                ax.plot(p[:, 0], p[:, 1], p[:, 2], "-o", color=colour, lw=2, ms=4, label=label)
        ax.scatter([0], [0], [0], color="k", s=10)  # trunk origin (spine_shoulder)
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_xlabel("x fwd")
        ax.set_ylabel("y left")
        ax.set_zlabel("z up")
        ax.set_title(f"t = {result.t[f]:.2f} s", fontsize=9)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper left", fontsize=7)
        fig.canvas.draw()
        images.append(Image.fromarray(np.asarray(fig.canvas.buffer_rgba())[..., :3]))
    plt.close(fig)
    step = (result.t[frames[1]] - result.t[frames[0]]) if len(frames) > 1 else 0.1
    duration_ms = int(round(1000 / fps if fps else 1000 * step))
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(target, save_all=True, append_images=images[1:], duration=max(duration_ms, 20), loop=0)
    return target
