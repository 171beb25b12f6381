"""Pure functions over batches of discrete DMPs (torch or numpy in, same kind out).

:func:`rollout_batch` is the entry point for other packages (e.g. PoWER evaluates many
perturbed weight sets at once). It evaluates the exact linear map of
:mod:`lfd.dmp.transform`; operators for a time grid and a fixed ``tau`` are cached, so
repeated calls cost a few small matrix products and no Python loop over the batch.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import torch
from torch import Tensor

from lfd import checks

from .canonical import discrete_features
from .fitting import DEFAULT_RIDGE, TrajectoryFit
from .formulation import DEFAULT_FORMULATION, check_formulation, scale_weights
from .gains import DiscreteGains
from .stepping import coupled_rollout
from .transform import RolloutOperator, build_refined_operator

__all__ = ["clear_caches", "discrete_operator", "rollout_batch"]


def discrete_operator(t: Tensor, tau: Tensor, n_basis: int, gains: DiscreteGains) -> RolloutOperator:
    """Rollout operator of a discrete DMP on the time grid ``t``.

    Args:
        t: ``(T,)`` strictly increasing times in seconds; the motion starts at ``t[0]``.
        tau: ``()`` or ``(B,)`` temporal scaling in seconds (differentiable).
        n_basis: number of basis functions ``K``.
        gains: DMP gains.

    Returns:
        :class:`~lfd.dmp.transform.RolloutOperator` in the dtype of ``t`` (use float64).
    """
    theta = (t - t[0]) / tau[..., None]

    def features_of(times: Tensor) -> Tensor:
        return discrete_features(times, n_basis, gains.alpha_s, gains.overlap)

    return build_refined_operator(theta, features_of, tau, gains.alpha_z, gains.beta_z)


def grid_key(t: np.ndarray) -> bytes:
    """Hashable cache key of a float64 time grid."""
    return np.ascontiguousarray(t, dtype=np.float64).tobytes()


@lru_cache(maxsize=32)
def _cached_operator(t_bytes: bytes, tau: float, n_basis: int, gains: DiscreteGains) -> RolloutOperator:
    t = torch.from_numpy(np.frombuffer(t_bytes, dtype=np.float64).copy())
    return discrete_operator(t, torch.tensor(tau, dtype=torch.float64), n_basis, gains)


@lru_cache(maxsize=32)
def cached_trajectory_fit(
    t_bytes: bytes, tau: float, n_basis: int, gains: DiscreteGains, ridge: float = DEFAULT_RIDGE
) -> TrajectoryFit:
    """:class:`~lfd.dmp.fitting.TrajectoryFit` for a grid key from :func:`grid_key` (cached)."""
    return TrajectoryFit.from_operator(_cached_operator(t_bytes, tau, n_basis, gains), ridge)


def clear_caches() -> None:
    """Drop the cached operators and trajectory-fit solvers (e.g. to free memory or time a cold start)."""
    cached_trajectory_fit.cache_clear()
    _cached_operator.cache_clear()


def operator_for(t: np.ndarray, tau, n_basis: int, gains: DiscreteGains, dtype, device) -> RolloutOperator:
    """Operator for grid ``t`` (float64 numpy) and ``tau`` (float or tensor), in ``dtype`` on ``device``.

    A fixed scalar ``tau`` hits an LRU cache (keyed on the grid, ``tau``, ``K`` and gains);
    a tensor ``tau`` that needs gradients, or one ``tau`` per sample, is built on the fly
    (in float64, then cast, keeping the autograd graph).
    """
    if isinstance(tau, Tensor) and (tau.requires_grad or tau.ndim > 0):
        grid = torch.as_tensor(t, dtype=torch.float64, device=tau.device)
        return discrete_operator(grid, tau.to(torch.float64), n_basis, gains).to(dtype, device)
    return _cached_operator(grid_key(t), float(tau), n_basis, gains).to(dtype, device)


def discrete_scale(formulation: str, gains: DiscreteGains):
    """``(weights, y0, goal) -> v``: the amplitude-scaled weights of ``formulation`` (see
    :mod:`lfd.dmp.formulation`), as :func:`evaluate` expects."""
    stiffness = gains.alpha_z * gains.beta_z

    def scale(weights: Tensor, y0: Tensor, goal: Tensor, out: Tensor | None = None) -> Tensor:
        return scale_weights(weights, y0, goal, formulation, stiffness, out=out)

    return scale


def discrete_rollout(
    operator: RolloutOperator,
    y0: Tensor,
    goal: Tensor,
    weights: Tensor,
    return_derivatives: bool = False,
    *,
    formulation: str = DEFAULT_FORMULATION,
    z0: Tensor | None = None,
):
    """Discrete DMP trajectory from an operator (forcing weights scaled per ``formulation``).

    Args:
        operator: from :func:`discrete_operator` / :func:`operator_for`.
        y0, goal: ``(B, D)``; weights: ``(B, D, K)`` (any of them may have batch 1).
        formulation: see :mod:`lfd.dmp.formulation` (stiffness from the operator's gains).
        z0: ``(B, D)`` start scaled velocity ``tau dy/dt(0)``; ``None`` means at rest.

    Returns:
        ``(B, T, D)`` positions, or ``(y, dy/dt, d2y/dt2)``.
    """
    v = scale_weights(weights, y0, goal, formulation, operator.alpha_z * operator.beta_z)
    return operator.apply(y0, goal, v, z0, return_derivatives=return_derivatives)


def time_grid(t, n_steps, dt) -> np.ndarray:
    """Float64 time grid in seconds from either ``t`` ``(T,)`` or ``arange(n_steps) * dt``."""
    if (t is None) == (n_steps is None and dt is None):
        raise ValueError("pass either t (sample times) or both n_steps and dt")
    if t is not None:
        return checks.time_grid(t.detach().cpu().numpy() if isinstance(t, Tensor) else t, min_samples=1)
    steps = checks.positive_int(n_steps, "n_steps")
    return np.arange(steps, dtype=np.float64) * checks.positive_float(dt, "dt")


def _batch_size(vectors: dict, weights, tau) -> int | None:
    """Common batch size of the inputs (``None`` when none is batched), after shape checks.

    Args:
        vectors: per-DoF inputs by name (``y0``, ``goal``, ...), each ``(D,)`` or ``(B, D)``.
        weights: ``(D, K)`` or ``(B, D, K)``; tau: float or tensor ``()``/``(B,)``.
    """
    if weights.ndim not in (2, 3):
        raise ValueError(f"weights must have shape (D, K) or (B, D, K), got {tuple(weights.shape)}")
    n_dims = weights.shape[-2]
    for name, value in vectors.items():
        if value.ndim not in (1, 2) or value.shape[-1] != n_dims:
            raise ValueError(f"{name} must have shape ({n_dims},) or (B, {n_dims}), got {tuple(value.shape)}")
    tau_ndim = tau.ndim if isinstance(tau, Tensor) else 0
    if tau_ndim > 1:
        raise ValueError(f"tau must be a scalar or have shape (B,), got {tuple(tau.shape)}")
    sizes = {name: value.shape[0] for name, value in vectors.items() if value.ndim == 2}
    if weights.ndim == 3:
        sizes["weights"] = weights.shape[0]
    if tau_ndim == 1:
        sizes["tau"] = tau.shape[0]
    if len(set(sizes.values())) > 1:
        raise ValueError(f"batch sizes disagree: {sizes}")
    return next(iter(sizes.values()), None)


def _tau_value(tau):
    """A numpy/float ``tau``: finite and > 0, scalar or ``(B,)``; returns float or tensor."""
    value = checks.finite_array(tau, "tau", ndim=(0, 1))
    if np.any(value <= 0):
        raise ValueError(f"tau must be > 0 seconds, got {tau!r}")
    return float(value) if value.ndim == 0 else torch.from_numpy(value)


def _batch_shape(*tensors: Tensor | None) -> torch.Size:
    """The broadcast shape of ``(B or 1, D)`` tensors (``None`` skipped), without
    ``torch.broadcast_shapes``' Python overhead (tens of microseconds per call)."""
    shapes = [x.shape for x in tensors if x is not None]
    return torch.Size((max(s[0] for s in shapes), *shapes[0][1:]))


def evaluate(y0, goal, weights, t: np.ndarray, tau, make_operator, scale, yd0=None, return_derivatives=False):
    """Shared front end of every rollout: convert, check, broadcast, build, apply.

    Args:
        y0, goal, yd0: ``(D,)`` or ``(B, D)``; weights: ``(D, K)`` or ``(B, D, K)``;
            numpy/lists (validated, float64 numpy out) or tensors (tensor out).
        t: ``(T,)`` validated float64 time grid in seconds.
        tau: float, or tensor ``()``/``(B,)`` in seconds.
        make_operator: ``(t, tau, n_basis, dtype, device) -> RolloutOperator``.
        scale: ``(weights (B, D, K), y0 (B, D), goal (B, D), out=None) -> v (B, D, K)``, the
            amplitude-scaled weights fed to the operator (written into ``out`` when given:
            the operator's input buffer, used when no input needs gradients).
        yd0: start velocity in units/s (``None``: at rest).

    Returns:
        ``(B, T, D)`` (``(T, D)`` if nothing is batched), or the derivative triple.
    """
    named = {"y0": (y0, (1, 2)), "goal": (goal, (1, 2)), "weights": (weights, (2, 3))}
    if yd0 is not None:
        named["yd0"] = (yd0, (1, 2))
    as_numpy = not any(isinstance(x, Tensor) for x, _ in (*named.values(), (tau, None)))
    if as_numpy:
        values = {
            name: torch.from_numpy(checks.finite_array(x, name, ndim=dims, copy=False))
            for name, (x, dims) in named.items()
        }
    else:
        reference = next(x for x in (weights, y0, goal, tau) if isinstance(x, Tensor))
        values = {
            name: torch.as_tensor(x, dtype=reference.dtype, device=reference.device)
            for name, (x, _) in named.items()
        }
    if not isinstance(tau, Tensor):
        tau = _tau_value(tau)
    vectors = {name: value for name, value in values.items() if name != "weights"}
    unbatched = _batch_size(vectors, values["weights"], tau) is None
    values = {name: x if x.ndim == (3 if name == "weights" else 2) else x[None] for name, x in values.items()}
    weights = values["weights"]
    operator = make_operator(t, tau, weights.shape[-1], weights.dtype, weights.device)
    z0 = None if yd0 is None else values["yd0"] * operator.tau[..., None]
    y0, goal = values["y0"], values["goal"]
    batch = _batch_shape(y0, goal, weights[..., 0], z0)
    needs_grad = any(x.requires_grad for x in (*values.values(), *([] if z0 is None else [z0])))
    if needs_grad or weights.shape[:-1] != batch:
        v = scale(weights, y0, goal)
        outputs = operator.apply(y0, goal, v, z0, return_derivatives=return_derivatives)
    else:  # one weight set per sample: the scaled weights go straight into the operator's input columns
        inputs, slot = operator.input_buffer(y0, goal, z0, batch, weights.shape[-1])
        scale(weights, y0, goal, out=slot)
        outputs = operator.apply_inputs(inputs, z0 is not None, return_derivatives=return_derivatives)
    outputs = outputs if return_derivatives else (outputs,)
    if unbatched:
        outputs = tuple(x[0] for x in outputs)
    if as_numpy:
        outputs = tuple(x.numpy() for x in outputs)
    return outputs if return_derivatives else outputs[0]


def rollout_with_gains(
    y0,
    goal,
    weights,
    t: np.ndarray,
    tau,
    gains: DiscreteGains,
    return_derivatives=False,
    *,
    formulation,
    yd0=None,
):
    """:func:`rollout_batch` with an already validated grid ``t``, resolved gains and formulation."""

    def make_operator(times, tau_value, n_basis, dtype, device):
        return operator_for(times, tau_value, n_basis, gains, dtype, device)

    scale = discrete_scale(formulation, gains)
    return evaluate(y0, goal, weights, t, tau, make_operator, scale, yd0, return_derivatives)


def rollout_batch(
    y0,
    goal,
    weights,
    t=None,
    *,
    n_steps: int | None = None,
    dt: float | None = None,
    tau=None,
    alpha_z: float = 25.0,
    beta_z: float | None = None,
    alpha_s: float | None = None,
    overlap: float = 0.8,
    formulation: str = DEFAULT_FORMULATION,
    yd0=None,
    coupling=None,
    return_derivatives: bool = False,
):
    """Roll out a batch of discrete DMPs sharing one time grid.

    Shapes (``B`` batch, ``D`` DoF, ``K`` basis functions, ``T`` samples)::

        y0       (B, D) or (D,)        start positions (e.g. radians or metres)
        goal     (B, D) or (D,)        goal positions
        weights  (B, D, K) or (D, K)   forcing weights
        yd0      (B, D) or (D,)        start velocity in units/s (default: at rest)
        tau      float, () or (B,)     duration in seconds (default: t[-1] - t[0])
        ->       (B, T, D), or (T, D) when no input has a batch dimension

    Inputs without a batch dimension are shared by the whole batch (e.g. one start and
    goal, 1000 weight sets). Pass either ``t`` ``(T,)`` (seconds, strictly increasing,
    the motion starts at ``t[0]``, at rest unless ``yd0`` is given) or ``n_steps`` and
    ``dt`` (``t = arange(n_steps) * dt``). ``formulation`` (``"pastor"`` default, or
    ``"ijspeert"``) sets how the forcing term scales, see :mod:`lfd.dmp.formulation`; the
    weights must come from a fit with the same formulation.

    Backend: if any of ``y0, goal, weights, tau`` is a ``torch.Tensor``, all are used as
    tensors (dtype and device of the first tensor among ``weights, y0, goal, tau``) and
    the result is a tensor, differentiable w.r.t. ``y0``, ``goal``, ``weights`` and
    ``tau`` (tensor inputs are shape-checked only, to stay cheap on GPU). Otherwise numpy
    in, float64 numpy out, with NaN/inf and ``tau > 0`` checks.

    Args:
        coupling: coupling terms (:mod:`lfd.dmp.coupling`: obstacles, joint limits); the
            motion is then integrated step-wise on the same refined grid, vectorised over
            the batch (numpy inputs only; see :meth:`lfd.dmp.DMP.rollout`).
        return_derivatives: also return velocity (units/s) and acceleration (units/s^2),
            same shape as the positions.

    Returns:
        Positions, or ``(positions, velocities, accelerations)``.

    Example:
        >>> import numpy as np
        >>> from lfd.dmp import rollout_batch
        >>> w = np.random.default_rng(0).normal(size=(1000, 7, 20))
        >>> rollout_batch(np.zeros(7), np.ones(7), w, n_steps=100, dt=0.04).shape
        (1000, 100, 7)
    """
    gains = DiscreteGains.resolve(alpha_z, beta_z, alpha_s, overlap)
    formulation = check_formulation(formulation)
    times = time_grid(t, n_steps, dt)
    if tau is None:
        if times.shape[0] < 2:
            raise ValueError("tau is required when the time grid has a single sample")
        tau = times[-1] - times[0]
    if coupling:
        n_basis = checks.positive_int(np.shape(weights)[-1], "n_basis")
        return coupled_rollout(
            times,
            y0,
            goal,
            tau,
            weights,
            yd0,
            coupling,
            return_derivatives,
            n_basis=n_basis,
            gains=gains,
            formulation=formulation,
        )
    return rollout_with_gains(
        y0, goal, weights, times, tau, gains, return_derivatives, formulation=formulation, yd0=yd0
    )
