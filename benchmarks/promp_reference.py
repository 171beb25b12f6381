"""lfd.dmp.ProMP vs movement_primitives' ProMP (0.9.1): agreement at equal settings and speed, one process.

Equal settings: movement_primitives' basis (K bases, overlap 0.7), ridge 1e-12, their weights from
``weights()`` per demonstration and ``from_weight_distribution(mean, np.cov(W.T))``; the
conditioning is one via point (their ``condition_position``) and three at once (ours) vs one
after another (theirs). ``imitate`` (their EM fit) is compared on the mean trajectory only.
Speed-up = their time / ours (best of 3 runs).

    PYTHONPATH=src python benchmarks/promp_reference.py
"""

from __future__ import annotations

import time

import numpy as np
from movement_primitives.promp import ProMP as ReferenceProMP

from lfd.dmp import ProMP


def best_of(function, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def demos(rng, n_demos: int, n_steps: int, n_dims: int):
    t = np.linspace(0.0, 2.0, n_steps)
    s = t / 2.0
    freq = 1.0 + 0.1 * rng.normal(size=(n_demos, 1, n_dims))
    offset, slope = 0.2 * rng.normal(size=(2, n_demos, 1, n_dims))
    return t, np.sin(2 * np.pi * s[:, None] * freq) + offset + slope * s[:, None]


def row(rng, n_demos: int, n_steps: int, n_dims: int, n_basis: int) -> str:
    """One markdown table row: agreement and speed-ups for one problem size."""
    t, Y = demos(rng, n_demos, n_steps, n_dims)

    def fit_ref():
        ref = ReferenceProMP(n_dims, n_basis)
        weights = np.array([ref.weights(t.copy(), y) for y in Y])
        return ref.from_weight_distribution(weights.mean(axis=0), np.cov(weights.T))

    ref, ours = fit_ref(), ProMP(n_basis=n_basis).fit(t, Y)
    times, points = np.array([0.0, 1.2, 2.0]), Y[0, [0, n_steps // 2, -1]] + 0.1
    noise = 1e-4 * np.eye(n_dims)

    def condition_ref():
        out = ref
        for when, point in zip(times, points):
            out = out.condition_position(point, y_cov=noise, t=when, t_max=2.0)
        return out

    ref_c, ours_c = condition_ref(), ours.condition(times, points, y_cov=noise)
    diffs = [
        np.abs(ours.mean_trajectory(t) - ref.mean_trajectory(t.copy())).max(),
        np.abs(ours.var_trajectory(t) - ref.var_trajectory(t.copy())).max(),
        np.abs(ours_c.mean_trajectory(t) - ref_c.mean_trajectory(t.copy())).max(),
        np.abs(ours_c.var_trajectory(t) - ref_c.var_trajectory(t.copy())).max(),
    ]
    em = ReferenceProMP(n_dims, n_basis)
    em.imitate(np.tile(t, (n_demos, 1)), Y)
    em_diff = np.abs(em.mean_trajectory(t.copy()) - ours.mean_trajectory(t)).max() / np.ptp(Y)
    speed = [
        best_of(fit_ref) / best_of(lambda: ProMP(n_basis=n_basis).fit(t, Y)),
        best_of(lambda: ref.var_trajectory(t.copy())) / best_of(lambda: ours.var_trajectory(t)),
        best_of(condition_ref) / best_of(lambda: ours.condition(times, points, y_cov=noise)),
        best_of(lambda: ref.sample_trajectories(t.copy(), 1000, np.random.RandomState(0)))
        / best_of(lambda: ours.sample_trajectories(t, 1000, rng=0)),
    ]
    return (
        f"| {n_demos} | {n_steps} | {n_dims} | {n_basis} | {' / '.join(f'{d:.1e}' for d in diffs)} | "
        f"{em_diff:.1%} | " + " | ".join(f"{s:.1f}x" for s in speed) + " |"
    )


def main() -> None:
    rng = np.random.default_rng(0)
    print(
        "| N | T | D | K | max abs diff mean / var / cond. mean / cond. var | imitate (EM) mean diff / range |",
        end="",
    )
    print(" fit | var_trajectory | condition (3 points) | 1000 samples |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for size in ((10, 100, 3, 10), (10, 200, 7, 20), (20, 500, 7, 20)):
        print(row(rng, *size))


if __name__ == "__main__":
    main()
