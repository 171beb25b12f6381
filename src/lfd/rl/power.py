"""PoWER: Policy learning by Weighting Exploration with the Returns (Kober & Peters), on DMPs.

The policy is a fitted :class:`lfd.dmp.DMP`; its parameters ``theta`` are the forcing
weights ``(D, K)`` and, optionally, the goal ``(D,)``. One iteration:

1. explore: ``theta_k = theta + eps_k``, ``eps_k ~ N(0, diag(sigma^2))``, ``k = 1..K``,
   all ``K`` rollouts evaluated as one batch (:class:`lfd.rl.rollout.DMPRollout`);
2. returns ``Q_k = reward(rollout_k)``, multiplied by ``exp(-limit_penalty * v_k)`` where
   ``v_k`` is the rollout's largest joint-limit violation (rad) when limits are given;
3. importance sampling: every rollout ever evaluated is remembered with its return and
   the ``M`` best of *all* of them are kept (:func:`lfd.rl.memory.keep_best`);
4. update ``theta <- theta + sum_k (theta_k - theta) Q_k / sum_k Q_k`` over the kept ``M``;
5. roll out the updated policy once: its error decides the stopping rule
   (``error <= tol`` and no limit violation) and the rollout joins the memory.

Exploration (the original code drew ``sigma`` from each weight's own magnitude, so a zero
weight never explored). Here every weight of DoF ``d`` gets the same standard deviation
``sigma / a_d``, where ``a_d = |g_d - y0_d| max_{i,t} |dy_d(t) / dw_{d,i}|`` is the largest
trajectory displacement per unit weight (:meth:`lfd.rl.DMPRollout.weight_scale`): a
one-sigma change of any single weight moves the trajectory by at most ``sigma`` (units of
``y``), whatever the weight's value. Exploration is thus uniform in forcing-term units
(the forcing term is ``weights * s * (g - y0)``), so late bases, faded by the phase ``s``,
barely move the end point, which the goal controls: the goal is explored with its own
``sigma_goal`` (units of ``y``). Both shrink by ``sigma_decay`` per iteration and, when
an error function is available, in proportion to the policy's remaining error,
``min(1, max(e_i, tol) / e_0)``, so exploration anneals as the goal is approached (and
stays unchanged while the error is already within ``tol``, e.g. when only joint limits
remain to be fixed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._checks import as_finite_array, check_float, check_int, to_numpy
from .memory import keep_best
from .rewards import limit_violation
from .rollout import DMPRollout

__all__ = ["PowerHistory", "PowerResult", "power"]


@dataclass(frozen=True)
class PowerHistory:
    """Per-iteration record. Row 0 is the initial policy, row ``i`` iteration ``i``.

    Attributes:
        policy_return: ``(I + 1,)`` return of the policy after the row's update (penalised).
        best_return: ``(I + 1,)`` best return among the row's exploratory rollouts.
        mean_return: ``(I + 1,)`` mean return of the row's exploratory rollouts.
        error: ``(I + 1,)`` error of the policy (NaN without an error function).
        rollouts: ``(I + 1,)`` rollouts used so far (exploration and policy evaluations).
        exploration: ``(I + 1,)`` exploration scale of the row relative to ``sigma``
            (``sigma_decay`` and error scaling), 0 for row 0.

    Row 0 has no exploration: its best and mean returns are the initial policy's.
    """

    policy_return: np.ndarray
    best_return: np.ndarray
    mean_return: np.ndarray
    error: np.ndarray
    rollouts: np.ndarray
    exploration: np.ndarray


@dataclass(frozen=True)
class PowerResult:
    """Outcome of :func:`power`.

    Attributes:
        weights: ``(D, K)`` adapted forcing weights.
        goal: ``(D,)`` adapted goal (equal to the initial goal unless ``sigma_goal > 0``).
        trajectory: ``(T, D)`` rollout of the adapted policy.
        policy_return: return of that rollout (after the joint-limit penalty).
        error: its error (NaN without an error function).
        within_limits: whether that rollout stays within the joint limits (True without limits).
        converged: the stopping rule was met (always False without ``tol``).
        iterations: PoWER iterations run.
        rollouts: rollouts used, the initial policy's included.
        history: :class:`PowerHistory`.
    """

    weights: np.ndarray
    goal: np.ndarray
    trajectory: np.ndarray
    policy_return: float
    error: float
    within_limits: bool
    converged: bool
    iterations: int
    rollouts: int
    history: PowerHistory


class _Problem:
    """Rollouts, penalised returns and errors for parameter vectors ``theta = [w.ravel(), g]``."""

    def __init__(self, rollout: DMPRollout, reward, error, lower, upper, limit_penalty: float):
        self.rollout, self.reward, self.error = rollout, reward, error
        self.lower, self.upper, self.limit_penalty = lower, upper, limit_penalty
        self.split = rollout.n_dof * rollout.n_basis

    def unpack(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(B, P)`` parameters -> weights ``(B, D, K)`` and goals ``(B, D)``."""
        weights = theta[:, : self.split].reshape(-1, self.rollout.n_dof, self.rollout.n_basis)
        return weights, theta[:, self.split :]

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Trajectories ``(B, T, D)``, penalised returns ``(B,)`` and limit violations ``(B,)`` (rad)."""
        trajectories = self.rollout(*self.unpack(theta))
        returns = np.asarray(self.reward(trajectories), dtype=np.float64)
        if returns.shape != theta.shape[:1] or not np.all(np.isfinite(returns)) or np.any(returns < 0):
            raise ValueError(
                f"reward must return {theta.shape[0]} finite non-negative returns for trajectories "
                f"{trajectories.shape}, got shape {returns.shape} with min {np.min(returns, initial=np.inf)}"
            )
        violation = np.zeros(theta.shape[0])
        if self.lower is not None:
            violation = limit_violation(trajectories, self.lower, self.upper)
            returns = returns * np.exp(-self.limit_penalty * violation)
        return trajectories, returns, violation

    def policy_error(self, trajectory: np.ndarray) -> float:
        """Error of one rollout ``(1, T, D)``; NaN without an error function."""
        if self.error is None:
            return float("nan")
        value = np.asarray(self.error(trajectory), dtype=np.float64)
        if value.shape != (1,) or not np.isfinite(value[0]):
            raise ValueError(f"error must return one finite value per trajectory, got {value!r}")
        return float(value[0])


def _limits(lower, upper, n_dof: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Validated ``(D,)`` limits (``inf`` allowed for unbounded joints), or ``(None, None)``."""
    if lower is None and upper is None:
        return None, None
    if lower is None or upper is None:
        raise ValueError("lower and upper must be given together")
    bounds = []
    for name, value in (("lower", lower), ("upper", upper)):
        array = to_numpy(value).astype(np.float64)
        if array.shape != (n_dof,) or np.any(np.isnan(array)):
            raise ValueError(f"{name} must have shape ({n_dof},) without NaN, got {array.shape}")
        bounds.append(array)
    if np.any(bounds[0] > bounds[1]):
        raise ValueError("lower must be <= upper for every joint")
    return bounds[0], bounds[1]


def power(
    dmp,
    reward,
    *,
    weights=None,
    goal=None,
    y0=None,
    t=None,
    n_rollouts: int = 10,
    n_best: int = 3,
    max_iter: int = 100,
    sigma: float = 0.02,
    sigma_goal: float = 0.0,
    sigma_decay: float = 1.0,
    scale_by_error: bool = True,
    error=None,
    tol: float | None = None,
    lower=None,
    upper=None,
    limit_penalty: float = 100.0,
    seed: int | None = None,
) -> PowerResult:
    """Improve a DMP's weights (and optionally its goal) with PoWER; see the module docstring.

    Shapes: ``D`` DoF, ``K`` basis functions, ``T`` samples per rollout, ``B`` rollouts.

    Args:
        dmp: fitted :class:`lfd.dmp.DMP` (one demonstration); it is not modified.
        reward: callable ``reward(trajectories (B, T, D)) -> (B,)`` finite non-negative
            returns, e.g. :class:`lfd.rl.JointGoalReward` or :class:`lfd.rl.TaskGoalReward`.
        weights: ``(D, K)`` initial weights (default ``dmp.weights_``).
        goal: ``(D,)`` initial goal (default ``dmp.goal_``).
        y0: ``(D,)`` start (default ``dmp.y0_``). t: ``(T,)`` time grid (s), default the DMP's.
        n_rollouts: exploratory rollouts per iteration ``K`` (>= 1).
        n_best: importance-sampling memory size ``M`` (>= 1): the update averages the ``M``
            best rollouts seen so far. A small ``M`` follows the best rollouts greedily,
            fastest for deterministic rewards (on Sawyer goal changes ``M = 3`` needed 16-20 %
            fewer rollouts than ``M = 5`` and 43 % fewer than ``M = 10``); with noisy returns
            use a larger ``M``, since a lucky rollout stays in the memory.
        max_iter: iteration cap (>= 0).
        sigma: weight exploration, as the largest trajectory displacement (units of ``y``)
            of a one-sigma change of one weight (>= 0). Weights of a DoF whose goal
            equals its start have no effect and are not explored.
        sigma_goal: goal exploration standard deviation (units of ``y``, >= 0; 0 keeps the goal).
        sigma_decay: factor in ``(0, 1]`` applied to the exploration every iteration.
        scale_by_error: scale exploration by ``min(1, max(e_i, tol) / e_0)`` (``tol`` read as 0
            when ``None``) when an error function exists and ``e_0 > tol``.
        error: callable ``error(trajectories (B, T, D)) -> (B,)`` (e.g. terminal distance to
            the goal, rad or m); default ``reward.error`` if the reward has one.
        tol: stopping rule: stop once the policy's error is ``<= tol`` (and it is within the
            limits). ``None``: run ``max_iter`` iterations.
        lower, upper: ``(D,)`` joint limits (rad; ``+-inf`` for unbounded joints). A rollout
            whose largest violation is ``v`` rad has its return multiplied by
            ``exp(-limit_penalty * v)``, and a policy outside the limits never counts as converged.
        limit_penalty: penalty rate (1/rad, >= 0).
        seed: seed of ``numpy.random.default_rng`` (same seed, same result).

    Returns:
        :class:`PowerResult` with the final (not the best-ever) policy.

    Raises:
        ValueError: a bad argument (named in the message), or a reward returning negative
            or non-finite values.
    """
    if not callable(reward):
        raise ValueError(f"reward must be callable, got {type(reward).__name__}")
    rollout = DMPRollout(dmp, t=t, y0=y0)
    n_dof, n_basis = rollout.n_dof, rollout.n_basis
    w0 = as_finite_array(dmp.weights_ if weights is None else weights, "weights", shape=(n_dof, n_basis))
    g0 = as_finite_array(dmp.goal_ if goal is None else goal, "goal", shape=(n_dof,))
    n_rollouts = check_int(n_rollouts, "n_rollouts", minimum=1)
    n_best = check_int(n_best, "n_best", minimum=1)
    max_iter = check_int(max_iter, "max_iter", minimum=0)
    sigma = check_float(sigma, "sigma", low=0.0)
    sigma_goal = check_float(sigma_goal, "sigma_goal", low=0.0)
    sigma_decay = check_float(sigma_decay, "sigma_decay", low=0.0, high=1.0, strict_low=True)
    limit_penalty = check_float(limit_penalty, "limit_penalty", low=0.0)
    if tol is not None:
        tol = check_float(tol, "tol", low=0.0, strict_low=True)
    error = getattr(reward, "error", None) if error is None else error
    if error is not None and not callable(error):
        raise ValueError(f"error must be callable, got {type(error).__name__}")
    if tol is not None and error is None:
        raise ValueError("tol needs an error function: pass error=... or a reward with an error method")
    lower, upper = _limits(lower, upper, n_dof)
    problem = _Problem(rollout, reward, error, lower, upper, limit_penalty)

    amplitude = rollout.weight_scale(g0)
    std_weights = np.divide(sigma, amplitude, out=np.zeros_like(amplitude), where=amplitude > 0)
    std = np.concatenate([np.repeat(std_weights, n_basis), np.full(n_dof, sigma_goal)])
    rng = np.random.default_rng(seed)

    theta = np.concatenate([w0.ravel(), g0])
    trajectory, returns, violation = problem.evaluate(theta[None])
    err = first_err = problem.policy_error(trajectory)
    floor = 0.0 if tol is None else tol  # errors below tol do not shrink exploration further
    memory = keep_best(np.empty((0, theta.size)), np.empty(0), theta[None], returns, n_best)
    rollouts = 1
    rows = [(returns[0], returns[0], returns[0], err, rollouts, 0.0)]

    def done() -> bool:
        return tol is not None and err <= tol and violation[0] == 0.0

    iteration = 0
    while iteration < max_iter and not done():
        iteration += 1
        scale = sigma_decay ** (iteration - 1)
        if scale_by_error and error is not None and first_err > floor:
            scale *= min(1.0, max(err, floor) / first_err)
        samples = theta + rng.standard_normal((n_rollouts, theta.size)) * (std * scale)
        _, sample_returns, _ = problem.evaluate(samples)
        memory = keep_best(*memory, samples, sample_returns, n_best)
        kept, kept_returns = memory
        if kept_returns.sum() > 0.0:  # reward-weighted average of the kept perturbations
            theta = theta + kept_returns @ (kept - theta) / kept_returns.sum()
        trajectory, returns, violation = problem.evaluate(theta[None])
        err = problem.policy_error(trajectory)
        memory = keep_best(*memory, theta[None], returns, n_best)
        rollouts += n_rollouts + 1
        rows.append((returns[0], sample_returns.max(), sample_returns.mean(), err, rollouts, scale))

    columns = [np.array(column) for column in zip(*rows)]
    history = PowerHistory(*columns[:4], columns[4].astype(np.int64), columns[5])
    weights_out, goal_out = problem.unpack(theta[None])
    return PowerResult(
        weights=weights_out[0].copy(),
        goal=goal_out[0].copy(),
        trajectory=trajectory[0],
        policy_return=float(returns[0]),
        error=err,
        within_limits=bool(violation[0] == 0.0),
        converged=done(),
        iterations=iteration,
        rollouts=rollouts,
        history=history,
    )
