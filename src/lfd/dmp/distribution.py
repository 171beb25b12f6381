"""Distribution of DMP parameters over several demonstrations, propagated to the state space in closed form.

One :class:`~lfd.dmp.DMP` is fitted to each of ``N`` demonstrations (all at once when they share
a time grid); the start, goal and forcing weights of each DoF form a parameter vector whose
sample mean and covariance are the learned distribution. With fixed ``tau`` (and start velocity)
the rollout is *linear* in these parameters (``formulation="pastor"``:
``y_d(t) = a(t) y0_d + b(t) g_d + m(t)^T w_d``; see :mod:`lfd.dmp.transform`), so the
trajectory distribution is Gaussian with mean and covariance through that linear map: exact,
no sampling and no sigma points. The map is read off the one rollout implementation
(:meth:`lfd.dmp.DMP.rollout` of unit inputs). With ``formulation="ijspeert"`` the forcing term
scales with ``g - y0``, so the map is linear in the weights only: the start and goal are then
held fixed (at the mean or the values given).

movement_primitives propagates a DMP weight distribution by the unscented transform (sigma points
rolled out one by one, dual Cartesian DMPs only); for a linear map that is exact too and agrees
with this closed form, which the tests check with sigma points and Monte Carlo rollouts.
"""

from __future__ import annotations

import numpy as np
import torch

from lfd import checks

from .discrete import DMP
from .promp import _demonstrations

__all__ = ["DMPDistribution"]


class DMPDistribution:
    """Gaussian over DMP parameters ``[y0_d, g_d, w_d1..w_dK]`` per DoF, learned from demonstrations.

    Args:
        cov_reg: shrinkage of the parameter covariance, ``cov_ = S + cov_reg (trace(S) / P) I``
            (``S`` the sample covariance with ``ddof=1``, ``P = D (K + 2)``; default 0).
        **dmp_params: arguments of :class:`~lfd.dmp.DMP` (``n_basis``, ``alpha_z``, ``formulation``, ...).

    Attributes (after :meth:`fit`):
        mean_: ``(D (K + 2),)`` parameter mean, DoF-major: ``[y0_d, g_d, w_d1, ..., w_dK]`` per DoF.
        cov_: ``(P, P)`` parameter covariance.
        params_: ``(N, P)`` per-demonstration parameters.
        tau_: mean demonstration duration (s), the default ``tau`` of the propagation.
        n_steps_: median number of samples, the default length of the output grid.
        n_dims_: ``D``.
        dmp: the :class:`~lfd.dmp.DMP` whose settings are used (unfitted).
    """

    def __init__(self, cov_reg: float = 0.0, **dmp_params):
        self.dmp = DMP(**dmp_params)
        if (
            isinstance(cov_reg, bool)
            or not isinstance(cov_reg, (int, float))
            or not np.isfinite(cov_reg)
            or cov_reg < 0
        ):
            raise ValueError(f"cov_reg must be a finite number >= 0, got {cov_reg!r}")
        self.cov_reg = float(cov_reg)

    def __repr__(self) -> str:
        return f"DMPDistribution(cov_reg={self.cov_reg}, dmp={self.dmp!r})"

    def fit(self, t, Y) -> DMPDistribution:
        """Fit one DMP per demonstration and the Gaussian over their parameters.

        Args:
            t: ``(T,)`` shared times (s), ``(N, T)``, or a list of ``N`` ``(T_i,)`` arrays.
            Y: ``(N, T, D)`` positions or a list of ``N`` ``(T_i, D)`` arrays (different
                durations: each DMP gets its own ``tau``; the weights live in normalised time).

        Returns:
            ``self``.

        Raises:
            ValueError: bad shapes, NaN/inf, fewer than 3 samples, ``t`` not strictly increasing.
        """
        ts, ys = _demonstrations(t, Y)
        if len({ti.tobytes() for ti in ts}) == 1:  # one grid: one batched fit
            fitted = DMP(**self.dmp._params()).fit(ts[0], np.stack(ys))
            weights, starts, goals = fitted.weights_, fitted.y0_, fitted.goal_
        else:
            fits = [DMP(**self.dmp._params()).fit(ti, yi) for ti, yi in zip(ts, ys)]
            weights = np.stack([f.weights_ for f in fits])
            starts, goals = np.stack([f.y0_ for f in fits]), np.stack([f.goal_ for f in fits])
        params = np.concatenate([starts[..., None], goals[..., None], weights], axis=-1)  # (N, D, K + 2)
        n_demos, n_dims = params.shape[:2]
        self.params_ = params.reshape(n_demos, -1)
        mean = self.params_.mean(axis=0)
        centred = self.params_ - mean
        cov = centred.T @ centred / max(n_demos - 1, 1)
        cov += self.cov_reg * np.trace(cov) / cov.shape[0] * np.eye(cov.shape[0])
        self.mean_, self.cov_, self.n_dims_ = mean, cov, n_dims
        self.tau_ = float(np.mean([ti[-1] - ti[0] for ti in ts]))
        self.n_steps_ = int(np.median([ti.shape[0] for ti in ts]))
        return self

    def _check_fitted(self) -> None:
        if not hasattr(self, "mean_"):
            raise ValueError("the DMPDistribution is not fitted: call fit() first")

    @property
    def weights_mean_(self) -> np.ndarray:
        """``(D, K)`` mean forcing weights."""
        self._check_fitted()
        return self.mean_.reshape(self.n_dims_, -1)[:, 2:]

    @property
    def weights_cov_(self) -> np.ndarray:
        """``(D K, D K)`` covariance of the forcing weights (DoF-major)."""
        self._check_fitted()
        k = self.dmp.n_basis + 2
        index = np.array([d * k + j for d in range(self.n_dims_) for j in range(2, k)])
        return self.cov_[np.ix_(index, index)]

    def _grid(self, t, tau) -> tuple[np.ndarray, float]:
        self._check_fitted()
        tau = self.tau_ if tau is None else checks.positive_float(tau, "tau")
        times = np.linspace(0.0, tau, self.n_steps_) if t is None else checks.time_grid(t, min_samples=1)
        return times, tau

    def linear_map(self, t=None, tau=None) -> np.ndarray:
        """``(T, K + 2)`` map from one DoF's ``[y0, g, w_1..w_K]`` to its positions (``"pastor"`` only).

        Args:
            t: ``(T,)`` output times (s, from the start); default ``linspace(0, tau, n_steps_)``.
            tau: duration (s); default ``tau_``.

        Raises:
            ValueError: ``formulation="ijspeert"`` (not linear in start and goal), bad ``t``/``tau``.
        """
        if self.dmp.formulation != "pastor":
            raise ValueError(
                "linear_map needs formulation='pastor' (with 'ijspeert' fix y0 and goal in propagate)"
            )
        times, tau = self._grid(t, tau)
        unit = np.eye(self.dmp.n_basis + 2)[:, :, None]  # (K + 2, K + 2, 1): one parameter at a time
        columns = self.dmp.rollout(
            t=times, y0=unit[:, 0], goal=unit[:, 1], tau=tau, weights=unit[:, 2:].transpose(0, 2, 1)
        )
        return columns[..., 0].T

    def propagate(self, t=None, tau=None, y0=None, goal=None) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form state-space distribution of the rollouts.

        Args:
            t: ``(T,)`` output times (s, from the start); default ``linspace(0, tau, n_steps_)``.
            tau: duration (s); default ``tau_`` (the mean demonstrated duration).
            y0, goal: ``(D,)`` fixed start and goal; ``None`` (both, default, ``"pastor"``) lets
                them vary with the data. Fixing them uses the marginal weight distribution.

        Returns:
            ``(mean (T, D), cov (T, D, T, D))`` in the units of the demonstrations.

        Raises:
            ValueError: bad shapes, NaN, ``tau <= 0``, not fitted.
        """
        times, tau = self._grid(t, tau)
        d = self.n_dims_
        if y0 is None and goal is None and self.dmp.formulation == "pastor":
            blocks = np.kron(np.eye(d), self.linear_map(times, tau))  # (D T, P) DoF-major rows
            mean, cov = self.mean_, self.cov_
        else:
            blocks, offset = self._weight_map(times, tau, y0, goal)
            mean, cov = self.weights_mean_.reshape(-1), self.weights_cov_
        out_mean = (blocks @ mean).reshape(d, -1).T
        out_cov = (blocks @ cov @ blocks.T).reshape(d, len(times), d, len(times)).transpose(1, 0, 3, 2)
        if y0 is not None or goal is not None or self.dmp.formulation != "pastor":
            out_mean = out_mean + offset
        return out_mean, 0.5 * (out_cov + out_cov.transpose(2, 3, 0, 1))

    def _weight_map(self, times, tau, y0, goal) -> tuple[np.ndarray, np.ndarray]:
        """``(D T, D K)`` map of the weights and the ``(T, D)`` free response for fixed start/goal."""
        d, k = self.n_dims_, self.dmp.n_basis
        means = self.mean_.reshape(d, k + 2)
        y0 = means[:, 0] if y0 is None else checks.finite_array(y0, "y0", ndim=(1,))
        goal = means[:, 1] if goal is None else checks.finite_array(goal, "goal", ndim=(1,))
        if y0.shape != (d,) or goal.shape != (d,):
            raise ValueError(f"y0 and goal must have shape ({d},), got {y0.shape} and {goal.shape}")
        unit = np.concatenate([np.zeros((1, d, k)), np.broadcast_to(np.eye(k)[:, None, :], (k, d, k))])
        rolled = self.dmp.rollout(t=times, y0=y0, goal=goal, tau=tau, weights=unit)  # (K + 1, T, D)
        offset, columns = rolled[0], rolled[1:] - rolled[:1]  # columns (K, T, D)
        blocks = np.zeros((d, len(times), d, k))
        blocks[np.arange(d), :, np.arange(d), :] = columns.transpose(2, 1, 0)
        return blocks.reshape(d * len(times), d * k), offset

    def var_trajectory(self, t=None, tau=None, y0=None, goal=None) -> np.ndarray:
        """Marginal variances ``(T, D)`` of the propagated distribution (see :meth:`propagate`)."""
        _, cov = self.propagate(t, tau, y0, goal)
        t_idx, d_idx = np.arange(cov.shape[0]), np.arange(cov.shape[1])
        return np.clip(cov[t_idx[:, None], d_idx, t_idx[:, None], d_idx], 0.0, None)

    def sample_trajectories(self, n: int, t=None, tau=None, rng=None) -> np.ndarray:
        """``n`` rollouts ``(n, T, D)`` of parameters drawn from the distribution (sampling-based)."""
        n = checks.positive_int(n, "n")
        times, tau = self._grid(t, tau)
        rng = np.random.default_rng(rng)
        params = rng.multivariate_normal(self.mean_, self.cov_, size=n, method="eigh")
        return self.rollout_params(params, times, tau)

    def rollout_params(self, params, t=None, tau=None) -> np.ndarray:
        """Rollouts ``(B, T, D)`` of parameter vectors ``(B, P)`` (layout of ``mean_``)."""
        times, tau = self._grid(t, tau)
        params = checks.finite_array(params, "params", ndim=(2,))
        if params.shape[1] != self.mean_.shape[0]:
            raise ValueError(f"params must have shape (B, {self.mean_.shape[0]}), got {params.shape}")
        blocks = params.reshape(params.shape[0], self.n_dims_, -1)
        rolled = self.dmp.rollout(
            t=times,
            y0=blocks[..., 0],
            goal=blocks[..., 1],
            tau=tau,
            weights=np.ascontiguousarray(blocks[..., 2:]),
        )
        return rolled.numpy() if isinstance(rolled, torch.Tensor) else rolled
