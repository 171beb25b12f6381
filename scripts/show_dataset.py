"""Grid of first frames of a reaching dataset with the demonstrated tool paths drawn in.

Usage::

    python scripts/show_dataset.py data/quick_s42 --out grid.png [--n 12] [--split test]

Each panel is the first camera frame of an episode; the line is the demonstrated
end-effector (tool) path projected with the episode's camera matrices, from blue (start)
to yellow (end), and the red cross is the grasp target point. The dataset is verified
against its manifest first.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from lfd.sim import project_points
from lfd.visuomotor.data import SPLITS, load_dataset


def pick(records: list, n: int) -> list:
    """``n`` records spread evenly over ``records`` (all if fewer)."""
    if len(records) <= n:
        return records
    return [records[i] for i in np.linspace(0, len(records) - 1, n).round().astype(int)]


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("dataset", type=Path, help="dataset folder (with manifest.json)")
    parser.add_argument("--out", type=Path, default=Path("dataset_grid.png"), help="output PNG")
    parser.add_argument("--n", type=int, default=12, help="number of episodes to show")
    parser.add_argument("--split", choices=("all", *SPLITS), default="all")
    parser.add_argument("--cols", type=int, default=4)
    args = parser.parse_args(argv)

    data = load_dataset(args.dataset)
    records = data.episodes if args.split == "all" else data.split(args.split)
    if not records:
        raise SystemExit(f"{args.dataset}: no episodes in split '{args.split}'")
    shown = pick(records, args.n)
    cols = min(args.cols, len(shown))
    rows = math.ceil(len(shown) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.4 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, rec in zip(axes.flat, shown, strict=False):  # more panels than episodes
        frame = rec.frames()[0]
        h, w = frame.shape[:2]
        view, proj = rec.arrays["camera_view"], rec.arrays["camera_projection"]
        path = project_points(rec.arrays["ee_poses"][:, :3, 3], view, proj, w, h)
        target = project_points(rec.target_point, view, proj, w, h)
        ax.imshow(frame, extent=(0, w, h, 0))
        ax.scatter(path[:, 0], path[:, 1], c=np.linspace(0, 1, len(path)), cmap="viridis", s=4)
        ax.plot(path[:, 0], path[:, 1], color="white", lw=0.6, alpha=0.6)
        ax.plot(*target, marker="x", color="red", ms=7, mew=2)
        ax.set_xlim(0, w)
        ax.set_ylim(h, 0)
        ax.set_title(
            f"#{rec.index} {rec.split}: {rec.obj.name}\n"
            f"x={rec.placement.x:.2f} y={rec.placement.y:.2f} yaw={math.degrees(rec.placement.yaw):.0f}deg",
            fontsize=8,
        )
    counts = data.manifest["episodes"]
    fig.suptitle(
        f"{args.dataset.name}: {counts['train']} train / {counts['val']} val / {counts['test']} test episodes, "
        f"discarded {sum(data.manifest['discarded'].values())}",
        fontsize=10,
    )
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=120)
    plt.close(fig)
    print(f"wrote {args.out}")
    return args.out


if __name__ == "__main__":
    main()
