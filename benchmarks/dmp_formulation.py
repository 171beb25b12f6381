"""Measurement behind the default ``formulation=`` of lfd.dmp (docs/dmp.md, "Formulation").

For each formulation ("pastor", "ijspeert") it reports, on the same demonstrations:

1. reproduction RMSE relative to each DoF's range, split into DoFs that move to a new
   position and DoFs that end where they began (``g == y0``), on LASA handwriting (2-D,
   with a third DoF added that lifts and comes back, like a hand carried over an obstacle)
   and on synthetic 7-joint reaches in which two joints return to their start;
2. goal changes: the largest distance of the new-goal rollout from "the demonstration plus
   the goal offset" relative to the offset, for a DoF that moves far (|g - y0| = range) and
   one that moves little (|g - y0| = 2 % of its range), goal moved by 10 % of the range;
3. temporal scaling: ``rollout(tau=2 tau)(2 t) == rollout()(t)``, max abs difference.

Run: ``PYTHONPATH=src python benchmarks/dmp_formulation.py`` (a few seconds).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "dmp"))

from dmp_helpers import LASA_SHAPES, lasa_demo, smooth_demo

from lfd.dmp import DMP
from lfd.dmp.formulation import FORMULATIONS


def returning_demos():
    """(name, t, y, returning mask) with some DoFs ending at their start."""
    cases = []
    for name in LASA_SHAPES:
        t, y = lasa_demo(name)
        s = (t - t[0]) / (t[-1] - t[0])
        lift = 0.3 * np.ptp(y) * np.sin(np.pi * s) ** 2  # up and down again
        cases.append((f"LASA {name}", t, np.column_stack([y, lift]), np.array([False, False, True])))
    rng = np.random.default_rng(0)
    for i in range(10):
        t, y = smooth_demo(rng, 100, 7, duration=4.0)
        s = (t - t[0]) / (t[-1] - t[0])
        for d in (2, 5):  # joints that swing out and back
            y[:, d] = y[0, d] + rng.uniform(0.2, 1.0) * np.sin(np.pi * s) * np.sin(
                np.pi * s * rng.integers(1, 3)
            )
        cases.append((f"7-joint {i}", t, y, np.isin(np.arange(7), (2, 5))))
    return cases


def reproduction(formulation):
    moving, returning = [], []
    for _, t, y, mask in returning_demos():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            out = DMP(20, formulation=formulation).fit(t, y).rollout(t=t)
        err = np.sqrt(np.mean((out - y) ** 2, axis=0)) / np.ptp(y, axis=0)
        moving.extend(err[~mask])
        returning.extend(err[mask])
    return np.median(moving), np.max(moving), np.median(returning), np.max(returning)


def goal_change(formulation):
    t = np.linspace(0, 2, 200)
    s = t / t[-1]
    shape = np.sin(np.pi * s) * 0.5
    minimum_jerk = 10 * s**3 - 15 * s**4 + 6 * s**5
    far = minimum_jerk + shape  # |g - y0| = 1
    near = 0.02 * minimum_jerk + shape  # |g - y0| = 0.02
    y = np.column_stack([far, near])
    dmp = DMP(20, formulation=formulation).fit(t, y)
    offset = 0.1 * np.ptp(y, axis=0)
    long_t = np.linspace(0, 3 * dmp.tau_, 600)
    base = dmp.rollout(t=long_t)
    moved = dmp.rollout(t=long_t, goal=dmp.goal_ + offset)
    # deviation of (moved - base) from the offset, over the motion, relative to the offset
    excess = np.max(np.abs(moved - base), axis=0) / offset
    end_error = np.abs(moved[-1] - (dmp.goal_ + offset)) / offset
    return excess, end_error


def temporal(formulation):
    rng = np.random.default_rng(3)
    t, y = smooth_demo(rng, 150, 3, duration=1.5)
    dmp = DMP(formulation=formulation).fit(t, y)
    return np.abs(dmp.rollout(t=2 * t, tau=2 * dmp.tau_) - dmp.rollout(t=t)).max()


def main():
    print(
        "| formulation | moving DoFs: median / max RMSE | returning DoFs: median / max RMSE "
        "| goal +10 %: max shift / offset (far, near DoF) | end error / offset | tau x2 max diff |"
    )
    print("|---|---|---|---|---|---|")
    for formulation in FORMULATIONS:
        mov_med, mov_max, ret_med, ret_max = reproduction(formulation)
        excess, end_error = goal_change(formulation)
        print(
            f"| {formulation} | {mov_med:.2e} / {mov_max:.2e} | {ret_med:.2e} / {ret_max:.2e} "
            f"| {excess[0]:.2f}, {excess[1]:.2f} | {end_error.max():.1e} | {temporal(formulation):.1e} |"
        )
    print(
        "\nRMSE relative to each DoF's range; 'max shift / offset' is 1.00 when a goal change moves "
        "the path by no more than the goal offset (shape kept), larger when it rescales the shape."
    )


if __name__ == "__main__":
    main()
