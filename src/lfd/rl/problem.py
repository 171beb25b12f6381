"""The shared harness of the policy searches (PoWER, PI^BB, CMA-ES): parameters, rollouts, returns, stopping.

Every search in :mod:`lfd.rl` optimises the same parameter vector of a fitted
:class:`lfd.dmp.DMP`, ``theta = [weights.ravel() (D * K), goal (D)]`` (the goal part only
when it is explored), evaluates perturbed parameters as one batch of rollouts
(:class:`lfd.rl.DMPRollout`), and stops with the same rule: the policy's error (the
reward's ``error``, e.g. the terminal or via-point distance) is ``<= tol`` and the rollout
stays within the joint limits. Every search counts one rollout per evaluated parameter
vector, the evaluation of the updated policy (which decides the stopping rule) included, so
the rollout counts of different searches compare directly.

Exploration is expressed in trajectory units: :meth:`SearchProblem.scale` gives, for each
parameter, the largest trajectory displacement (units of ``y``) of a unit change, per basis
(late bases, faded by the phase, get proportionally larger weight changes) and with a floor
on the goal displacement of goal-scaled DMPs, so no DoF and no basis is ever frozen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lfd.checks import check_float, check_int, finite_array, to_numpy

from .rewards import limit_violation
from .rollout import DMPRollout

__all__ = ["PowerHistory", "PowerResult", "SearchProblem"]

#: Floor of ``|g - y0|`` in the exploration scale of goal-scaled DMPs, as a fraction of the
#: largest ``|g - y0|`` over the DoF (and at least ``1e-3`` in the units of ``y``).
GOAL_FLOOR = 0.1


@dataclass(frozen=True)
class PowerHistory:
    """Per-iteration record. Row 0 is the initial policy, row ``i`` iteration ``i``.

    Attributes:
        policy_return: ``(I + 1,)`` return of the policy after the row's update (penalised).
        best_return: ``(I + 1,)`` best return among the row's exploratory rollouts.
        mean_return: ``(I + 1,)`` mean return of the row's exploratory rollouts.
        error: ``(I + 1,)`` error of the policy (NaN without an error function).
        rollouts: ``(I + 1,)`` rollouts used so far (exploration and policy evaluations).
        exploration: ``(I + 1,)`` exploration of the row relative to the initial one (RMS
            over the parameters of the standard deviation, or CMA-ES's step size), 0 for row 0.

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
    """Outcome of a policy search (:func:`lfd.rl.power`, :func:`lfd.rl.pibb`, :func:`lfd.rl.cmaes`).

    Attributes:
        weights: ``(D, K)`` adapted forcing weights.
        goal: ``(D,)`` adapted goal (equal to the initial goal unless it was explored).
        trajectory: ``(T, D)`` rollout of the adapted policy.
        policy_return: return of that rollout (after the joint-limit penalty).
        error: its error (NaN without an error function).
        within_limits: whether that rollout stays within the joint limits (True without limits).
        converged: the stopping rule was met (always False without ``tol``).
        iterations: iterations run.
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


#: Name used by the searches other than PoWER.
SearchResult = PowerResult


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


class SearchProblem:
    """Rollouts, penalised returns, errors and the stopping rule for parameter vectors ``theta``.

    Args:
        dmp: fitted :class:`lfd.dmp.DMP` (one demonstration); not modified.
        reward: ``reward(trajectories (B, T, D)) -> (B,)`` finite non-negative returns. If it
            has a ``per_step(trajectories) -> (B, T)`` method (rewards per sample, summing to
            the return), per-step PoWER uses it for the returns-to-go.
        weights: ``(D, K)`` initial weights (default ``dmp.weights_``).
        goal: ``(D,)`` initial goal (default ``dmp.goal_``).
        y0: ``(D,)`` start (default ``dmp.y0_``). t: ``(T,)`` time grid (s), default the DMP's.
        explore_goal: the goal is part of ``theta`` (after the weights).
        error: ``error(trajectories (B, T, D)) -> (B,)``; default ``reward.error`` if any.
        tol: stopping tolerance on the error (> 0) or ``None`` (never converge).
        lower, upper: ``(D,)`` joint limits (rad, ``+-inf`` for unbounded joints) or ``None``.
        limit_penalty: returns are multiplied by ``exp(-limit_penalty * v)``, ``v`` the
            largest violation (rad), 1/rad, >= 0.
        per_basis: exploration scale per basis (default); ``False`` scales every basis of a
            DoF like its most influential (earliest) one, as before (late bases barely explore).
    """

    def __init__(self, dmp, reward, *, weights=None, goal=None, y0=None, t=None, explore_goal=False, error=None,
                 tol=None, lower=None, upper=None, limit_penalty=100.0, per_basis=True):  # fmt: skip
        if not callable(reward):
            raise ValueError(f"reward must be callable, got {type(reward).__name__}")
        self.rollout = DMPRollout(dmp, t=t, y0=y0)
        self.n_dof, self.n_basis = self.rollout.n_dof, self.rollout.n_basis
        self.weights0 = finite_array(dmp.weights_ if weights is None else weights, "weights",
                                        shape=(self.n_dof, self.n_basis))  # fmt: skip
        self.goal0 = finite_array(dmp.goal_ if goal is None else goal, "goal", shape=(self.n_dof,))
        self.reward = reward
        self.per_step_reward = getattr(reward, "per_step", None)
        self.reward_to_go = getattr(reward, "returns_to_go", None)
        #: whether the reward gives per-step information (else per-step PoWER is episodic, exactly)
        self.has_returns_to_go = self.reward_to_go is not None or self.per_step_reward is not None
        self.error = getattr(reward, "error", None) if error is None else error
        if self.error is not None and not callable(self.error):
            raise ValueError(f"error must be callable, got {type(self.error).__name__}")
        if tol is not None:
            tol = check_float(tol, "tol", low=0.0, strict_low=True)
            if self.error is None:
                raise ValueError(
                    "tol needs an error function: pass error=... or a reward with an error method"
                )
        self.tol = tol
        self.lower, self.upper = _limits(lower, upper, self.n_dof)
        self.limit_penalty = check_float(limit_penalty, "limit_penalty", low=0.0)
        self.explore_goal = bool(explore_goal)
        self.per_basis = bool(per_basis)
        self.split = self.n_dof * self.n_basis
        self.theta0 = (
            np.concatenate([self.weights0.ravel(), self.goal0])
            if self.explore_goal
            else self.weights0.ravel()
        )
        self.size = self.theta0.size
        displacement = np.abs(self.goal0 - self.rollout.y0)
        self.goal_floor = max(GOAL_FLOOR * float(displacement.max(initial=0.0)), 1e-3)

    def unpack(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(B, P)`` parameters -> weights ``(B, D, K)`` and goals ``(B, D)``."""
        weights = theta[:, : self.split].reshape(-1, self.n_dof, self.n_basis)
        goals = (
            theta[:, self.split :]
            if self.explore_goal
            else np.broadcast_to(self.goal0, (theta.shape[0], self.n_dof))
        )
        return weights, goals

    def goal_of(self, theta: np.ndarray) -> np.ndarray:
        """``(D,)`` goal of one parameter vector ``(P,)``."""
        return theta[self.split :] if self.explore_goal else self.goal0

    def scale(self, theta: np.ndarray) -> np.ndarray:
        """``(P,)`` trajectory displacement (units of ``y``) per unit change of each parameter at ``theta``.

        Weights: :meth:`lfd.rl.DMPRollout.basis_scale` at ``theta``'s goal, with the goal
        displacement floored at :data:`GOAL_FLOOR` times the largest initial one; goal
        entries: 1 (a goal change moves the end point by as much).
        """
        weights = self.rollout.basis_scale(self.goal_of(theta), floor=self.goal_floor)
        if not self.per_basis:  # the earliest (most influential) basis' scale for every basis
            weights = np.broadcast_to(weights.max(axis=1, keepdims=True), weights.shape)
        weights = weights.ravel()
        return np.concatenate([weights, np.ones(self.n_dof)]) if self.explore_goal else weights

    def _penalise(self, trajectories: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        violation = np.zeros(trajectories.shape[0])
        if self.lower is not None:
            violation = limit_violation(trajectories, self.lower, self.upper)
            factor = np.exp(-self.limit_penalty * violation)
            values = values * (factor if values.ndim == 1 else factor[:, None])
        return values, violation

    def _check_returns(self, values: np.ndarray, shape: tuple, name: str) -> np.ndarray:
        values = np.asarray(values, dtype=np.float64)
        if values.shape != shape or not np.all(np.isfinite(values)) or np.any(values < 0):
            raise ValueError(
                f"{name} must return finite non-negative values of shape {shape}, got shape {values.shape} "
                f"with min {np.min(values, initial=np.inf)}"
            )
        return values

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Trajectories ``(B, T, D)``, penalised returns ``(B,)`` and limit violations ``(B,)`` (rad)."""
        trajectories = self.rollout(*self.unpack(theta))
        returns = self._check_returns(self.reward(trajectories), theta.shape[:1], "reward")
        returns, violation = self._penalise(trajectories, returns)
        return trajectories, returns, violation

    def returns_to_go(self, trajectories: np.ndarray, returns: np.ndarray) -> np.ndarray:
        """``(B, T)`` penalised returns-to-go ``Q(t) = sum_{t' >= t} r(t')``.

        From the reward's ``returns_to_go`` when it has one, else from its ``per_step``
        rewards; otherwise every ``Q(t)`` is the episode's return (the episodic case).
        """
        shape = trajectories.shape[:2]
        if self.reward_to_go is not None:
            q = self._check_returns(self.reward_to_go(trajectories), shape, "reward.returns_to_go")
            return self._penalise(trajectories, q)[0]
        if self.per_step_reward is None:
            return np.repeat(returns[:, None], trajectories.shape[1], axis=1)
        rewards = self._check_returns(self.per_step_reward(trajectories), shape, "reward.per_step")
        rewards, _ = self._penalise(trajectories, rewards)
        return np.cumsum(rewards[:, ::-1], axis=1)[:, ::-1]

    def policy_error(self, trajectory: np.ndarray) -> float:
        """Error of one rollout ``(1, T, D)``; NaN without an error function."""
        if self.error is None:
            return float("nan")
        value = np.asarray(self.error(trajectory), dtype=np.float64)
        if value.shape != (1,) or not np.isfinite(value[0]):
            raise ValueError(f"error must return one finite value per trajectory, got {value!r}")
        return float(value[0])

    def converged(self, error: float, violation: float) -> bool:
        """The stopping rule: ``error <= tol`` and no joint-limit violation."""
        return self.tol is not None and error <= self.tol and violation == 0.0


class Recorder:
    """Evaluates policies, counts rollouts and keeps the history rows of one search."""

    def __init__(self, problem: SearchProblem, theta: np.ndarray):
        self.problem = problem
        self.rollouts = 0
        self.rows: list[tuple] = []
        self.policy(theta, None, 0.0)

    def samples(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Evaluate exploratory parameters ``(B, P)``: trajectories and penalised returns (counted)."""
        trajectories, returns, _ = self.problem.evaluate(theta)
        self.rollouts += theta.shape[0]
        return trajectories, returns

    def policy(self, theta: np.ndarray, sample_returns, exploration: float) -> float:
        """Evaluate the policy ``(P,)`` after an update (counted), record the row; returns its return."""
        trajectory, returns, violation = self.problem.evaluate(theta[None])
        self.rollouts += 1
        self.theta, self.trajectory, self.violation = theta, trajectory[0], float(violation[0])
        self.policy_return = float(returns[0])
        self.error = self.problem.policy_error(trajectory)
        if sample_returns is None:
            sample_returns = returns
        self.rows.append((self.policy_return, sample_returns.max(), sample_returns.mean(), self.error, self.rollouts,
                          exploration))  # fmt: skip
        return self.policy_return

    def done(self) -> bool:
        return self.problem.converged(self.error, self.violation)

    def result(self, iterations: int) -> PowerResult:
        columns = [np.array(column) for column in zip(*self.rows)]
        history = PowerHistory(*columns[:4], columns[4].astype(np.int64), columns[5])
        weights, goal = self.problem.unpack(self.theta[None])
        return PowerResult(
            weights=weights[0].copy(),
            goal=np.array(goal[0], dtype=np.float64),
            trajectory=self.trajectory,
            policy_return=self.policy_return,
            error=self.error,
            within_limits=self.violation == 0.0,
            converged=self.done(),
            iterations=iterations,
            rollouts=self.rollouts,
            history=history,
        )


def check_common(n_rollouts, max_iter) -> tuple[int, int]:
    """Validated ``n_rollouts >= 1`` and ``max_iter >= 0``."""
    return check_int(n_rollouts, "n_rollouts", minimum=1), check_int(max_iter, "max_iter", minimum=0)


def check_variance_bounds(bounds) -> tuple[float, float]:
    """Validated ``(low, high)`` relative variance bounds with ``0 < low <= 1 <= high``."""
    try:
        low, high = (check_float(v, "variance_bounds", low=0.0) for v in bounds)
    except TypeError as exc:
        raise ValueError(f"variance_bounds must be a pair (low, high), got {bounds!r}") from exc
    if not 0.0 < low <= 1.0 <= high:
        raise ValueError(f"variance_bounds must satisfy 0 < low <= 1 <= high, got {bounds}")
    return low, high
