"""PoWER convergence on 20 Sawyer goal changes: ours (lfd.rl.power) vs the thesis-text algorithm.

What this measures: a *goal search*. The end point is pinned by the DMP goal, so the
weights barely matter here (turning weight exploration off changes little, and goal
noise plus error annealing explain most of the gap to the baseline). The baseline below
follows the thesis text, not the published pyrdmp code (that one is
``lfd.rl.power(variant="pyrdmp")``). For tasks where the weights matter (via points,
obstacles), with PoWER per-step/episodic, PI^BB, CMA-ES and pyrdmp on one harness, see
``benchmarks/power_tasks.py`` and ``docs/power.md``.

Problem (identical for both algorithms, the thesis' "DMP learned from the demonstration
only" setting): a 20-basis DMP fitted to the scripted Sawyer demonstration of
``power_sawyer_example.py`` must learn, from the eq. 5.4 reward alone (w1 = 0.99), to reach
a new goal. The policy parameters are the 7 x 20 weights and the 7 goal values, starting
from the demonstration's; no IK of the new goal is used. Stopping rule: the policy's final
position within 0.01 rad of the goal (joint space) or its end effector within 1 cm (task
space), and within the joint limits (returns of rollouts outside them are multiplied by
``exp(-100 v)``, ``v`` the violation in rad, for both). Both use the same batched rollouts
(:class:`lfd.rl.DMPRollout`), 10 exploratory rollouts per iteration plus one rollout of the
updated policy, and the same iteration cap; a run that hits the cap is marked ``cap`` and
counted with the cap's rollouts, so the ratio is then a lower bound.

* joint space: goals = demonstrated final configuration + N(0, 0.15^2) rad per joint,
  T = 1000 samples (4 s);
* task space: goals = demonstrated end-effector goal + uniform offsets in [-0.2, 0.2] m in
  x and y (z kept), T = 200 samples (4 s; forward kinematics of every sample is the cost).

Ours (``lfd.rl.power`` defaults): weight exploration normalised by each DoF's
forcing-term scale (zero weights explore), goal exploration ``sigma_goal`` (0.1 rad in
joint space, 0.2 rad in task space: chosen in a sweep over {0.05, 0.1, 0.2, 0.3} on tuning
goals drawn with seed + 1000, not on the benchmark goals), both annealed with the
remaining error; importance sampling over the 3 best rollouts seen so far. The original
(re-implemented below, clearly labelled): exploration standard deviation proportional to
each parameter's own magnitude (``c |theta_j|``, so zero parameters never explore), best
half of the 10 rollouts of the current iteration, no memory across iterations. Its factor
``c`` is tuned by this script on 5 tuning goals (seed + 1000) over {0.003, 0.01, 0.03, 0.1}
(the best total is used; fixed to 0.01 with --quick).

Also printed: rollouts used by ``adapt_to_goal`` (goal set to the new goal / an IK
solution first, then PoWER) on the same goals, and the time of one iteration
(10 rollouts + 1, 7 DoF, T = 1000, joint-space reward; target < 5 ms).

Usage::

    PYTHONPATH=src python benchmarks/power_convergence.py [--quick] [--seed 0]
"""

from __future__ import annotations

import argparse
import statistics
import time
from dataclasses import dataclass

import numpy as np
from power_sawyer_example import DEMO_GOAL, sawyer_demo, tool_positions

from lfd.dmp import DMP
from lfd.rl import DMPRollout, JointGoalReward, TaskGoalReward, adapt_to_goal, limit_violation, power
from lfd.robots import load_robot

N_ROLLOUTS = 10
W1 = 0.99
TOL = 0.01  # rad (joint space) or m (task space)
LIMIT_PENALTY = 100.0
C_GRID = (0.003, 0.01, 0.03, 0.1)
N_STEPS = {"joint": 1000, "task": 200}
SIGMA_GOAL = {"joint": 0.1, "task": 0.2}  # rad
UNIT = {"joint": "mrad", "task": "mm"}  # errors are printed in 1e-3 rad / 1e-3 m


@dataclass(frozen=True)
class Run:
    """Outcome of one algorithm on one goal."""

    iterations: int
    rollouts: int
    error: float
    converged: bool
    seconds: float


# --------------------------------------------------------------------------------------
# THESIS-TEXT ALGORITHM (re-implemented from the text, for comparison only): sigma_j = c |theta_j|,
# best half of the current K rollouts, reward-weighted perturbations, no memory.
# --------------------------------------------------------------------------------------
def original_power(rollout: DMPRollout, theta0, reward, error, tol, c, lower, upper, max_iter, seed) -> Run:
    """PoWER as in the original code, on ``theta = [weights.ravel(), goal]``."""
    start = time.perf_counter()
    rng = np.random.default_rng(seed)
    split = rollout.n_dof * rollout.n_basis

    def evaluate(theta):
        trajectories = rollout(theta[:, :split].reshape(-1, rollout.n_dof, rollout.n_basis), theta[:, split:])
        returns = reward(trajectories) * np.exp(-LIMIT_PENALTY * limit_violation(trajectories, lower, upper))
        return trajectories, returns

    theta = np.array(theta0, dtype=np.float64)
    trajectory, _ = evaluate(theta[None])
    rollouts, iteration = 1, 0

    def done():
        return error(trajectory)[0] <= tol and limit_violation(trajectory, lower, upper)[0] == 0.0

    while iteration < max_iter and not done():
        iteration += 1
        eps = rng.standard_normal((N_ROLLOUTS, theta.size)) * (c * np.abs(theta))
        _, returns = evaluate(theta + eps)
        best = np.argsort(-returns)[: N_ROLLOUTS // 2]
        if returns[best].sum() > 0.0:
            theta = theta + returns[best] @ eps[best] / returns[best].sum()
        trajectory, _ = evaluate(theta[None])
        rollouts += N_ROLLOUTS + 1
    return Run(iteration, rollouts, float(error(trajectory)[0]), done(), time.perf_counter() - start)


# --------------------------------------------------------------------------------------


def ours(dmp, reward, sigma_goal, lower, upper, max_iter, seed) -> Run:
    start = time.perf_counter()
    result = power(dmp, reward, sigma_goal=sigma_goal, n_rollouts=N_ROLLOUTS, tol=TOL, lower=lower, upper=upper,
                   limit_penalty=LIMIT_PENALTY, max_iter=max_iter, seed=seed)  # fmt: skip
    return Run(
        result.iterations, result.rollouts, result.error, result.converged, time.perf_counter() - start
    )


def original(dmp, reward, lower, upper, max_iter, seed, c) -> Run:
    theta0 = np.concatenate([dmp.weights_.ravel(), dmp.goal_])
    return original_power(DMPRollout(dmp), theta0, reward, reward.error, TOL, c, lower, upper, max_iter, seed)


def problems(robot, space: str, rng, n_goals: int):
    """DMP fitted to the demonstration, and ``n_goals`` goals with their rewards."""
    t, demo = sawyer_demo(robot, N_STEPS[space])
    dmp = DMP(n_basis=20).fit(t, demo)
    lower, upper = robot.lower.numpy(), robot.upper.numpy()
    if space == "joint":
        goals = [
            np.clip(dmp.goal_ + rng.normal(0.0, 0.15, 7), lower + 0.05, upper - 0.05) for _ in range(n_goals)
        ]
        rewards = [JointGoalReward(goal, W1) for goal in goals]
    else:
        demo_xyz = tool_positions(robot, dmp.goal_[None])[0]
        goals = [demo_xyz + np.r_[rng.uniform(-0.2, 0.2, 2), 0.0] for _ in range(n_goals)]
        rewards = [TaskGoalReward(robot, goal, W1) for goal in goals]
    return dmp, goals, rewards


def tune_c(robot, space, max_iter, seed) -> float:
    """The original's exploration factor with the fewest total rollouts on 5 tuning goals."""
    dmp, _, rewards = problems(robot, space, np.random.default_rng(seed + 1000), 5)
    lower, upper = robot.lower.numpy(), robot.upper.numpy()
    totals = {
        c: sum(original(dmp, r, lower, upper, max_iter, seed, c).rollouts for r in rewards) for c in C_GRID
    }
    return min(totals, key=totals.get)


def cells(run: Run) -> str:
    """Table cells: iterations (``cap`` if not converged), rollouts, final error (1e-3 units), seconds."""
    mark = "" if run.converged else " cap"
    return f"{run.iterations}{mark} | {run.rollouts} | {run.error * 1e3:.2f} | {run.seconds:.2f}"


def table(robot, space: str, args, c: float) -> None:
    """Run both algorithms (and ``adapt_to_goal``) on the goals of ``space``; print the markdown table."""
    dmp, goals, rewards = problems(robot, space, np.random.default_rng(args.seed), args.goals)
    lower, upper = robot.lower.numpy(), robot.upper.numpy()
    unit = UNIT[space]
    print(f"\n### {space} space: {args.goals} goals, T = {N_STEPS[space]}, tolerance {TOL * 1e3:.0f} {unit}, "
          f"cap {args.max_iter} iterations, original c = {c}\n")  # fmt: skip
    print(f"| goal | start error [{unit}] | ours: it | rollouts | error [{unit}] | s "
          f"| original: it | rollouts | error [{unit}] | s | ratio | adapt_to_goal rollouts |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    totals = {"ours": [], "orig": [], "adapt": []}
    for k, (goal, reward) in enumerate(zip(goals, rewards)):
        start_error = reward.error(dmp.rollout()[None])[0]
        mine = ours(dmp, reward, SIGMA_GOAL[space], lower, upper, args.max_iter, args.seed + k)
        theirs = original(dmp, reward, lower, upper, args.max_iter, args.seed + k, c)
        adapted = adapt_to_goal(dmp, goal, robot=robot, space=space, w1=W1, tol=TOL, max_iter=args.max_iter,
                                seed=args.seed + k)  # fmt: skip
        totals["ours"].append(mine)
        totals["orig"].append(theirs)
        totals["adapt"].append(adapted)
        print(f"| {k} | {start_error * 1e3:.0f} | {cells(mine)} | {cells(theirs)} "
              f"| {theirs.rollouts / mine.rollouts:.1f} | {adapted.rollouts} |")  # fmt: skip
    mine_total, theirs_total = (sum(r.rollouts for r in totals[key]) for key in ("ours", "orig"))
    row = ["**total**", ""]
    for key, total in (("ours", mine_total), ("orig", theirs_total)):
        runs = totals[key]
        row += [str(sum(r.iterations for r in runs)), str(total), f"{sum(r.converged for r in runs)}/{len(runs)} conv.",
                f"{sum(r.seconds for r in runs):.1f}"]  # fmt: skip
    adapted = totals["adapt"]
    converged = f"{sum(r.converged for r in adapted)}/{len(adapted)} conv."
    row += [f"**{theirs_total / mine_total:.1f}**", f"{sum(r.rollouts for r in adapted)} ({converged})"]
    print("| " + " | ".join(row) + " |")


def iteration_time(robot, repeats: int) -> tuple[float, float]:
    """Median and best time (ms) of one iteration: 10 rollouts + 1, 7 DoF, T = 1000, joint reward."""
    dmp, _, (reward,) = problems(robot, "joint", np.random.default_rng(0), 1)
    n_iter = 100

    def run(iterations):
        start = time.perf_counter()
        power(dmp, reward, sigma_goal=0.1, max_iter=iterations, seed=0)
        return time.perf_counter() - start

    run(5)
    samples = [(run(n_iter) - run(0)) / n_iter * 1e3 for _ in range(repeats)]
    return statistics.median(samples), min(samples)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 goals, cap 100 iterations, no tuning of c")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    args.goals, args.max_iter = (5, 100) if args.quick else (20, 300)

    robot = load_robot("sawyer")
    print(f"Sawyer demonstration goal {DEMO_GOAL} m; 10 rollouts per iteration; w1 = {W1}")
    for space in ("joint", "task"):
        c = 0.01 if args.quick else tune_c(robot, space, args.max_iter, args.seed)
        table(robot, space, args, c)
    median, best = iteration_time(robot, 3 if args.quick else 7)
    print(f"\none iteration (10 rollouts + 1 policy rollout, 7 DoF, T = 1000, joint-space reward): "
          f"median {median:.2f} ms, best {best:.2f} ms (target < 5 ms)")  # fmt: skip


if __name__ == "__main__":
    main()
