"""CMA-ES (Hansen's standard (mu/mu_w, lambda)-CMA-ES) over the same DMP parameters as PoWER.

The search runs in *scaled* coordinates ``x``: parameter ``p`` is ``theta_p = theta0_p +
x_p / a_p`` with ``a_p`` the largest trajectory displacement of a unit change of that
parameter at the initial policy (:meth:`lfd.rl.problem.SearchProblem.scale`), so one unit
of ``x`` moves the trajectory by at most one unit of ``y`` (1 rad in joint space) for every
weight and goal entry: the "well scaled" CMA-ES of the benchmarks. It maximises the
penalised return (only the ranking of returns matters, so any monotone transformation of
the reward gives the same search).

The updates follow Hansen (2016), "The CMA Evolution Strategy: A Tutorial", with its
default parameters: weighted recombination of the ``mu = lambda / 2`` best, cumulative
step-size adaptation, rank-one and rank-mu covariance updates. Each iteration also rolls
out the mean (counted) for the shared stopping rule.
"""

from __future__ import annotations

import math

import numpy as np

from lfd.checks import check_float

from .problem import PowerResult, Recorder, SearchProblem, check_common

__all__ = ["cma_parameters", "cmaes"]


def cma_parameters(n: int, popsize: int) -> dict:
    """Default strategy parameters of the tutorial for dimension ``n`` and population ``lambda``."""
    mu = popsize // 2
    raw = math.log((popsize + 1) / 2) - np.log(np.arange(1, mu + 1))
    weights = raw / raw.sum()
    mueff = 1.0 / np.sum(weights**2)
    cc = (4 + mueff / n) / (n + 4 + 2 * mueff / n)
    cs = (mueff + 2) / (n + mueff + 5)
    c1 = 2 / ((n + 1.3) ** 2 + mueff)
    cmu = min(1 - c1, 2 * (mueff - 2 + 1 / mueff) / ((n + 2) ** 2 + mueff))
    damps = 1 + 2 * max(0.0, math.sqrt((mueff - 1) / (n + 1)) - 1) + cs
    chi_n = math.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n**2))
    return dict(mu=mu, weights=weights, mueff=mueff, cc=cc, cs=cs, c1=c1, cmu=cmu, damps=damps, chi_n=chi_n)


def cmaes(
    dmp,
    reward,
    *,
    weights=None,
    goal=None,
    y0=None,
    t=None,
    sigma0: float = 0.005,
    sigma_goal: float = 0.0,
    popsize: int | None = None,
    max_iter: int = 300,
    error=None,
    tol: float | None = None,
    lower=None,
    upper=None,
    limit_penalty: float = 100.0,
    seed: int | None = None,
) -> PowerResult:
    """Improve a DMP's weights (and optionally its goal) with CMA-ES in scaled coordinates.

    Args:
        dmp, reward, weights, goal, y0, t, error, tol, lower, upper, limit_penalty, seed:
            as for :func:`lfd.rl.power` (the same harness).
        sigma0: initial step size in scaled coordinates (units of ``y``: a one-sigma change
            of one parameter moves the trajectory by at most ``sigma0``), > 0.
        sigma_goal: > 0 adds the goal to the parameters (its initial step is ``sigma0`` too,
            since a goal unit moves the end point by one unit); 0 keeps the goal.
        popsize: ``lambda`` (default ``4 + floor(3 ln n)``, >= 2).
        max_iter: iteration cap (>= 0).

    Returns:
        :class:`lfd.rl.PowerResult` of the final mean; ``history.exploration`` holds the step
        size relative to ``sigma0``.

    Example::

        result = cmaes(dmp, ViaPointReward(t, 2.0, point, goal=dmp.goal_), tol=0.01, seed=0)
    """
    sigma0 = check_float(sigma0, "sigma0", low=0.0, strict_low=True)
    sigma_goal = check_float(sigma_goal, "sigma_goal", low=0.0)
    problem = SearchProblem(dmp, reward, weights=weights, goal=goal, y0=y0, t=t, explore_goal=sigma_goal > 0.0,
                            error=error, tol=tol, lower=lower, upper=upper, limit_penalty=limit_penalty)  # fmt: skip
    n = problem.size
    popsize = 4 + int(3 * math.log(n)) if popsize is None else popsize
    popsize, max_iter = check_common(popsize, max_iter)
    if popsize < 2:
        raise ValueError(f"popsize must be >= 2, got {popsize}")
    p = cma_parameters(n, popsize)
    rng = np.random.default_rng(seed)
    theta0 = problem.theta0.copy()
    scale = problem.scale(theta0)
    scale = np.where(scale > 0, scale, 1.0)
    recorder = Recorder(problem, theta0)
    mean = np.zeros(n)
    sigma = sigma0
    cov = np.eye(n)
    eigvecs, eigvals = np.eye(n), np.ones(n)
    p_sigma, p_c = np.zeros(n), np.zeros(n)
    evaluations, eigen_at = 0, 0
    iteration = 0
    while iteration < max_iter and not recorder.done():
        iteration += 1
        if evaluations - eigen_at > popsize / (p["c1"] + p["cmu"]) / n / 10:
            eigen_at = evaluations
            cov = np.triu(cov) + np.triu(cov, 1).T
            eigvals, eigvecs = np.linalg.eigh(cov)
            eigvals = np.maximum(eigvals, 1e-20)
        sqrt_vals = np.sqrt(eigvals)
        z = rng.standard_normal((popsize, n))
        y = (z * sqrt_vals) @ eigvecs.T  # ~ N(0, C)
        x = mean + sigma * y
        _, returns = recorder.samples(theta0 + x / scale)
        evaluations += popsize
        order = np.argsort(-returns, kind="stable")[: p["mu"]]
        y_w = p["weights"] @ y[order]
        mean = mean + sigma * y_w
        inv_sqrt_y = eigvecs @ ((eigvecs.T @ y_w) / sqrt_vals)  # C^-1/2 y_w
        p_sigma = (1 - p["cs"]) * p_sigma + math.sqrt(p["cs"] * (2 - p["cs"]) * p["mueff"]) * inv_sqrt_y
        norm_ps = np.linalg.norm(p_sigma)
        h_sigma = norm_ps / math.sqrt(1 - (1 - p["cs"]) ** (2 * evaluations / popsize)) / p[
            "chi_n"
        ] < 1.4 + 2 / (n + 1)
        p_c = (1 - p["cc"]) * p_c + h_sigma * math.sqrt(p["cc"] * (2 - p["cc"]) * p["mueff"]) * y_w
        rank_mu = (y[order].T * p["weights"]) @ y[order]
        delta_h = (1 - h_sigma) * p["cc"] * (2 - p["cc"])
        cov = (
            (1 - p["c1"] - p["cmu"]) * cov
            + p["c1"] * (np.outer(p_c, p_c) + delta_h * cov)
            + p["cmu"] * rank_mu
        )
        sigma *= math.exp((p["cs"] / p["damps"]) * (norm_ps / p["chi_n"] - 1))
        recorder.policy(theta0 + mean / scale, returns, sigma / sigma0)
    return recorder.result(iteration)
