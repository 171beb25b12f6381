"""Policy search for DMP skills: PoWER, PI^BB, CMA-ES (pure numpy/torch, no simulator inside).

Main entry points (one harness, :class:`SearchProblem`: same parameters, rollouts, rollout
counting and stopping rule; see ``docs/power.md``):

- :func:`power`: PoWER on the weights (and optionally the goal) of a fitted
  :class:`lfd.dmp.DMP`: ``variant="per-step"`` (Kober & Peters, default), ``"episodic"`` or
  ``"pyrdmp"`` (the published pyrdmp code), with batched rollouts, importance sampling over
  the best rollouts seen so far, variance adaptation, joint-limit penalties and a stopping rule.
- :func:`pibb` (Stulp & Sigaud's PI^BB) and :func:`cmaes` (Hansen's CMA-ES, scaled coordinates).
- :func:`adapt_to_goal`: adapt a learned DMP to a new goal in joint space (rad) or task
  space (m, through the robot's IK/FK), then refine it with PoWER; :func:`refine` fits
  a DMP to a joint trajectory and refines it towards a task-space goal.
- Rewards (the thesis's eq. 5.4): :class:`JointGoalReward`, :class:`TaskGoalReward`,
  :func:`returns_from_distances`; via points and obstacles with per-step returns-to-go:
  :class:`ViaPointReward`, :class:`ObstacleReward`; any
  ``reward(trajectories (B, T, D)) -> (B,)`` works.

Example::

    import numpy as np
    from lfd.dmp import DMP
    from lfd.rl import JointGoalReward, power

    t = np.linspace(0.0, 1.0, 200)
    s = t / t[-1]
    demo = (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None] * np.array([1.0, -0.5])   # (T, 2) rad
    dmp = DMP(n_basis=20).fit(t, demo)
    new_goal = np.array([1.2, -0.3])
    result = power(dmp, JointGoalReward(new_goal), sigma_goal=0.05, tol=0.01, seed=0)
    result.converged, result.goal, result.rollouts
"""

from .adapt import adapt_to_goal, goal_configuration, refine
from .cmaes import cmaes
from .memory import keep_best
from .pibb import pibb
from .power import POWER_VARIANTS, power
from .problem import PowerHistory, PowerResult, SearchProblem
from .rewards import (
    JointGoalReward,
    ObstacleReward,
    TaskGoalReward,
    ViaPointReward,
    limit_violation,
    returns_from_distances,
)
from .rollout import DMPRollout

__all__ = [
    "POWER_VARIANTS",
    "DMPRollout",
    "JointGoalReward",
    "ObstacleReward",
    "PowerHistory",
    "PowerResult",
    "SearchProblem",
    "TaskGoalReward",
    "ViaPointReward",
    "adapt_to_goal",
    "cmaes",
    "goal_configuration",
    "keep_best",
    "limit_violation",
    "pibb",
    "power",
    "refine",
    "returns_from_distances",
]
