"""Probabilistic movement primitive (ProMP, Paraschos et al. 2013), scikit-learn style.

A ProMP is a Gaussian over the weights ``w`` of normalised radial basis functions of the phase
``s = t / duration``: ``y_d(s) = sum_k psi_k(s) w_{d,k}`` per DoF ``d``, ``w ~ N(mean_, cov_)``.
Fitting several demonstrations estimates one weight vector per demonstration (ridge least
squares) and their sample mean and covariance; the distribution over trajectories follows in
closed form (mean, variance, covariance, samples, log-likelihood), and conditioning on via
points, goals or a start is Gaussian conditioning in weight space.

The basis is movement_primitives' (``movement_primitives.promp.ProMP``): centres evenly spaced
on ``[0, 1]``, ``psi_k(s) = exp(-(s - c_k)^2 / (2 h))`` with ``h = -1 / (8 K^2 ln(overlap))``,
normalised to sum to one at every phase; the weight layout is DoF-major (index ``d K + k``).
With ``cov_reg=0`` the fit equals movement_primitives' ``weights()`` per demonstration
followed by ``from_weight_distribution(mean, np.cov(W.T))`` (tested to rounding);
``docs/dmp.md`` lists where the two differ (time normalisation, input mutation).

Units: times in the units of ``fit``'s ``t`` (seconds) measured from each demonstration's
first sample; positions in the units of the demonstrations (any ``D``: joint angles or
task-space coordinates). Shapes: ``N`` demonstrations, ``T`` samples, ``D`` DoF, ``K`` bases.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import torch

from lfd import checks

from . import _io
from ._base import Parameterised

__all__ = ["ProMP"]

_DTYPE = torch.float64


def promp_basis(phase: torch.Tensor, n_basis: int, overlap: float) -> torch.Tensor:
    """``(T, K)`` normalised Gaussian activations at ``phase`` ``(T,)`` (movement_primitives' basis)."""
    centres = torch.linspace(0.0, 1.0, n_basis, dtype=phase.dtype)
    h = -1.0 / (8.0 * n_basis**2 * math.log(overlap))
    activations = torch.exp(-((phase[:, None] - centres) ** 2) / (2.0 * h))
    return activations / activations.sum(dim=-1, keepdim=True)


def _demonstrations(t, y) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Split ``fit``'s inputs into per-demonstration ``(t_i (T_i,), y_i (T_i, D))``."""
    if isinstance(y, (list, tuple)):
        ys = [checks.finite_array(yi, f"Y[{i}]", ndim=(2,)) for i, yi in enumerate(y)]
        if not isinstance(t, (list, tuple)):
            ts = [t] * len(ys)
        elif len(t) != len(ys):
            raise ValueError(f"t must hold one time vector per demonstration ({len(ys)}), got {len(t)}")
        else:
            ts = list(t)
    else:
        array = checks.finite_array(y, "Y", ndim=(2, 3))
        ys = list(array[None] if array.ndim == 2 else array)
        times = checks.finite_array(t, "t", ndim=(1, 2))
        if times.ndim == 2 and times.shape[0] != len(ys):
            raise ValueError(
                f"t must be (T,) or (N, T) with N = {len(ys)} demonstrations, got shape {times.shape}"
            )
        ts = list(times) if times.ndim == 2 else [times] * len(ys)
    if not ys:
        raise ValueError("Y must hold at least one demonstration")
    ts = [checks.time_grid(ti, min_samples=2, name=f"t[{i}]") for i, ti in enumerate(ts)]
    for i, (ti, yi) in enumerate(zip(ts, ys)):
        if yi.shape[0] != ti.shape[0] or yi.shape[1] != ys[0].shape[1] or yi.shape[1] < 1:
            raise ValueError(
                f"Y[{i}] must have shape (len(t[{i}]), D) = ({ti.shape[0]}, {ys[0].shape[1]}), got {yi.shape}"
            )
    return ts, ys


class ProMP(Parameterised):
    """Probabilistic movement primitive over ``D`` DoF with ``K`` bases per DoF.

    Args:
        n_basis: bases ``K`` per DoF (>= 1; default 10, movement_primitives' default).
        overlap: width parameter in ``(0, 1)`` of movement_primitives' basis (default 0.7,
            theirs): ``h = -1 / (8 K^2 ln(overlap))``.
        ridge: absolute Tikhonov term added to ``Psi^T Psi`` in each demonstration's weight fit
            (default ``1e-12``, movement_primitives' ``lmbda``).
        cov_reg: shrinkage of the weight covariance: ``cov_ = S + cov_reg * (trace(S) / P) I``
            with ``S`` the sample covariance (``ddof=1``) and ``P = D K`` (default 0: the data's
            covariance, which has rank ``N - 1`` at most).

    Attributes (after :meth:`fit`):
        mean_: ``(D K,)`` weight mean, DoF-major.
        cov_: ``(D K, D K)`` weight covariance.
        weights_: ``(N, D K)`` per-demonstration weights.
        duration_: mean demonstration duration (units of ``t``); phase ``s = t / duration_``.
        noise_: RMS residual of the per-demonstration fits (units of ``y``), the default
            observation noise of :meth:`log_likelihood`.
        n_dims_: ``D``.
    """

    _PARAMS = ("n_basis", "overlap", "ridge", "cov_reg")
    _FITTED = "mean_"  # set by fit() and from_weight_distribution()

    def __init__(self, n_basis: int = 10, overlap: float = 0.7, ridge: float = 1e-12, cov_reg: float = 0.0):
        self.n_basis = checks.positive_int(n_basis, "n_basis")
        self.overlap = checks.unit_interval(overlap, "overlap")
        self.ridge = checks.check_float(ridge, "ridge", low=0.0)
        self.cov_reg = checks.check_float(cov_reg, "cov_reg", low=0.0)

    def _check_fitted(self) -> None:
        if not self.is_fitted:
            raise ValueError("the ProMP is not fitted: call fit() or from_weight_distribution() first")

    def fit(self, t, Y) -> ProMP:
        """Learn the weight distribution from ``N`` demonstrations.

        Each demonstration is time-normalised to the phase ``(t_i - t_i[0]) / (t_i[-1] - t_i[0])``
        and fitted by ridge least squares (all at once: zero-padded to the longest); the weights'
        sample mean and (regularised) covariance are the ProMP.

        Args:
            t: ``(T,)`` times shared by all demonstrations, ``(N, T)``, or a list of ``N``
                ``(T_i,)`` arrays (strictly increasing, >= 2 samples).
            Y: ``(N, T, D)`` (or one ``(T, D)``) positions, or a list of ``N`` ``(T_i, D)`` arrays
                (demonstrations of different durations).

        Returns:
            ``self``.

        Raises:
            ValueError: shapes that do not match, NaN/inf, ``t`` not strictly increasing.
        """
        ts, ys = _demonstrations(t, Y)
        n_demos, n_dims, longest = len(ys), ys[0].shape[1], max(yi.shape[0] for yi in ys)
        basis = torch.zeros(n_demos, longest, self.n_basis, dtype=_DTYPE)
        targets = torch.zeros(n_demos, longest, n_dims, dtype=_DTYPE)
        for i, (ti, yi) in enumerate(zip(ts, ys)):
            phase = torch.from_numpy((ti - ti[0]) / (ti[-1] - ti[0]))
            basis[i, : ti.shape[0]] = promp_basis(phase, self.n_basis, self.overlap)
            targets[i, : ti.shape[0]] = torch.from_numpy(yi)
        gram = basis.transpose(1, 2) @ basis + self.ridge * torch.eye(self.n_basis, dtype=_DTYPE)
        # pseudo-inverse like movement_primitives: the minimum-norm fit when T_i < K (gram singular)
        weights = torch.linalg.pinv(gram, hermitian=True) @ (basis.transpose(1, 2) @ targets)  # (N, K, D)
        residual = targets - basis @ weights  # padded rows are zero
        self.noise_ = float(torch.sqrt((residual**2).sum() / (sum(yi.shape[0] for yi in ys) * n_dims)))
        self.weights_ = weights.transpose(1, 2).reshape(n_demos, n_dims * self.n_basis).numpy()
        self.duration_ = float(np.mean([ti[-1] - ti[0] for ti in ts]))
        mean = self.weights_.mean(axis=0)
        centred = self.weights_ - mean
        cov = centred.T @ centred / max(n_demos - 1, 1)
        cov += self.cov_reg * np.trace(cov) / cov.shape[0] * np.eye(cov.shape[0])
        self.mean_, self.cov_, self.n_dims_ = mean, cov, n_dims
        return self

    def from_weight_distribution(self, mean, cov, duration: float = 1.0) -> ProMP:
        """Set the weight distribution directly (``mean`` ``(D K,)``, ``cov`` ``(D K, D K)``).

        Raises:
            ValueError: sizes that are not a multiple of ``K``, ``cov`` not square/symmetric.
        """
        mean = checks.finite_array(mean, "mean", ndim=(1,))
        cov = checks.finite_array(cov, "cov", ndim=(2,))
        size = mean.shape[0]
        if size % self.n_basis or cov.shape != (size, size):
            raise ValueError(
                f"mean must be (D K,) with K = {self.n_basis} and cov (D K, D K), got {mean.shape}, {cov.shape}"
            )
        if not np.allclose(cov, cov.T, rtol=1e-8, atol=1e-12 * max(1.0, np.abs(cov).max())):
            raise ValueError("cov must be symmetric")
        self.mean_, self.cov_, self.n_dims_ = mean, cov, size // self.n_basis
        self.duration_ = checks.positive_float(duration, "duration")
        self.noise_ = getattr(self, "noise_", 0.0)
        return self

    def save(self, path) -> None:
        """Write the settings and the weight distribution to a JSON file (atomically).

        Args:
            path: file path ending in ``.json``; its directory must exist.

        Raises:
            ValueError: ``path`` does not end in ``.json``.
        """
        params = self._params()
        fitted = None
        if self.is_fitted:
            fitted = {"mean": self.mean_, "cov": self.cov_, "duration": self.duration_, "noise": self.noise_}
        _io.write_json(path, "lfd.dmp.ProMP", params, fitted)

    @classmethod
    def load(cls, path) -> ProMP:
        """Read a ProMP written by :meth:`save` (without the per-demonstration ``weights_``).

        Raises:
            FileNotFoundError: no such file.
            ValueError: not a ProMP file, or inconsistent contents (named in the message).
        """
        params, fitted = _io.read_json(path, "lfd.dmp.ProMP")
        try:
            promp = cls(**params)
            if fitted is not None:
                promp.from_weight_distribution(fitted["mean"], fitted["cov"], fitted["duration"])
                promp.noise_ = checks.check_float(fitted["noise"], "noise", low=0.0)
        except (TypeError, KeyError, ValueError) as exc:
            raise ValueError(f"{path}: bad ProMP contents: {exc}") from exc
        return promp

    # --- state-space distribution -------------------------------------------------------

    def _phase_basis(self, t, name: str = "t", min_samples: int = 1) -> torch.Tensor:
        """``(T, K)`` basis at times ``t`` (units of fit's ``t``, from the motion's start)."""
        self._check_fitted()
        times = checks.finite_array(t, name, ndim=(0, 1)).reshape(-1)
        if times.shape[0] < min_samples:
            raise ValueError(f"{name} needs at least {min_samples} samples, got {times.shape[0]}")
        return promp_basis(torch.from_numpy(times / self.duration_), self.n_basis, self.overlap)

    def _blocks(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Mean ``(D, K)`` and covariance ``(D, K, D, K)`` as tensors."""
        self._check_fitted()
        d, k = self.n_dims_, self.n_basis
        return torch.from_numpy(self.mean_).reshape(d, k), torch.from_numpy(self.cov_).reshape(d, k, d, k)

    def mean_trajectory(self, t) -> np.ndarray:
        """Mean positions ``(T, D)`` at times ``t`` ``(T,)`` (units of fit's ``t``, from the start)."""
        mean, _ = self._blocks()
        return (self._phase_basis(t) @ mean.T).numpy()

    def var_trajectory(self, t) -> np.ndarray:
        """Marginal variances ``(T, D)`` (squared units of ``y``, clipped at 0) at times ``t`` ``(T,)``."""
        basis = self._phase_basis(t)
        _, cov = self._blocks()
        diagonal = torch.diagonal(cov, dim1=0, dim2=2).permute(2, 0, 1)  # (D, K, K)
        return torch.einsum("tk,dkl,tl->td", basis, diagonal, basis).clamp_min(0.0).numpy()

    def cov_trajectory(self, t) -> np.ndarray:
        """Covariance ``(T, D, T, D)`` of the positions at times ``t`` ``(T,)``."""
        basis = self._phase_basis(t)
        _, cov = self._blocks()
        return torch.einsum("tk,dkel,ul->tdue", basis, cov, basis).numpy()

    def sample_trajectories(self, t, n: int, rng=None) -> np.ndarray:
        """``n`` trajectories ``(n, T, D)`` drawn from the ProMP at times ``t`` ``(T,)``.

        Args:
            rng: ``numpy.random.Generator``, seed or ``None``.
        """
        n = checks.positive_int(n, "n")
        basis = self._phase_basis(t)
        rng = np.random.default_rng(rng)
        factor = torch.from_numpy(self._factor())  # (P, r)
        normal = torch.from_numpy(rng.standard_normal((n, factor.shape[1])))
        weights = torch.from_numpy(self.mean_) + normal @ factor.T  # (n, P)
        return (weights.reshape(n, self.n_dims_, self.n_basis) @ basis.T).transpose(1, 2).numpy()

    def _factor(self) -> np.ndarray:
        """``L`` ``(P, r)`` with ``L L^T = cov_`` over the positive eigenvalues (PSD-safe)."""
        values, vectors = np.linalg.eigh(self.cov_)
        keep = values > values.max(initial=0.0) * self.cov_.shape[0] * np.finfo(float).eps
        return vectors[:, keep] * np.sqrt(values[keep])

    # --- conditioning and likelihood ---------------------------------------------------

    def condition(self, t_star, y_star, y_cov=0.0) -> ProMP:
        """A new ProMP conditioned on positions ``y_star`` at times ``t_star`` (via points, goal, start).

        Gaussian conditioning of the weights on all ``M`` observations at once (Paraschos et al.
        2013, eq. 5-6; the same as conditioning one point after another):
        ``L = cov Psi^T (y_cov + Psi cov Psi^T)^+``, ``mean' = mean + L (y* - Psi mean)``,
        ``cov' = cov - L Psi cov`` (pseudo-inverse: a singular weight covariance with ``y_cov = 0``
        is handled, the result is symmetrised).

        Args:
            t_star: time or ``(M,)`` times (units of fit's ``t``, from the start).
            y_star: ``(D,)`` or ``(M, D)`` positions.
            y_cov: observation covariance: a number (variance, all DoF), ``(D, D)`` shared,
                or ``(M, D, D)``; 0 (default) passes the points exactly.

        Raises:
            ValueError: shapes that do not match ``M``/``D``, NaN, a negative variance.
        """
        self._check_fitted()
        times = checks.finite_array(t_star, "t_star", ndim=(0, 1)).reshape(-1)
        d, m = self.n_dims_, times.shape[0]
        targets = checks.finite_array(y_star, "y_star", ndim=(1, 2))
        targets = targets[None] if targets.ndim == 1 else targets
        if targets.shape != (m, d):
            raise ValueError(
                f"y_star must have shape ({d},) or (M, {d}) with M = len(t_star) = {m}, got {np.shape(y_star)}"
            )
        noise = self._observation_cov(y_cov, m)
        basis = self._phase_basis(times, "t_star")  # (M, K)
        # observation matrix (M D, D K): row (j, d) reads DoF d at time j
        observe = np.einsum("jk,de->jdek", basis.numpy(), np.eye(d)).reshape(m * d, d * self.n_basis)
        cross = self.cov_ @ observe.T  # (P, M D); small dense algebra: numpy beats torch's overhead here
        innovation = observe @ cross
        for j in range(m):
            innovation[j * d : (j + 1) * d, j * d : (j + 1) * d] += noise[j]
        gain = cross @ np.linalg.pinv(innovation, hermitian=True)
        new_mean = self.mean_ + gain @ (targets.reshape(-1) - observe @ self.mean_)
        new_cov = self.cov_ - gain @ cross.T
        conditioned = copy.copy(self)
        conditioned.mean_ = new_mean
        conditioned.cov_ = 0.5 * (new_cov + new_cov.T)
        return conditioned

    def _observation_cov(self, y_cov, m: int) -> np.ndarray:
        """``(M, D, D)`` observation covariance from a number, ``(D, D)`` or ``(M, D, D)``."""
        d = self.n_dims_
        cov = checks.finite_array(y_cov, "y_cov", ndim=(0, 2, 3))
        if cov.ndim == 0:
            if cov < 0:
                raise ValueError(f"y_cov must be >= 0, got {float(cov)}")
            cov = cov * np.eye(d)
        if cov.shape[-2:] != (d, d) or (cov.ndim == 3 and cov.shape[0] != m):
            raise ValueError(f"y_cov must be a number, ({d}, {d}) or ({m}, {d}, {d}), got shape {cov.shape}")
        if np.any(np.diagonal(cov, axis1=-2, axis2=-1) < 0):
            raise ValueError("y_cov must have non-negative variances")
        return np.broadcast_to(cov, (m, d, d)).copy()

    def log_likelihood(self, t, y, noise: float | None = None) -> float | np.ndarray:
        """Log-density of trajectories under the ProMP with isotropic observation noise.

        ``vec(y) ~ N(Psi mean_, Psi cov_ Psi^T + noise^2 I)`` over all ``T D`` values, evaluated
        with the Woodbury identity (cost O(T D r^2), ``r`` the rank of ``cov_``).

        Args:
            t: ``(T,)`` sample times (units of fit's ``t``, from the start).
            y: ``(T, D)`` trajectory or ``(B, T, D)`` batch sharing ``t``.
            noise: observation noise standard deviation (units of ``y``, > 0); default
                ``noise_``, the RMS residual of the fit.

        Returns:
            A float for ``(T, D)``, ``(B,)`` array for a batch (nats).

        Raises:
            ValueError: shapes that do not match, NaN, ``noise <= 0`` (also a zero default).
        """
        basis = self._phase_basis(t, min_samples=1)
        trajectories = checks.finite_array(y, "y", ndim=(2, 3))
        single = trajectories.ndim == 2
        batch = trajectories[None] if single else trajectories
        if batch.shape[1:] != (basis.shape[0], self.n_dims_):
            raise ValueError(
                f"y must have shape (T, D) or (B, T, D) with (T, D) = ({basis.shape[0]}, {self.n_dims_}), "
                f"got {trajectories.shape}"
            )
        sigma = self.noise_ if noise is None else noise
        variance = checks.positive_float(sigma, "noise") ** 2
        mean, _ = self._blocks()
        residual = torch.from_numpy(batch) - basis @ mean.T  # (B, T, D)
        factor = torch.from_numpy(self._factor()).reshape(self.n_dims_, self.n_basis, -1)  # (D, K, r)
        response = torch.einsum("tk,dkr->tdr", basis, factor).reshape(-1, factor.shape[-1])  # (T D, r)
        flat = residual.reshape(residual.shape[0], -1)  # (B, T D), time-major like response
        inner = torch.eye(response.shape[1], dtype=_DTYPE) + response.T @ response / variance
        chol = torch.linalg.cholesky(inner)
        projected = torch.cholesky_solve((flat @ response).T, chol)  # (r, B)
        quad = ((flat**2).sum(-1) - ((flat @ response) * projected.T).sum(-1) / variance) / variance
        size = flat.shape[1]
        logdet = size * math.log(variance) + 2.0 * torch.log(torch.diagonal(chol)).sum()
        values = (-0.5 * (size * math.log(2.0 * math.pi) + logdet + quad)).numpy()
        return float(values[0]) if single else values
