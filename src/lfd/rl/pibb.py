"""PI^BB (Stulp & Sigaud 2012): black-box PI^2 with covariance matrix adaptation, on DMP parameters.

One iteration, with the same harness and exploration units as :func:`lfd.rl.power`:

1. sample ``theta_k = theta + eps_k``, ``eps_k ~ N(0, Sigma)``, ``k = 1..n``;
2. costs ``J_k = -ln Q_k`` (``Q_k`` the penalised return, so ``J`` is the task's summed
   cost for the ``exp(-cost)`` rewards of :mod:`lfd.rl.rewards`);
3. probabilities ``P_k = exp(-h (J_k - min J) / (max J - min J)) / sum_l ...`` (``h = 10``);
4. ``theta <- sum_k P_k theta_k`` and covariance adaptation
   ``Sigma <- sum_k P_k eps_k eps_k^T`` (diagonal here, as dmpbbo's default updater for
   large parameter vectors, since ``n = 10`` samples cannot estimate a 140 x 140
   covariance), kept within ``variance_bounds`` times the initial variance.

Exploration is expressed in trajectory units, per parameter (``sigma / a_p``, see
:meth:`lfd.rl.problem.SearchProblem.scale`), from the initial policy.
"""

from __future__ import annotations

import numpy as np

from lfd.checks import check_float

from .problem import PowerResult, Recorder, SearchProblem, check_common, check_variance_bounds

__all__ = ["pibb"]


def pibb(
    dmp,
    reward,
    *,
    weights=None,
    goal=None,
    y0=None,
    t=None,
    n_rollouts: int = 10,
    max_iter: int = 100,
    sigma: float = 0.01,
    sigma_goal: float = 0.0,
    eliteness: float = 10.0,
    variance_bounds: tuple[float, float] = (0.01, 4.0),
    error=None,
    tol: float | None = None,
    lower=None,
    upper=None,
    limit_penalty: float = 100.0,
    seed: int | None = None,
) -> PowerResult:
    """Improve a DMP's weights (and optionally its goal) with PI^BB; see the module docstring.

    Args:
        dmp, reward, weights, goal, y0, t, error, tol, lower, upper, limit_penalty, seed,
        n_rollouts, max_iter, sigma, sigma_goal: as for :func:`lfd.rl.power`.
        eliteness: ``h`` of the cost-to-probability mapping (> 0).
        variance_bounds: ``(low, high)`` bounds of the adapted variance relative to the initial one.

    Returns:
        :class:`lfd.rl.PowerResult`.

    Example::

        result = pibb(dmp, ObstacleReward(centre, 0.1, goal=dmp.goal_), tol=0.01, seed=0)
    """
    n_rollouts, max_iter = check_common(n_rollouts, max_iter)
    sigma = check_float(sigma, "sigma", low=0.0)
    sigma_goal = check_float(sigma_goal, "sigma_goal", low=0.0)
    eliteness = check_float(eliteness, "eliteness", low=0.0, strict_low=True)
    low, high = check_variance_bounds(variance_bounds)
    problem = SearchProblem(dmp, reward, weights=weights, goal=goal, y0=y0, t=t, explore_goal=sigma_goal > 0.0,
                            error=error, tol=tol, lower=lower, upper=upper, limit_penalty=limit_penalty)  # fmt: skip
    rng = np.random.default_rng(seed)
    theta = problem.theta0.copy()
    scale = problem.scale(theta)
    base = np.concatenate([np.full(problem.split, sigma), np.full(theta.size - problem.split, sigma_goal)])
    std0 = np.divide(base, scale, out=np.zeros_like(scale), where=scale > 0)
    variance = np.square(std0)
    recorder = Recorder(problem, theta)
    iteration = 0
    while iteration < max_iter and not recorder.done():
        iteration += 1
        eps = rng.standard_normal((n_rollouts, theta.size)) * np.sqrt(variance)
        _, returns = recorder.samples(theta + eps)
        costs = -np.log(np.maximum(returns, 1e-300))
        spread = costs.max() - costs.min()
        probabilities = (
            np.exp(-eliteness * (costs - costs.min()) / spread) if spread > 0 else np.ones(n_rollouts)
        )
        probabilities /= probabilities.sum()
        theta = theta + probabilities @ eps
        variance = np.clip(probabilities @ np.square(eps), low * np.square(std0), high * np.square(std0))
        ratio = np.divide(variance, np.square(std0), out=np.ones_like(variance), where=std0 > 0)
        recorder.policy(theta, returns, float(np.sqrt(np.mean(ratio))))
    return recorder.result(iteration)
