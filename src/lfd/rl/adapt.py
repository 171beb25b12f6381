"""Adapt a learned DMP to a new goal: set its goal, then refine it with PoWER.

Joint space: the DMP's goal parameter becomes the new goal (rad) and the reward is
eq. 5.4 on the joint vector. Task space: the goal parameter becomes an IK solution for
the target (the full pose if one is given, position only if that fails or if only a
position is given), seeded with the demonstrated final configuration so the solution stays
close to the demonstration; the reward is eq. 5.4 on the end-effector position from FK.

:func:`refine` is the third use: fit a DMP to a joint trajectory that ends near a
task-space goal (e.g. the closed-loop reach of learned models) and let PoWER bring its end
effector to the goal.

In all cases PoWER then refines the weights and the goal (a DMP rollout ends close to,
but not exactly at, its goal, and an IK solution may miss an unreachable target), with
the robot's joint limits as a penalty (see :func:`lfd.rl.power`): the return of a rollout
whose largest violation is ``v`` rad is multiplied by ``exp(-limit_penalty * v)`` and a
policy outside the limits never counts as converged.
"""

from __future__ import annotations

import warnings

import numpy as np

from lfd.checks import finite_array, to_numpy
from lfd.dmp import DMP

from .power import PowerResult, power
from .rewards import JointGoalReward, TaskGoalReward

__all__ = ["adapt_to_goal", "goal_configuration", "refine"]


def _robot_limits(robot) -> tuple[np.ndarray, np.ndarray]:
    """``(D,)`` lower and upper limits (rad) of ``robot``; continuous joints are unbounded."""
    lower = to_numpy(robot.lower).astype(np.float64)
    upper = to_numpy(robot.upper).astype(np.float64)
    continuous = getattr(robot, "continuous", None)
    if continuous is not None:
        free = to_numpy(continuous).astype(bool)
        lower[free], upper[free] = -np.inf, np.inf
    return lower, upper


def goal_configuration(robot, target, q0) -> np.ndarray:
    """Joint configuration (rad) that puts the robot's tool at a task-space target.

    Args:
        robot: :class:`lfd.robots.Robot` (``ik``).
        target: ``(3,)`` tool position or ``(4, 4)`` tool pose (m), world frame.
        q0: ``(D,)`` initial guess (rad), e.g. the demonstration's final configuration.

    Returns:
        ``(D,)`` IK solution within the joint limits. A pose target is solved with its
        orientation first and position only if that fails; an unreachable target gives
        the IK's best effort (check it with ``robot.fk``).
    """
    target = finite_array(target, "target")
    if target.shape not in ((3,), (4, 4)):
        raise ValueError(f"target must be a (3,) position or a (4, 4) pose, got shape {target.shape}")
    q0 = finite_array(q0, "q0", shape=(robot.n_dof,))
    solution = robot.ik(target[None], q0)
    if target.shape == (4, 4) and not bool(solution.success[0]):
        solution = robot.ik(target[None, :3, 3], q0)
    return to_numpy(solution.q[0]).astype(np.float64)


def adapt_to_goal(
    dmp,
    goal,
    *,
    robot=None,
    space: str = "joint",
    w1: float = 0.99,
    tol: float = 0.01,
    sigma: float = 0.02,
    sigma_goal: float = 0.02,
    **power_options,
) -> PowerResult:
    """Adapt a fitted DMP to a new goal and refine it with PoWER until the goal is reached.

    Args:
        dmp: fitted :class:`lfd.dmp.DMP` (``D`` joints); not modified.
        goal: joint space: ``(D,)`` goal (rad). Task space: ``(3,)`` tool position or
            ``(4, 4)`` tool pose (m); only the position enters the reward.
        robot: :class:`lfd.robots.Robot`; required in task space. When given, its joint
            limits are enforced (continuous joints unbounded; ``lower``/``upper`` in
            ``power_options`` take precedence) and a joint-space goal must lie within them.
        space: ``"joint"`` or ``"task"``.
        w1: terminal weight of the eq. 5.4 reward, in ``[0, 1]``. Keep it close to 1: when
            the goal is explored, the running part prefers arriving early to arriving
            exactly (see :mod:`lfd.rl.rewards`).
        tol: terminal error at which PoWER stops (rad in joint space, m in task space).
        sigma, sigma_goal: weight and goal exploration of :func:`lfd.rl.power` (rad).
        **power_options: further keyword arguments of :func:`lfd.rl.power`
            (``n_rollouts``, ``n_best``, ``max_iter``, ``seed``, ``limit_penalty``, ...).

    Returns:
        :class:`lfd.rl.PowerResult`; ``result.goal`` is the adapted DMP goal (rad).
    """
    if space not in ("joint", "task"):
        raise ValueError(f"space must be 'joint' or 'task', got {space!r}")
    if not getattr(dmp, "is_fitted", False):
        raise ValueError("dmp must be fitted (call DMP.fit first)")
    n_dof = np.shape(dmp.goal_)[-1]
    if robot is not None:
        if robot.n_dof != n_dof:
            raise ValueError(f"robot has {robot.n_dof} joints but the DMP has {n_dof} DoF")
        lower, upper = _robot_limits(robot)
        power_options.setdefault("lower", lower)
        power_options.setdefault("upper", upper)
    if space == "joint":
        joint_goal = finite_array(goal, "goal", shape=(n_dof,))
        if robot is not None and not bool(robot.within_limits(joint_goal[None])[0]):
            raise ValueError(f"goal {joint_goal} lies outside the joint limits of robot {robot.name!r}")
        reward = JointGoalReward(joint_goal, w1)
    else:
        if robot is None:
            raise ValueError("robot is required for a task-space goal")
        target = finite_array(goal, "goal")
        if target.shape not in ((3,), (4, 4)):
            raise ValueError(
                f"goal must be a (3,) position or a (4, 4) pose in task space, got shape {target.shape}"
            )
        joint_goal = goal_configuration(robot, target, dmp.goal_)
        reward = TaskGoalReward(robot, target if target.shape == (3,) else target[:3, 3], w1)
    return power(dmp, reward, goal=joint_goal, tol=tol, sigma=sigma, sigma_goal=sigma_goal, **power_options)


def refine(
    robot, t, q, goal, n_basis: int = 20, w1: float = 0.9, seed: int = 0, **power_options
) -> PowerResult:
    """Fit a DMP (``n_basis`` per joint) to ``q (T, n)`` at times ``t (T,)`` and refine it
    with PoWER (weights and goal) towards the end-effector position ``goal (3,)`` (m).

    Args:
        robot: :class:`lfd.robots.Robot`; its joint limits are enforced (continuous joints
            unbounded) and its FK gives the eq. 5.4 reward (:class:`~lfd.rl.TaskGoalReward`).
        t, q: the trajectory to start from, seconds and rad.
        goal: ``(3,)`` tool position (m), world frame.
        n_basis: DMP basis functions per joint.
        w1: terminal weight of the reward.
        seed: seed of PoWER's exploration.
        **power_options: further :func:`lfd.rl.power` options (``n_rollouts``, ``n_best``,
            ``max_iter``, ``sigma``, ``sigma_goal``, ``tol``, ...).

    Returns:
        :class:`lfd.rl.PowerResult` (``trajectory``, ``converged``, ``iterations``, ``history``).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # joints that move and return are expected here
        dmp = DMP(n_basis=n_basis).fit(np.asarray(t, dtype=np.float64), np.asarray(q, dtype=np.float64))
    reward = TaskGoalReward(robot, goal, w1)
    lower, upper = _robot_limits(robot)
    return power(dmp, reward, lower=lower, upper=upper, seed=seed, **power_options)
