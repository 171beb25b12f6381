"""PoWER: Policy learning by Weighting Exploration with the Returns (Kober & Peters 2009, 2011), on DMPs.

The policy is a fitted :class:`lfd.dmp.DMP`; its parameters ``theta`` are the forcing
weights ``(D, K)`` and, optionally, the goal ``(D,)`` (the harness:
:class:`lfd.rl.problem.SearchProblem`). One iteration:

1. explore: ``theta_k = theta + eps_k``, ``eps_k ~ N(0, Sigma)``, ``Sigma`` diagonal, ``k = 1..n``,
   all rollouts evaluated as one batch (:class:`lfd.rl.DMPRollout`);
2. returns ``Q_k`` (and, per step, returns-to-go ``Q_k(t) = sum_{t' >= t} r_k(t')``),
   multiplied by ``exp(-limit_penalty * v_k)`` where ``v_k`` is the rollout's largest
   joint-limit violation (rad) when limits are given;
3. importance sampling: every rollout ever evaluated is remembered with its returns and
   the ``M`` best of *all* of them are kept (:func:`lfd.rl.memory.keep_best`);
4. update over the kept rollouts (``eps_k = theta_k - theta`` re-expressed w.r.t. the current policy):

   - ``variant="per-step"`` (Kober & Peters' PoWER): per DoF,
     ``theta <- theta + (sum_k sum_t W(t) Q_k(t))^-1 sum_k sum_t W(t) eps_k Q_k(t)`` with
     ``W(t) = phi(t) phi(t)^T / (phi(t)^T Sigma phi(t))`` and ``phi(t)`` the basis
     activations (features ``s psi_i / sum_j psi_j``) at sample ``t``: a perturbation of a
     basis is credited with the returns that follow the time where that basis acts. The
     goal (no basis) is updated with ``Q_k(0)``. With episodic returns (a reward without
     ``per_step``), ``Q_k(t) = Q_k`` and the update is the episodic one.
   - ``variant="episodic"``: ``theta <- theta + sum_k eps_k Q_k / sum_k Q_k``.
   - ``variant="pyrdmp"``: the published pyrdmp code (heracleia/pyrdmp, ``pyrdmp/dmp.py``,
     ``DynamicMovementPrimitive.adapt``, commit 0164e5f): exploration drawn with *mean*
     ``std_t(psi_i(t) w_i)`` (the spread of the weighted, un-normalised activation over the
     motion) and standard deviation 1, in pyrdmp's weight units (``w (g - y0)`` of this
     library's ``"ijspeert"`` weights; ``K (w - (g - y0))`` of ``"pastor"``'s, one unit of
     forcing input either way), the best ``floor(n * 0.5)`` rollouts of the *current* batch
     (no memory), no variance adaptation, and its stopping test: stop when the best
     rollout of the batch ends within 0.1 (units of ``y``) of the goal on every DoF
     (``stop="published"``, the default of this variant; ``stop="tol"`` uses the harness'
     rule instead). The goal is not explored unless ``sigma_goal > 0`` (an ablation).

5. variance adaptation (``adapt_variance``, Kober's code): per parameter,
   ``sigma^2 <- sum_k Q_k eps_k^2 / sum_k Q_k`` over the kept rollouts, kept within
   ``variance_bounds`` times the initial variance, so exploration never vanishes;
6. roll out the updated policy once: its error decides the stopping rule
   (``error <= tol`` and no limit violation) and the rollout joins the memory.

Exploration (per-step and episodic). Every weight gets the standard deviation
``sigma / a_{d,i}``, where ``a_{d,i} = max_t |dy_d(t) / dw_{d,i}|`` is the largest
trajectory displacement per unit of that weight at the current goal
(:meth:`lfd.rl.DMPRollout.basis_scale`): a one-sigma change of any single weight moves the
trajectory by ``sigma`` (units of ``y``), for early and late bases alike, and for a
goal-scaled DMP the goal displacement in ``a`` is floored at 10 % of the largest one, so a
DoF whose goal equals its start explores as soon as its goal moves. The goal is explored
with its own ``sigma_goal`` (units of ``y``). Annealing: both shrink by ``sigma_decay``
per iteration and, with ``scale_by_error``, in proportion to the policy's remaining error,
``min(1, max(e_i, tol) / e_0)``.

Defaults (per-step, variance adaptation on, error annealing off, ``sigma = 0.02``,
``n_best = 3``, ``n_rollouts = 8``) were chosen on development tasks (``benchmarks/power_tasks.py --dev``:
LASA shapes and seeds not in the reported tables); see ``docs/power.md``.
"""

from __future__ import annotations

import numpy as np
import torch

from lfd.checks import check_choice, check_float, check_int

from .memory import keep_best
from .problem import PowerHistory, PowerResult, Recorder, SearchProblem, check_common, check_variance_bounds

__all__ = ["POWER_VARIANTS", "PowerHistory", "PowerResult", "power"]

#: Accepted ``variant=`` values of :func:`power`; the first is the default.
POWER_VARIANTS = ("per-step", "episodic", "pyrdmp")

PYRDMP_THRESHOLD = 0.1  # the published stopping test: |x_T - g| < 0.1
PYRDMP_RATE = 0.5  # the published share of rollouts kept


def basis_features(dmp, t: np.ndarray) -> np.ndarray:
    """``(T, K)`` forcing-term features ``s psi_i(s) / sum_j psi_j(s)`` of ``dmp`` at times ``t`` (s)."""
    from lfd.dmp.canonical import discrete_features

    theta = torch.from_numpy((np.asarray(t, dtype=np.float64) - float(t[0])) / float(dmp.tau_))
    return discrete_features(theta, dmp.n_basis, dmp.alpha_s, dmp.overlap).numpy()


def activations(dmp, t: np.ndarray) -> np.ndarray:
    """``(T, K)`` un-normalised basis activations ``psi_i(s)`` of ``dmp`` at times ``t`` (s)."""
    from lfd.dmp.canonical import discrete_activations

    theta = torch.from_numpy((np.asarray(t, dtype=np.float64) - float(t[0])) / float(dmp.tau_))
    return discrete_activations(theta, dmp.n_basis, dmp.alpha_s, dmp.overlap).numpy()


def pyrdmp_exploration(rng, n: int, weights: np.ndarray, psi: np.ndarray) -> np.ndarray:
    """pyrdmp's exploration ``(n, D, K)``: ``normal(loc=std_t(psi_i(t) w_{d,i}), scale=1)``.

    The published code (``np.random.normal(np.std(psv[j] * a[j]))``) passes the spread as
    the *mean* and keeps numpy's default standard deviation 1.

    Args:
        rng: ``numpy.random.Generator``.
        n: number of rollouts.
        weights: ``(D, K)`` weights in pyrdmp's units (one unit = one unit of forcing input).
        psi: ``(T, K)`` un-normalised basis activations.
    """
    spread = np.std(psi[None] * weights[:, None, :], axis=1)  # (D, K)
    return rng.normal(loc=spread, scale=1.0, size=(n, *weights.shape))


def per_step_update(features, q, eps, variance_weights) -> np.ndarray:
    """Kober & Peters' per-DoF update of the weights, ``(D, K)``.

    Args:
        features: ``(T, K)`` basis features ``phi(t)``.
        q: ``(M, T)`` returns-to-go of the kept rollouts.
        eps: ``(M, D, K)`` their weight perturbations w.r.t. the current policy.
        variance_weights: ``(D, K)`` exploration variances ``Sigma`` (weight units).

    Returns:
        ``(D, K)`` ``(sum_k sum_t W Q_k)^-1 sum_k sum_t W eps_k Q_k`` with
        ``W(t) = phi phi^T / (phi^T Sigma_d phi)``, solved per DoF with a tiny ridge so that
        bases without credit (``Q = 0`` where they act) stay where they are.
    """
    norm = np.einsum("tk,dk->dt", features**2, variance_weights)  # phi^T Sigma_d phi, (D, T)
    gain = 1.0 / np.maximum(norm, 1e-300)
    total = q.sum(axis=0)  # (T,)
    a = np.einsum("dt,ti,tj->dij", gain * total, features, features, optimize=True)
    projection = np.einsum("tk,mdk->mdt", features, eps)  # phi(t)^T eps_{k,d}
    b = np.einsum("dmt,ti->di", gain[:, None] * (q * projection.transpose(1, 0, 2)), features, optimize=True)
    ridge = 1e-10 * np.einsum("dii->d", a)[:, None, None] / features.shape[1] + 1e-300
    a = a + ridge * np.eye(features.shape[1])
    return np.linalg.solve(a, b[..., None])[..., 0]


def power(
    dmp,
    reward,
    *,
    weights=None,
    goal=None,
    y0=None,
    t=None,
    variant: str = "per-step",
    n_rollouts: int = 8,
    n_best: int = 3,
    max_iter: int = 100,
    sigma: float = 0.02,
    sigma_goal: float = 0.0,
    sigma_decay: float = 1.0,
    scale_by_error: bool = False,
    adapt_variance: bool | None = None,
    variance_bounds: tuple[float, float] = (0.01, 4.0),
    error=None,
    tol: float | None = None,
    stop: str | None = None,
    lower=None,
    upper=None,
    limit_penalty: float = 100.0,
    per_basis: bool = True,
    seed: int | None = None,
) -> PowerResult:
    """Improve a DMP's weights (and optionally its goal) with PoWER; see the module docstring.

    Shapes: ``D`` DoF, ``K`` basis functions, ``T`` samples per rollout, ``B`` rollouts.

    Args:
        dmp: fitted :class:`lfd.dmp.DMP` (one demonstration); it is not modified.
        reward: callable ``reward(trajectories (B, T, D)) -> (B,)`` finite non-negative
            returns, e.g. :class:`lfd.rl.JointGoalReward`, :class:`lfd.rl.ViaPointReward`,
            :class:`lfd.rl.ObstacleReward`; its optional ``per_step(trajectories) -> (B, T)``
            gives the per-sample rewards of the per-step variant.
        weights: ``(D, K)`` initial weights (default ``dmp.weights_``).
        goal: ``(D,)`` initial goal (default ``dmp.goal_``).
        y0: ``(D,)`` start (default ``dmp.y0_``). t: ``(T,)`` time grid (s), default the DMP's.
        variant: ``"per-step"`` (default), ``"episodic"`` or ``"pyrdmp"``.
        n_rollouts: exploratory rollouts per iteration (>= 1).
        n_best: importance-sampling memory size ``M`` (>= 1): the update averages the ``M``
            best rollouts seen so far (not used by ``"pyrdmp"``, which keeps the best half of
            the batch). With noisy returns use a larger ``M``, since a lucky rollout stays.
        max_iter: iteration cap (>= 0).
        sigma: weight exploration, as the trajectory displacement (units of ``y``) of a
            one-sigma change of one weight (>= 0); not used by ``"pyrdmp"``.
        sigma_goal: goal exploration standard deviation (units of ``y``, >= 0; 0 keeps the goal).
        sigma_decay: factor in ``(0, 1]`` applied to the exploration every iteration.
        scale_by_error: scale exploration by ``min(1, max(e_i, tol) / e_0)`` (``tol`` read as 0
            when ``None``) when an error function exists and ``e_0 > tol``.
        adapt_variance: Kober's variance adaptation (default: on, off for ``"pyrdmp"``).
        variance_bounds: ``(low, high)`` bounds of the adapted variance relative to the
            initial one, ``0 < low <= 1 <= high``.
        error: callable ``error(trajectories (B, T, D)) -> (B,)``; default ``reward.error``.
        tol: stopping rule: stop once the policy's error is ``<= tol`` (and it is within the
            limits). ``None``: run ``max_iter`` iterations.
        stop: ``"tol"`` (the rule above, default of ``"per-step"``/``"episodic"``) or
            ``"published"`` (pyrdmp's test, default of ``"pyrdmp"``; ``converged`` still
            reports the harness' rule on the final policy).
        lower, upper: ``(D,)`` joint limits (rad; ``+-inf`` for unbounded joints). A rollout
            whose largest violation is ``v`` rad has its return multiplied by
            ``exp(-limit_penalty * v)``, and a policy outside the limits never counts as converged.
        limit_penalty: penalty rate (1/rad, >= 0).
        per_basis: exploration scaled per basis (default); ``False`` scales all bases of a DoF
            like the earliest one (the behaviour before, which freezes late bases).
        seed: seed of ``numpy.random.default_rng`` (same seed, same result).

    Returns:
        :class:`PowerResult` with the final (not the best-ever) policy.

    Raises:
        ValueError: a bad argument (named in the message), or a reward returning negative
            or non-finite values.

    Example::

        t = np.linspace(0.0, dmp.tau_, dmp.n_steps_)
        point = dmp.rollout()[len(t) // 2] + 0.1           # (D,) rad off the motion at mid-time
        result = power(dmp, ViaPointReward(t, t[len(t) // 2], point, goal=dmp.goal_), tol=0.01, seed=0)
        result.converged, result.rollouts
    """
    check_choice(variant, "variant", POWER_VARIANTS)
    n_rollouts, max_iter = check_common(n_rollouts, max_iter)
    n_best = check_int(n_best, "n_best", minimum=1)
    sigma = check_float(sigma, "sigma", low=0.0)
    sigma_goal = check_float(sigma_goal, "sigma_goal", low=0.0)
    sigma_decay = check_float(sigma_decay, "sigma_decay", low=0.0, high=1.0, strict_low=True)
    if adapt_variance is None:
        adapt_variance = variant != "pyrdmp"
    low, high = check_variance_bounds(variance_bounds)
    stop = ("published" if variant == "pyrdmp" else "tol") if stop is None else stop
    if stop not in ("tol", "published"):
        raise ValueError(f"stop must be 'tol' or 'published', got {stop!r}")
    problem = SearchProblem(dmp, reward, weights=weights, goal=goal, y0=y0, t=t, explore_goal=sigma_goal > 0.0,
                            error=error, tol=tol, lower=lower, upper=upper, limit_penalty=limit_penalty,
                            per_basis=per_basis)  # fmt: skip
    rng = np.random.default_rng(seed)
    theta = problem.theta0.copy()
    recorder = Recorder(problem, theta)
    first_err = recorder.error
    floor = 0.0 if problem.tol is None else problem.tol
    n_dof, n_basis, split = problem.n_dof, problem.n_basis, problem.split
    # exploration standard deviations in trajectory units (units of y) per parameter
    base = np.concatenate([np.full(split, sigma), np.full(theta.size - split, sigma_goal)])
    relative = np.ones(theta.size)  # variance adaptation, relative standard deviation
    if variant == "per-step":
        features = basis_features(dmp, problem.rollout.t)
    if variant == "pyrdmp":
        return _pyrdmp(dmp, problem, recorder, rng, n_rollouts, max_iter, sigma_goal, stop)
    t_len = problem.rollout.t.size
    memory = keep_best(np.empty((0, theta.size + t_len)), np.empty(0),
                       _row(problem, theta, recorder), np.array([recorder.policy_return]), n_best)  # fmt: skip

    iteration = 0
    while iteration < max_iter and not recorder.done():
        iteration += 1
        anneal = sigma_decay ** (iteration - 1)
        if scale_by_error and problem.error is not None and first_err > floor:
            anneal *= min(1.0, max(recorder.error, floor) / first_err)
        scale = problem.scale(theta)  # y displacement per parameter unit, at the current goal
        std = np.divide(base * relative * anneal, scale, out=np.zeros_like(scale), where=scale > 0)
        samples = theta + rng.standard_normal((n_rollouts, theta.size)) * std
        trajectories, sample_returns = recorder.samples(samples)
        q = problem.returns_to_go(trajectories, sample_returns) if variant == "per-step" else None
        rows = np.concatenate([samples, q if q is not None else np.zeros((n_rollouts, t_len))], axis=1)
        memory = keep_best(*memory, rows, sample_returns, n_best)
        kept, kept_returns = memory
        kept_theta, kept_q = kept[:, : theta.size], kept[:, theta.size :]
        eps = kept_theta - theta
        if kept_returns.sum() > 0.0:
            step = kept_returns @ eps / kept_returns.sum()  # episodic reward-weighted average
            if variant == "per-step" and problem.has_returns_to_go and kept_q[:, 0].sum() > 0.0:
                variances = (std[:split] ** 2).reshape(n_dof, n_basis)
                step[:split] = per_step_update(features, kept_q, eps[:, :split].reshape(-1, n_dof, n_basis),
                                               np.maximum(variances, 1e-300)).ravel()  # fmt: skip
            if adapt_variance:
                spread = kept_returns @ np.square(eps * scale) / kept_returns.sum()  # trajectory units^2
                ratio = np.divide(spread, np.square(base), out=np.ones_like(spread), where=base > 0)
                relative = np.sqrt(np.clip(ratio, low, high))
            theta = theta + step
        recorder.policy(theta, sample_returns, float(np.sqrt(np.mean(np.square(relative * anneal)))))
        memory = keep_best(
            *memory, _row(problem, theta, recorder), np.array([recorder.policy_return]), n_best
        )
    return recorder.result(iteration)


def _row(problem: SearchProblem, theta: np.ndarray, recorder: Recorder) -> np.ndarray:
    """Memory row ``[theta, Q(t)]`` of the policy just evaluated by ``recorder``."""
    trajectory = recorder.trajectory[None]
    q = problem.returns_to_go(trajectory, np.array([recorder.policy_return]))
    return np.concatenate([theta, q[0]])[None]


def _pyrdmp(dmp, problem, recorder, rng, n_rollouts, max_iter, sigma_goal, stop) -> PowerResult:
    """The pyrdmp variant (see the module docstring)."""
    psi = activations(dmp, problem.rollout.t)  # (T, K)
    n_dof, split = problem.n_dof, problem.split
    n_keep = max(int(np.floor(n_rollouts * PYRDMP_RATE)), 1)
    y0 = problem.rollout.y0
    stiffness = float(dmp.alpha_z * dmp.beta_z)
    theta = recorder.theta
    iteration = 0

    def published_done(trajectory, goal) -> bool:
        return bool(np.all(np.abs(trajectory[-1] - goal) < PYRDMP_THRESHOLD))

    stopped = recorder.done() if stop == "tol" else False
    while iteration < max_iter and not stopped:
        iteration += 1
        weights, goals = problem.unpack(theta[None])
        displacement = goals[0] - y0
        # one unit of pyrdmp's weights is one unit of forcing input
        if problem.rollout.goal_scaled:
            safe = np.where(np.abs(displacement) > problem.goal_floor, displacement,
                            np.where(displacement < 0, -problem.goal_floor, problem.goal_floor))  # fmt: skip
            to_own = 1.0 / safe[:, None]
            own_units = weights[0] * safe[:, None]
        else:
            to_own = np.full((n_dof, 1), 1.0 / stiffness)
            own_units = stiffness * (weights[0] - displacement[:, None])
        eps = pyrdmp_exploration(rng, n_rollouts, own_units, psi) * to_own
        eps = eps.reshape(n_rollouts, split)
        if problem.explore_goal:
            eps = np.concatenate([eps, rng.standard_normal((n_rollouts, n_dof)) * sigma_goal], axis=1)
        samples = theta + eps
        trajectories, returns = recorder.samples(samples)
        best = np.argsort(-returns, kind="stable")[:n_keep]
        if returns[best].sum() > 0.0:
            theta = theta + returns[best] @ eps[best] / returns[best].sum()
        if stop == "published":
            # the published code tests the best rollout of the batch and returns it
            goal_best = problem.unpack(samples[best[:1]])[1][0]
            if published_done(trajectories[best[0]], goal_best):
                theta = samples[best[0]]
                stopped = True
        recorder.policy(theta, returns, 1.0)
        if stop == "tol":
            stopped = recorder.done()
    return recorder.result(iteration)
