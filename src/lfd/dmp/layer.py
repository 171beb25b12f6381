"""Differentiable discrete-DMP layer: DMP parameters in, trajectories out."""

from __future__ import annotations

from contextlib import nullcontext

import torch
from torch import Tensor, nn

from lfd import checks

from .formulation import DEFAULT_FORMULATION, check_formulation
from .functional import discrete_rollout, operator_for, time_grid
from .gains import DiscreteGains
from .transform import RolloutOperator

__all__ = ["DMPLayer"]


class DMPLayer(nn.Module):
    """Batched, differentiable rollout of discrete DMPs on a fixed uniform time grid.

    The trajectory is an exact linear function of the start, goal and weights (see
    :mod:`lfd.dmp.transform`); the matrices for the default ``tau`` are precomputed in
    float64 and kept as (non-persistent) buffers, so ``forward`` is a few batched matrix
    products with no loop over the batch or over time, and it agrees with
    :meth:`lfd.dmp.DMP.rollout` on the same parameters to float64 rounding.

    Args:
        n_basis: number of basis functions ``K`` per DoF.
        n_steps: number of output samples ``T`` (the first one is the start).
        dt: sample spacing in seconds; the grid is ``t = arange(T) * dt``.
        alpha_z, beta_z, alpha_s, overlap: DMP gains, as in :class:`lfd.dmp.DMP`.
        tau: default duration in seconds (default ``(T - 1) * dt``).
        formulation: ``"pastor"`` (default) or ``"ijspeert"``, as in :class:`lfd.dmp.DMP`
            (see :mod:`lfd.dmp.formulation`); weights must come from the same formulation.

    Buffers: ``t`` ``(T,)`` the output times in seconds; ``initial``, ``forced``,
    ``features`` the float64 operator matrices for the default ``tau``.

    Shapes: ``y0`` ``(B, D)``, ``goal`` ``(B, D)``, ``weights`` ``(B, D, K)`` ->
    ``(B, T, D)``. Works in the weights' dtype (float32 or float64; half-precision
    weights, e.g. a network's output under mixed-precision autocast, are rolled out in
    float32 with autocast off) and device; move the layer with ``.to(device)``.
    Gradients flow to ``y0``, ``goal``, ``weights`` and to ``tau`` when it is passed as a
    tensor (``()`` or ``(B,)``; then the matrices are rebuilt on every call, O(T * 128 * K)
    per distinct ``tau``). Inputs are shape-checked but not scanned for NaN, to keep the hot
    path free of host synchronisation.

    Example:
        >>> import torch
        >>> from lfd.dmp import DMPLayer
        >>> layer = DMPLayer(n_basis=20, n_steps=100, dt=0.04)
        >>> w = torch.zeros(8, 7, 20, requires_grad=True)
        >>> y = layer(torch.zeros(8, 7), torch.ones(8, 7), w)
        >>> y.shape
        torch.Size([8, 100, 7])
    """

    def __init__(
        self,
        n_basis: int,
        n_steps: int,
        dt: float,
        alpha_z: float = 25.0,
        beta_z: float | None = None,
        alpha_s: float | None = None,
        tau: float | None = None,
        overlap: float = 0.8,
        formulation: str = DEFAULT_FORMULATION,
    ):
        super().__init__()
        self.n_basis = checks.positive_int(n_basis, "n_basis")
        self.gains = DiscreteGains.resolve(alpha_z, beta_z, alpha_s, overlap)
        self.formulation = check_formulation(formulation)
        self._times = time_grid(None, n_steps, dt)
        if tau is None and n_steps < 2:
            raise ValueError("tau is required when n_steps == 1")
        self.tau = checks.positive_float((n_steps - 1) * dt if tau is None else tau, "tau")
        operator = operator_for(self._times, self.tau, self.n_basis, self.gains, torch.float64, "cpu")
        self.register_buffer("t", torch.from_numpy(self._times.copy()), persistent=False)
        self.register_buffer("initial", operator.initial.clone(), persistent=False)
        self.register_buffer("forced", operator.forced.clone(), persistent=False)
        self.register_buffer("features", operator.features.clone(), persistent=False)

    @property
    def n_steps(self) -> int:
        """Number of output samples ``T``."""
        return int(self._times.shape[0])

    def extra_repr(self) -> str:
        return (
            f"n_basis={self.n_basis}, n_steps={self.n_steps}, tau={self.tau}, gains={self.gains}, "
            f"formulation={self.formulation!r}"
        )

    def operator(self, tau=None, dtype: torch.dtype = torch.float64, device=None) -> RolloutOperator:
        """Rollout operator for the default ``tau`` (buffers) or a given one, in ``dtype``."""
        device = self.forced.device if device is None else device
        if tau is None:
            tau_tensor = torch.tensor(self.tau, dtype=torch.float64, device=self.forced.device)
            operator = RolloutOperator(
                self.initial, self.forced, self.features, tau_tensor, self.gains.alpha_z, self.gains.beta_z
            )
            return operator.to(dtype, device)
        return operator_for(self._times, tau, self.n_basis, self.gains, dtype, device)

    def forward(
        self, y0: Tensor, goal: Tensor, weights: Tensor, tau=None, return_derivatives: bool = False, yd0=None
    ):
        """Roll out ``B`` DMPs.

        Args:
            y0: ``(B, D)`` start positions.
            goal: ``(B, D)`` goals.
            weights: ``(B, D, K)`` forcing weights.
            tau: ``None`` (layer default), a float, or a tensor ``()``/``(B,)`` in seconds.
            return_derivatives: also return velocity and acceleration.
            yd0: ``(B, D)`` start velocity in units/s (default: at rest).

        Returns:
            ``(B, T, D)`` positions, or ``(y, dy/dt, d2y/dt2)`` (units, units/s, units/s^2).
        """
        if weights.ndim != 3 or weights.shape[-1] != self.n_basis:
            raise ValueError(f"weights must have shape (B, D, {self.n_basis}), got {tuple(weights.shape)}")
        for name, value in (("y0", y0), ("goal", goal), ("yd0", y0 if yd0 is None else yd0)):
            if value.shape != weights.shape[:2]:
                raise ValueError(
                    f"{name} must have shape {tuple(weights.shape[:2])} (B, D), got {tuple(value.shape)}"
                )
        if isinstance(tau, Tensor) and not (tau.ndim == 0 or tau.shape == weights.shape[:1]):
            raise ValueError(
                f"tau must be a scalar or have shape ({weights.shape[0]},), got {tuple(tau.shape)}"
            )
        if tau is not None and not isinstance(tau, Tensor):
            tau = checks.positive_float(tau, "tau")
        # Mixed precision (autocast, float16 / bfloat16 heads): the rollout's matrix products
        # would run in half precision, where the forcing term overflows float16 (inf -> NaN)
        # and bfloat16 keeps ~3 digits of a joint angle; so it runs outside autocast in float32.
        dtype = weights.dtype if weights.dtype in (torch.float32, torch.float64) else torch.float32
        device = weights.device.type
        with torch.autocast(device, enabled=False) if torch.is_autocast_enabled(device) else nullcontext():
            y0, goal, weights = y0.to(dtype), goal.to(dtype), weights.to(dtype)
            yd0 = None if yd0 is None else yd0.to(dtype)
            operator = self.operator(tau, dtype, weights.device)
            z0 = None if yd0 is None else yd0 * operator.tau[..., None]
            return discrete_rollout(
                operator, y0, goal, weights, return_derivatives, formulation=self.formulation, z0=z0
            )
