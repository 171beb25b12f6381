"""Measurement behind the default ``ridge`` of the trajectory fit (docs/dmp.md, "Regularised fitting").

For each ridge value it fits ``DMP(n_basis=20)`` and reports:

- coarse grids: a demonstration sampled at 30, 40 and 50 points (30 Hz skeleton data over
  1-1.7 s; synthetic ones with 0.5 % measurement noise, like skeleton jitter) is fitted,
  then replayed on a 1000-sample grid of the same duration and compared with the
  underlying smooth motion (relative RMSE, median and max), plus the largest weight;
- fine grids: LASA handwriting at its own 1000 samples (reproduction RMSE relative to range).

Development data (used to choose the default): synthetic motions with seeds 0-19 and the
LASA shapes with an even index in ``LASA_SHAPES``; held-out report: seeds 100-119 and the
LASA shapes with an odd index. LASA coarse grids subsample the 1000 recorded points.

Run: ``PYTHONPATH=src python benchmarks/dmp_ridge.py [--split dev|test]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "dmp"))

from dmp_helpers import LASA_SHAPES, lasa_demo, smooth_demo

from lfd.dmp import DMP

RIDGES = (0.0, 1e-12, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6)
NOISE = 0.005  # measurement noise of the synthetic coarse samples, fraction of each DoF's range
COARSE = (30, 40, 50)
FINE = 1000


def split(name: str):
    seeds = range(0, 20) if name == "dev" else range(100, 120)
    shapes = LASA_SHAPES[0::2] if name == "dev" else LASA_SHAPES[1::2]
    return seeds, shapes


def coarse_cases(seeds, shapes):
    """(t_coarse, y_coarse, t_fine, y_fine) with the same start and end times."""
    for seed in seeds:
        rng = np.random.default_rng(seed)
        n = COARSE[seed % len(COARSE)]
        fine_t = np.linspace(0.0, n / 30.0, FINE)
        state = rng.bit_generator.state
        _, fine_y = smooth_demo(rng, t=fine_t, n_dims=7)
        rng.bit_generator.state = state  # the same motion, sampled coarsely
        coarse_t = np.linspace(0.0, n / 30.0, n)
        _, coarse_y = smooth_demo(rng, t=coarse_t, n_dims=7)
        noise = (
            NOISE * np.ptp(coarse_y, axis=0) * np.random.default_rng(seed + 1000).normal(size=coarse_y.shape)
        )
        yield coarse_t, coarse_y + noise, fine_t, fine_y
    for name in shapes:
        t, y = lasa_demo(name)
        for n in COARSE:
            index = np.round(np.linspace(0, len(t) - 1, n)).astype(int)
            yield t[index], y[index], t, y


def relative_rmse(a, b):
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1))) / np.ptp(b, axis=0).max())


def measure(ridge: float, split_name: str) -> dict:
    seeds, shapes = split(split_name)
    coarse, weights = [], []
    for ct, cy, ft, fy in coarse_cases(seeds, shapes):
        dmp = DMP(20, ridge=ridge).fit(ct, cy)
        coarse.append(relative_rmse(dmp.rollout(t=ft), fy))
        weights.append(np.abs(dmp.weights_).max() / np.ptp(cy, axis=0).max())
    fine = []
    for name in shapes:
        t, y = lasa_demo(name)
        fine.append(relative_rmse(DMP(20, ridge=ridge).fit(t, y).rollout(t=t), y))
    return {
        "coarse_median": np.median(coarse),
        "coarse_max": np.max(coarse),
        "weight_max": np.max(weights),
        "fine_median": np.median(fine),
        "fine_max": np.max(fine),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--split", choices=("dev", "test"), default="dev")
    args = parser.parse_args()
    print(f"split: {args.split}; errors relative to the demonstration's range, weights relative to it too\n")
    print(
        "| ridge | coarse -> 1000-sample replay: median / max RMSE | max abs weight / range "
        "| LASA 1000 samples: median / max RMSE |"
    )
    print("|---|---|---|---|")
    for ridge in RIDGES:
        m = measure(ridge, args.split)
        print(
            f"| {ridge:g} | {m['coarse_median']:.2e} / {m['coarse_max']:.2e} | {m['weight_max']:.3g} "
            f"| {m['fine_median']:.2e} / {m['fine_max']:.2e} |"
        )


if __name__ == "__main__":
    main()
