"""The imitation pipeline's outputs that every source shares: the robot trajectory as CSV and as a
``trajectory_msgs/JointTrajectory`` bag, the refinement plot and ``summary.json``.

Summary keys (all sources): ``source``, ``source_type``, ``robot``, ``frames`` (samples of the demonstration),
``time_scale`` (factor the DMP is stretched by to keep the velocity limits), ``end_tool_position_m``
(executed tool point at the end, robot base frame), ``dmp_vs_reference_rmse_rad`` (DMP rollout vs the
retargeted or recorded joints, on the same time grid), ``executed_vs_dmp_rmse_rad`` (PyBullet vs the
trajectory it was commanded: the refined one when refining), ``limit_violations`` (executed samples outside
the position limits or above the velocity limits), ``refine`` (None, or :meth:`Refinement.summary`), plus
the source's own entries.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .results import DMPFit
from .settings import ImitationSettings

__all__ = ["limit_violations", "write_common_outputs"]


def limit_violations(robot, t: np.ndarray, q: np.ndarray, slack: float = 1e-3) -> int:
    """Samples of ``q (T, n)`` at ``t (T,)`` outside the position limits (``slack`` rad) or whose speed
    from the previous sample exceeds the velocity limits by more than 5 %."""
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    outside = ((q < lo - slack) | (q > hi + slack)).any(axis=1)
    speed = np.abs(np.diff(q, axis=0)) / np.diff(t)[:, None]
    fast = np.concatenate([[False], (speed > 1.05 * robot.velocity_limits.numpy()).any(axis=1)])
    return int((outside | fast).sum())


def _plot_refinement(path: Path, refinement) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from lfd.io.files import write_bytes_atomic

    rollouts = [h["rollouts"] for h in refinement.history]
    fig, (ax_cost, ax_error) = plt.subplots(1, 2, figsize=(9, 3.2), constrained_layout=True)
    ax_cost.semilogy(rollouts, [max(h["cost"], 1e-12) for h in refinement.history], marker=".")
    ax_cost.set(
        xlabel="rollouts", ylabel="cost (task + shape)", title=f"{refinement.method}: cost per iteration"
    )
    ax_error.plot(rollouts, [100 * h["task_error_m"] for h in refinement.history], marker=".")
    ax_error.axhline(1.0, color="gray", linestyle="--", linewidth=1)
    ax_error.set(xlabel="rollouts", ylabel="task error (cm)", title=f"{refinement.task}")
    import io

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    write_bytes_atomic(path, buffer.getvalue())


def write_common_outputs(
    settings: ImitationSettings,
    out: Path,
    robot,
    *,
    source: str,
    source_type: str,
    t_source: np.ndarray,
    q_reference: np.ndarray,
    fit: DMPFit,
    q_commanded: np.ndarray,
    q_exec: np.ndarray,
    refinement=None,
    extra: dict | None = None,
) -> dict:
    """Write ``robot_trajectory.csv``, ``robot_trajectory.bag`` (or a ROS 2 bag folder, ``settings.outputs.bag``),
    ``refinement.png`` when refining, and ``summary.json``; returns the summary.

    Args:
        t_source: ``(T,)`` s, the demonstration's own times. q_reference: ``(T, n)`` rad, the retargeted or
            recorded joints. fit: the pipeline's :class:`~lfd.imitation.results.DMPFit` (robot time
            ``fit.t_robot``, rollout ``fit.q_dmp``). q_commanded: ``(T, n)`` what PyBullet was sent (the DMP
            or the refined rollout). q_exec: ``(T, n)`` executed. extra: entries added to the summary.
    """
    import torch

    from lfd.io.files import write_text_atomic
    from lfd.io.rosbag import write_joint_trajectory

    t = fit.t_robot
    cols = {"time_s": t, "source_time_s": t_source}
    for j, name in enumerate(robot.joint_names):
        cols[f"{name}_reference"] = q_reference[:, j]
        cols[f"{name}_dmp"] = fit.q_dmp[:, j]
        if refinement is not None:
            cols[f"{name}_refined"] = q_commanded[:, j]
        cols[f"{name}_executed"] = q_exec[:, j]
    data = np.column_stack(list(cols.values()))
    write_text_atomic(
        out / "robot_trajectory.csv",
        "\n".join([",".join(cols)] + [",".join(f"{v:.9g}" for v in r) for r in data]) + "\n",
    )
    bag_format = settings.outputs.bag
    if bag_format:
        bag = out / ("robot_trajectory.bag" if bag_format == "ros1" else "robot_trajectory_bag")
        if bag.exists():
            raise FileExistsError(f"{bag} exists; run in a new folder")
        write_joint_trajectory(bag, t - t[0], q_exec, robot.joint_names, format=bag_format)
    if refinement is not None:
        _plot_refinement(out / "refinement.png", refinement)
    end = robot.fk(torch.from_numpy(np.ascontiguousarray(q_exec[-1:])))[0, :3, 3].numpy()
    summary = {
        "source": source,
        "source_type": source_type,
        "robot": robot.name,
        "frames": int(len(t_source)),
        "time_scale": float(fit.factor),
        "dmp_n_basis": int(fit.dmp.n_basis),
        "end_tool_position_m": end.tolist(),
        "dmp_vs_reference_rmse_rad": float(np.sqrt(np.mean((fit.q_dmp - q_reference) ** 2))),
        "executed_vs_dmp_rmse_rad": float(np.sqrt(np.mean((q_exec - q_commanded) ** 2))),
        "limit_violations": limit_violations(robot, t, q_exec),
        "refine": None if refinement is None else refinement.summary(),
        **(extra or {}),
    }
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=1) + "\n")
    return summary
