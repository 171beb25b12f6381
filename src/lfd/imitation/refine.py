"""Refine an imitated skill by policy search (PoWER, PI^BB or CMA-ES from :mod:`lfd.rl`) for a task.

The rollout cost is :class:`lfd.rl.skill.SkillReward`: a task term (reach a target, pass a via point, keep
clear of a point) plus a term that keeps the joint trajectory close to the demonstrated one. The search stops
once the task error is within ``tol`` (m) or the rollout budget is spent.

Example::

    from lfd.imitation.refine import refine_skill
    result = refine_skill(robot, dmp, task="reach", target=[0.4, -0.2, 0.3], method="power", seed=0)
    result.task_error_m, result.shape_rmse_rad, result.rollouts, result.converged
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

__all__ = ["METHODS", "Refinement", "check_reachable", "refine_skill"]

#: Policy searches a skill can be refined with.
METHODS = ("power", "pibb", "cmaes")


@dataclass(frozen=True)
class Refinement:
    """Outcome of :func:`refine_skill`.

    Attributes:
        task, method: as asked. target: ``(3,)`` m.
        t: ``(T,)`` s, the DMP's time grid. reference: ``(T, D)`` rad, the DMP before refinement.
        trajectory: ``(T, D)`` rad, the refined rollout. weights, goal: the refined DMP parameters.
        task_error_m, shape_rmse_rad: the two terms of the refined rollout.
        rollouts, iterations, converged: of the search (converged: task error within ``tol`` and in limits).
        history: per iteration (0 = before) ``{"iteration", "rollouts", "cost", "task_error_m"}``; the cost is
            ``-log`` of the policy's return: task plus shape term plus any joint-limit penalty.
    """

    task: str
    method: str
    target: np.ndarray
    t: np.ndarray
    reference: np.ndarray
    trajectory: np.ndarray
    weights: np.ndarray
    goal: np.ndarray
    task_error_m: float
    shape_rmse_rad: float
    rollouts: int
    iterations: int
    converged: bool
    history: list = field(default_factory=list)

    def summary(self) -> dict:
        """The ``refine`` entry of the pipeline's ``summary.json``."""
        return {
            "task": self.task,
            "method": self.method,
            "target_m": self.target.tolist(),
            "rollouts": self.rollouts,
            "iterations": self.iterations,
            "task_error_m": self.task_error_m,
            "shape_rmse_rad": self.shape_rmse_rad,
            "converged": self.converged,
        }


def check_reachable(robot, target, q0, name: str = "refine.target", tol: float = 0.01) -> np.ndarray:
    """The joint configuration (rad) that puts ``robot``'s tool at ``target (3,)`` m, found by IK from ``q0``.

    Raises:
        ValueError: ``target`` is not 3 finite numbers, or the closest the IK gets is farther than ``tol``.
    """
    from lfd.rl import goal_configuration

    target = np.asarray(target, dtype=np.float64)
    if target.shape != (3,) or not np.isfinite(target).all():
        raise ValueError(
            f"{name} must be a tool position [x, y, z] in metres, got {np.asarray(target).tolist()}"
        )
    q = goal_configuration(robot, target, np.asarray(q0, dtype=np.float64))
    reached = robot.fk(torch.from_numpy(q[None]))[0, :3, 3].numpy()
    miss = float(np.linalg.norm(reached - target))
    if miss > tol:
        raise ValueError(
            f"{name} {target.round(3).tolist()} is out of reach of {robot.name}: the closest its tool gets is "
            f"{miss:.3f} m away; choose a target within reach"
        )
    return q


def refine_skill(
    robot,
    dmp,
    *,
    task: str,
    target,
    method: str = "power",
    tol: float = 0.01,
    max_rollouts: int = 400,
    shape_weight: float = 0.1,
    t_via: float | None = None,
    radius: float = 0.05,
    goal_init: str = "demo",
    seed: int = 0,
    progress: bool = False,
    **search_options,
) -> Refinement:
    """Refine the fitted ``dmp`` of ``robot`` (``D`` joints) for ``task`` (:data:`lfd.rl.skill.SKILL_TASKS`).

    Args:
        robot: :class:`lfd.robots.Robot`; its joint limits are enforced and its FK gives the task term.
        dmp: fitted :class:`lfd.dmp.DMP`; not modified.
        task, target, t_via, radius, shape_weight: see :class:`lfd.rl.skill.SkillReward` (``target`` m, robot
            base frame; ``t_via`` s on the DMP's time grid).
        method: one of :data:`METHODS`.
        tol: task error (m) at which the search stops.
        max_rollouts: rollout budget (>= 2).
        goal_init: reach only: ``"ik"`` starts the search from the DMP moved to the IK solution of the target
            (a DMP ends at its goal, so this often meets ``tol`` at once; the search then only has to keep
            it there); ``"demo"`` starts from the demonstrated goal and lets the search move it.
        seed: exploration seed.
        progress: show a progress bar over the rollouts (stderr).
        **search_options: further options of the search (``sigma``, ``n_rollouts``, ...).

    Returns:
        :class:`Refinement`.

    Raises:
        ValueError: an unknown task or method, a bad budget, or a target out of reach (reach and via point:
            checked by IK before any rollout).
    """
    from lfd.rl import cmaes, pibb, power
    from lfd.rl.adapt import _robot_limits
    from lfd.rl.skill import SKILL_TASKS, SkillReward

    if method not in METHODS:
        raise ValueError(f"refine.method must be one of {METHODS}, got {method!r}")
    if task not in SKILL_TASKS:
        raise ValueError(f"refine.task must be one of {SKILL_TASKS}, got {task!r}")
    if goal_init not in ("ik", "demo"):
        raise ValueError(f"refine.goal_init must be 'ik' or 'demo', got {goal_init!r}")
    if int(max_rollouts) < 2:
        raise ValueError(f"refine.max_rollouts must be >= 2, got {max_rollouts}")
    t = np.linspace(0.0, float(dmp.tau_), int(dmp.n_steps_))
    reference = np.asarray(dmp.rollout(t), dtype=np.float64)
    goal = np.asarray(dmp.goal_, dtype=np.float64)
    if task != "avoid":
        q_target = check_reachable(
            robot, target, reference[-1] if task == "reach" else reference[len(t) // 2]
        )
        if task == "reach" and goal_init == "ik":
            goal = q_target

    class CountedReward(SkillReward):  # every call of the reward is one batch of rollouts
        def __call__(self, trajectories):
            bar.update(np.shape(trajectories)[0])
            return super().__call__(trajectories)

    from tqdm.auto import tqdm

    bar = tqdm(
        total=int(max_rollouts), desc=f"refine {task} ({method})", unit="rollout", disable=not progress
    )
    reward = CountedReward(
        robot, task, target, reference, t, t_via=t_via, radius=radius, shape_weight=shape_weight
    )
    lower, upper = _robot_limits(robot)
    explore_goal = task == "reach"
    n_batch = int(search_options.pop("n_rollouts", 10))
    common = dict(goal=goal, t=t, tol=tol, lower=lower, upper=upper, seed=seed)
    if method == "cmaes":
        popsize = int(search_options.pop("popsize", n_batch))
        options = dict(sigma0=0.01, sigma_goal=0.01 if explore_goal else 0.0, popsize=popsize)
        options["max_iter"] = max(1, (int(max_rollouts) - 1) // popsize)
        search = cmaes
    else:
        options = dict(sigma=0.02, sigma_goal=0.02 if explore_goal else 0.0, n_rollouts=n_batch)
        options["max_iter"] = max(1, (int(max_rollouts) - 1) // n_batch)
        search = power if method == "power" else pibb
    try:
        result = search(dmp, reward, **common, **{**options, **search_options})
        if result.converged and bar.n < bar.total:  # the bar ends at 100 % and says why it stopped early
            bar.set_postfix_str(f"converged after {bar.n} of {bar.total} rollouts", refresh=False)
            bar.total = bar.n
            bar.refresh()
    finally:
        bar.close()
    terms = reward.terms(result.trajectory[None])
    h = result.history
    history = [
        {"iteration": i, "rollouts": int(r), "cost": float(-np.log(max(q, 1e-300))), "task_error_m": float(e)}
        for i, (r, q, e) in enumerate(zip(h.rollouts, h.policy_return, h.error, strict=True))
    ]
    return Refinement(
        task=task,
        method=method,
        target=np.asarray(target, dtype=np.float64),
        t=t,
        reference=reference,
        trajectory=np.asarray(result.trajectory),
        weights=np.asarray(result.weights),
        goal=np.asarray(result.goal),
        task_error_m=float(terms["task_error_m"][0]),
        shape_rmse_rad=float(terms["shape_rmse_rad"][0]),
        rollouts=int(result.rollouts),
        iterations=int(result.iterations),
        converged=bool(result.converged),
        history=history,
    )
