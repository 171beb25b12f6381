"""The Sawyer PoWER example: learn a 7-DoF DMP from a demonstration, adapt it to a new goal.

1. Demonstration (scripted): a quintic joint trajectory (4 s, zero end velocity and
   acceleration) from the Sawyer start pose [0, -50, 0, 120, 0, 0, 0] deg to an IK solution
   for the demonstration goal [0.035, -0.573, -0.04] m with the cube orientation
   [180, 0, 90] deg (roll, pitch, yaw); position-only IK if the pose IK fails.
2. A 20-basis DMP is fitted to it.
3. The DMP is adapted to a new task-space goal (default [0.237, -0.466, -0.04] m, same
   orientation) in two ways:

   * ``adapt_to_goal``: the DMP goal is set to an IK solution of the new pose, then PoWER
     refines weights and goal until the end effector is within 1 cm (the library's way);
   * reward only (the original thesis setting, "DMP learned from the demonstration only"):
     PoWER starts from the demonstrated goal and learns weights and goal from the eq. 5.4
     task-space reward alone, no IK of the new goal.

4. A PNG shows the joint trajectories, the end-effector xyz over time and from above, the
   reward-only learning curve and the basis activations.

Usage::

    PYTHONPATH=src python benchmarks/power_sawyer_example.py [--out power_sawyer.png] [--goal X Y Z] [--seed 0]
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import torch

from lfd.dmp import DMP
from lfd.dmp.canonical import discrete_activations
from lfd.rl import TaskGoalReward, adapt_to_goal, goal_configuration, power
from lfd.robots import load_robot

START_DEG = (0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0)
DEMO_GOAL = (0.035, -0.573, -0.04)
NEW_GOAL = (0.237, -0.466, -0.04)
CUBE_RPY_DEG = (180.0, 0.0, 90.0)
DURATION = 4.0  # s


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` (angles in rad), shape ``(3, 3)``."""
    cr, sr, cp, sp, cy, sy = (
        np.cos(roll),
        np.sin(roll),
        np.cos(pitch),
        np.sin(pitch),
        np.cos(yaw),
        np.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def cube_pose(position) -> np.ndarray:
    """Tool pose ``(4, 4)`` at ``position`` (m) with the cube orientation."""
    pose = np.eye(4)
    pose[:3, :3] = rpy_matrix(*np.deg2rad(CUBE_RPY_DEG))
    pose[:3, 3] = position
    return pose


def sawyer_demo(robot, n_steps: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Scripted demonstration: times ``(T,)`` (s) and a quintic joint trajectory ``(T, 7)`` (rad)."""
    start = np.deg2rad(START_DEG)
    goal = goal_configuration(robot, cube_pose(DEMO_GOAL), start)
    t = np.linspace(0.0, DURATION, n_steps)
    s = t / DURATION
    profile = 10 * s**3 - 15 * s**4 + 6 * s**5
    return t, start + (goal - start) * profile[:, None]


def tool_positions(robot, trajectory: np.ndarray) -> np.ndarray:
    """End-effector positions ``(T, 3)`` (m) of a joint trajectory ``(T, 7)``."""
    return robot.fk(torch.from_numpy(trajectory))[:, :3, 3].numpy()


def plot(path, t, dmp, robot, runs: dict, learning, new_goal) -> None:
    """Write the figure: joints, end-effector xyz and top view, learning curve, basis activations."""
    fig = plt.figure(figsize=(15, 9.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 3)
    colours = plt.cm.tab10(np.arange(7))
    styles = {"demonstration DMP": ":", "adapt_to_goal (IK goal + PoWER)": "-", "PoWER, reward only": "--"}

    ax = fig.add_subplot(grid[0, 0])
    for name, trajectory in runs.items():
        for j in range(7):
            ax.plot(t, np.rad2deg(trajectory[:, j]), styles[name], color=colours[j], lw=1.4)
    ax.set(title="Joint trajectories (colour = joint j0..j6)", xlabel="time [s]", ylabel="angle [deg]")
    ax.legend(
        [plt.Line2D([], [], ls=s, color="k") for s in styles.values()], styles.keys(), fontsize=8, loc="best"
    )

    ax = fig.add_subplot(grid[0, 1])
    for name, trajectory in runs.items():
        xyz = tool_positions(robot, trajectory)
        for k, (axis, colour) in enumerate(zip("xyz", ("tab:red", "tab:green", "tab:blue"))):
            ax.plot(
                t,
                xyz[:, k],
                styles[name],
                color=colour,
                lw=1.4,
                label=axis if name.startswith("adapt") else None,
            )
    for k, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        ax.axhline(new_goal[k], color=colour, lw=0.8, alpha=0.5)
    ax.set(title="End-effector position (thin lines: new goal)", xlabel="time [s]", ylabel="[m]")
    ax.legend(fontsize=8)

    ax = fig.add_subplot(grid[0, 2])
    for name, trajectory in runs.items():
        xyz = tool_positions(robot, trajectory)
        ax.plot(xyz[:, 0], xyz[:, 1], styles[name], color="k", lw=1.4, label=name)
    ax.plot(*DEMO_GOAL[:2], "o", color="tab:gray", ms=9, label="demonstration goal")
    ax.plot(*new_goal[:2], "*", color="tab:orange", ms=14, label="new goal")
    ax.add_patch(plt.Circle(new_goal[:2], 0.01, fill=False, color="tab:orange", lw=1))
    ax.set(title="End effector seen from above", xlabel="x [m]", ylabel="y [m]", aspect="equal")
    ax.legend(fontsize=8, loc="best")

    ax = fig.add_subplot(grid[1, 0])
    history = learning.history
    ax.semilogy(history.rollouts, 100 * history.error, "o-", ms=3, color="tab:purple")
    ax.axhline(1.0, color="tab:orange", lw=1, ls="--", label="1 cm tolerance")
    ax.set(title="PoWER, reward only: learning curve", xlabel="rollouts", ylabel="end-effector error [cm]")
    ax.legend(fontsize=8)

    ax = fig.add_subplot(grid[1, 1:])
    theta = torch.from_numpy((t - t[0]) / dmp.tau_)
    psi = discrete_activations(theta, dmp.n_basis, dmp.alpha_s, dmp.overlap).numpy()
    ax.plot(t, psi / psi.sum(axis=1, keepdims=True), lw=1.2)
    ax.plot(t, np.exp(-dmp.alpha_s * theta.numpy()), "k--", lw=1.5, label="phase s(t)")
    ax.set(title=f"Normalised basis activations ({dmp.n_basis} bases, centres evenly spaced in time)",
           xlabel="time [s]", ylabel="psi_i / sum_j psi_j")  # fmt: skip
    ax.legend(fontsize=8, loc="upper right")

    fig.suptitle("Sawyer: DMP learned from a demonstration, adapted to a new task-space goal with PoWER")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="power_sawyer.png", help="output PNG path")
    parser.add_argument(
        "--goal", type=float, nargs=3, default=NEW_GOAL, metavar=("X", "Y", "Z"), help="new goal (m)"
    )
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    robot = load_robot("sawyer")
    t, demo = sawyer_demo(robot)
    dmp = DMP(n_basis=20).fit(t, demo)
    new_goal = np.asarray(args.goal, dtype=np.float64)
    limits = dict(lower=robot.lower.numpy(), upper=robot.upper.numpy())

    start = time.perf_counter()
    adapted = adapt_to_goal(dmp, cube_pose(new_goal), robot=robot, space="task", seed=args.seed)
    adapt_seconds = time.perf_counter() - start
    start = time.perf_counter()
    reward = TaskGoalReward(robot, new_goal)
    learning = power(dmp, reward, sigma_goal=0.2, tol=0.01, max_iter=300, seed=args.seed, **limits)
    learn_seconds = time.perf_counter() - start

    demo_end = tool_positions(robot, dmp.rollout()[-1:])[0]
    print(f"demonstration DMP ends at {np.round(demo_end, 3).tolist()} m (demonstration goal {list(DEMO_GOAL)}), "
          f"{100 * np.linalg.norm(demo_end - new_goal):.1f} cm from the new goal {new_goal.tolist()}")  # fmt: skip
    for name, result, seconds in (
        ("adapt_to_goal", adapted, adapt_seconds),
        ("reward only", learning, learn_seconds),
    ):
        print(f"{name:14s}: converged={result.converged} iterations={result.iterations} rollouts={result.rollouts} "
              f"error={100 * result.error:.2f} cm within_limits={result.within_limits} ({seconds:.2f} s)")  # fmt: skip
    runs = {
        "demonstration DMP": dmp.rollout(),
        "adapt_to_goal (IK goal + PoWER)": adapted.trajectory,
        "PoWER, reward only": learning.trajectory,
    }
    plot(args.out, t, dmp, robot, runs, learning, new_goal)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
