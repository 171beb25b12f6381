"""Evaluation figures (matplotlib, Agg) and rollout GIFs (Pillow)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from PIL import Image

from lfd.visuomotor.policies import POLICIES


def policy_colour(kind: str) -> str:
    """The colour of a policy kind in every figure (its class's ``colour``; grey if unknown)."""
    cls = POLICIES.get(kind)
    return cls.colour if cls is not None else "tab:gray"


def policy_label(kind: str) -> str:
    """The name of a policy kind in tables and legends (its class's ``label``; the kind if unknown)."""
    cls = POLICIES.get(kind)
    return cls.label if cls is not None else kind


def distance_bars(
    path: Path,
    object_name: str,
    placement_labels: Sequence[str],
    distances_m: dict[str, Sequence[float]],
) -> None:
    """Final distance (cm) per placement of one object, one bar per method side by side.

    Args:
        distances_m: method -> final distances (m), one per entry of ``placement_labels``.
    """
    n = len(placement_labels)
    methods = list(distances_m)
    width = 0.8 / max(1, len(methods))
    fig, ax = plt.subplots(figsize=(max(5.0, 0.9 * n + 2.0), 3.6))
    x = np.arange(n)
    for i, method in enumerate(methods):
        ax.bar(
            x + (i - (len(methods) - 1) / 2) * width,
            np.asarray(distances_m[method]) * 100,
            width,
            label=policy_label(method),
            color=policy_colour(method),
        )
    for level in (2, 5):
        ax.axhline(level, color="k", lw=0.8, ls=":")
    ax.set_xticks(x)
    ax.set_xticklabels(placement_labels, rotation=30, ha="right", fontsize=7)
    ax.set_ylabel("final distance to grasp target (cm)")
    ax.set_title(f"{object_name}: distance error per placement")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def paths_3d(
    path: Path,
    object_name: str,
    targets: np.ndarray,
    demos: Sequence[np.ndarray | None],
    rollouts: dict[str, Sequence[np.ndarray]],
) -> None:
    """End-effector paths of one object's episodes in 3-D (torso frame, m).

    Args:
        targets: ``(P, 3)`` grasp target per placement.
        demos: per placement the demonstrated tool path ``(T, 3)`` (or None).
        rollouts: method -> per placement the executed tool path ``(S, 3)``.
    """
    fig = plt.figure(figsize=(6.0, 5.0))
    ax = fig.add_subplot(projection="3d")
    for k, demo in enumerate(demos):
        if demo is not None:
            ax.plot(*demo.T, color="k", lw=1.0, label="demonstration" if k == 0 else None)
    for method, paths in rollouts.items():
        for k, p in enumerate(paths):
            ax.plot(*p.T, color=policy_colour(method), lw=1.2, label=policy_label(method) if k == 0 else None)
            ax.scatter(*p[-1], color=policy_colour(method), s=12)
    ax.scatter(*np.asarray(targets).T, marker="*", s=80, color="red", label="grasp target")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(f"{object_name}: end-effector paths")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_gif(path: Path, frames: Sequence[np.ndarray], frame_seconds: float, scale: int = 2) -> None:
    """Animated GIF of uint8 ``(H, W, 3)`` frames, each shown ``frame_seconds``, upscaled ``scale`` times."""
    if not frames:
        raise ValueError(f"write_gif({path}): no frames")
    images = [
        Image.fromarray(f).resize((f.shape[1] * scale, f.shape[0] * scale), Image.NEAREST) for f in frames
    ]
    images[0].save(
        path,
        save_all=True,
        append_images=images[1:],
        duration=max(20, int(math.ceil(frame_seconds * 1000))),
        loop=0,
    )
