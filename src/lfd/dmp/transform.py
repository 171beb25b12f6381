"""Transformation system of a DMP as an exactly discretised linear system.

In normalised time ``theta = (t - t0) / tau`` and with ``e = y - g`` the transformation
system ``tau dz/dt = alpha_z (beta_z (g - y) - z) + f``, ``tau dy/dt = z`` reads

.. code-block:: text

    d/dtheta [e, z] = M [e, z] + [0, f],    M = [[0, 1], [-alpha_z beta_z, -alpha_z]]

a linear time-invariant system. Its solution on a time grid ``theta_0 < ... < theta_{T-1}``
is computed *exactly* for the spring-damper part (closed-form ``expm(M theta)``) and with a
first-order hold (piecewise-linear interpolation between samples) for the forcing input.
There is no integration step size to tune, the first sample is the start state, and any
(non-uniform) grid works.

Because the forcing term is linear in the (amplitude-scaled) weights ``v``, the whole
trajectory is a linear map of the start state, goal and weights:

.. code-block:: text

    y_n = g + E_ee(theta_n) (y0 - g) + E_ez(theta_n) z0 + Phi_e[n] @ v

:class:`RolloutOperator` holds these matrices for one time grid and one ``tau``; it is the
single implementation behind :meth:`lfd.dmp.DMP.rollout`, :func:`lfd.dmp.rollout_batch`
and :class:`lfd.dmp.DMPLayer`, and evaluating it is one matrix product, whatever the batch.

Building ``Phi`` (zero-state response to each forcing feature) involves no loop over time
steps: on a uniform grid it is one FFT convolution, O(T log T K); on other grids, all pairs
of samples inside blocks of :data:`BLOCK` samples with the state carried across blocks,
O(T BLOCK K). Both are differentiable w.r.t. ``tau`` (through ``theta``). Operators are
always *built* in float64 (the hold integrals involve cancellations that float32 cannot
resolve) and cast afterwards.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

__all__ = [
    "RolloutOperator",
    "build_operator",
    "build_refined_operator",
    "grid_substeps",
    "substeps",
    "transition",
]

#: Output samples per block on non-uniform grids: O(T * BLOCK * K) time, O(BLOCK^2)
#: memory, and a Python loop over T / BLOCK blocks.
BLOCK = 128

#: Grids whose steps agree to this relative tolerance are treated as uniform (FFT path).
UNIFORM_RTOL = 1e-9

#: Internal steps per unit of normalised time (per ``tau``) at least: every interval of a
#: coarser grid is subdivided equally when the operator is built and only the grid's own
#: rows are kept, so the first-order hold acts on a fine grid and a rollout at any sampling
#: agrees with the continuous solution (about 1e-5 of the motion's size) instead of carrying
#: the hold error of a 30-sample grid; fits on coarse grids then replay on fine grids as
#: they reproduce their samples. The subdivision depends on ``dt / tau`` only (not on the
#: number of samples), so temporal scaling stays exact and a longer grid starts with the
#: same samples as a shorter one; a batch with one ``tau`` per sample uses the finest
#: subdivision any of them needs (so it agrees with one rollout per ``tau`` to ~1e-6).
MIN_STEPS_PER_TAU = 1000


def transition(theta: Tensor, alpha_z: float, beta_z: float) -> Tensor:
    """State-transition matrix ``expm(M theta)`` of the unforced spring-damper.

    Args:
        theta: elapsed normalised time ``dt / tau`` (>= 0), any shape ``(...)``.
        alpha_z: damping gain (> 0).
        beta_z: spring gain (> 0).

    Returns:
        ``(..., 2, 2)`` matrices acting on the state ``[y - g, z]``.
    """
    mu = -0.5 * alpha_z
    q = 0.25 * alpha_z**2 - alpha_z * beta_z  # discriminant: 0 critically damped
    if q > 0.0:  # over-damped: two real modes, written to neither overflow nor cancel
        r = math.sqrt(q)
        slow = torch.exp((mu + r) * theta)
        fast_ratio = torch.exp(-2.0 * r * theta)
        cosine = 0.5 * slow * (1.0 + fast_ratio)
        sine = -0.5 * slow * torch.expm1(-2.0 * r * theta) / r
    elif q < 0.0:  # under-damped: damped oscillation
        omega = math.sqrt(-q)
        decay = torch.exp(mu * theta)
        cosine = decay * torch.cos(omega * theta)
        sine = decay * torch.sin(omega * theta) / omega
    else:  # critically damped (the default beta_z = alpha_z / 4)
        cosine = torch.exp(mu * theta)
        sine = cosine * theta
    half = 0.5 * alpha_z
    rows = (
        torch.stack([cosine + half * sine, sine], dim=-1),
        torch.stack([-alpha_z * beta_z * sine, cosine - half * sine], dim=-1),
    )
    return torch.stack(rows, dim=-2)


def _hold_gains(step: Tensor, alpha_z: float, beta_z: float) -> tuple[Tensor, Tensor]:
    """First-order-hold input gains of one step of normalised length ``step``.

    Over one step the state advances as ``x1 = E(h) x0 + G0 u0 + G1 u1`` when the input
    ``u`` varies linearly from ``u0`` to ``u1``. With ``J0 = int_0^h E(s) B ds`` and
    ``J1 = int_0^h s E(s) B ds`` (closed forms via ``M^-1``), ``G0 = J1 / h`` and
    ``G1 = J0 - J1 / h``.

    Returns:
        ``(G0, G1)``, each ``(..., 2)``.
    """
    e = transition(step, alpha_z, beta_z)
    e_ez, e_zz = e[..., 0, 1], e[..., 1, 1]
    stiffness = alpha_z * beta_z
    j0_e = (1.0 - e_zz - alpha_z * e_ez) / stiffness
    j0_z = e_ez
    j1_e = (step * (-alpha_z * e_ez - e_zz) + alpha_z * j0_e + j0_z) / stiffness
    j1_z = step * e_ez - j0_e
    g0 = torch.stack([j1_e, j1_z], dim=-1) / step[..., None]
    g1 = torch.stack([j0_e, j0_z], dim=-1) - g0
    return g0, g1


def _increments(theta: Tensor, features: Tensor, alpha_z: float, beta_z: float) -> Tensor:
    """``G0_m u_m + G1_m u_{m+1}``: state change over step ``m`` due to the input, ``(..., T-1, 2, K)``."""
    g0, g1 = _hold_gains(theta[..., 1:] - theta[..., :-1], alpha_z, beta_z)
    return g0[..., None] * features[..., :-1, None, :] + g1[..., None] * features[..., 1:, None, :]


def _is_uniform(theta: Tensor) -> bool:
    steps = theta[..., 1:] - theta[..., :-1]
    return bool(torch.allclose(steps, steps[..., :1].expand_as(steps), rtol=UNIFORM_RTOL, atol=0.0))


def _forced_response_uniform(theta: Tensor, features: Tensor, alpha_z: float, beta_z: float) -> Tensor:
    """Uniform grid (step ``h``): one FFT convolution of the features with a combined kernel.

    With constant hold gains, ``x_n = sum_{m<n} E((n-1-m) h) (G0 u_m + G1 u_{m+1})`` equals
    ``sum_{i<=n} c(n-i) u_i - E(n h) G1 u_0`` with ``c(j) = E(j h) G1 + E((j-1) h) G0``
    (second term only for ``j >= 1``).
    """
    n_steps = theta.shape[-1]
    step = theta[..., 1:2] - theta[..., :1]
    propagators = transition(
        step * torch.arange(n_steps, dtype=theta.dtype, device=theta.device), alpha_z, beta_z
    )
    g0, g1 = _hold_gains(step, alpha_z, beta_z)  # (..., 1, 2)
    from_end = (propagators @ g1[..., None])[..., 0]  # (..., T, 2): E(j h) G1
    from_start = (propagators @ g0[..., None])[..., 0]  # E(j h) G0
    kernel = from_end + torch.nn.functional.pad(from_start[..., :-1, :], (0, 0, 1, 0))
    size = 1 << (2 * n_steps - 2).bit_length()  # >= 2T - 1: linear, not circular, convolution
    spectrum = (
        torch.fft.rfft(kernel.movedim(-2, -1), n=size)[..., :, None, :]
        * torch.fft.rfft(features.movedim(-2, -1), n=size)[..., None, :, :]
    )  # (..., 2, K, F)
    states = torch.fft.irfft(spectrum, n=size)[..., 1:n_steps].movedim(-1, -3)  # (..., T-1, 2, K)
    states = states - from_end[..., 1:, :, None] * features[..., None, None, 0, :]
    return torch.cat([torch.zeros_like(states[..., :1, :, :]), states], dim=-3)  # x_0 = 0 exactly


def _forced_response_blocked(theta: Tensor, features: Tensor, alpha_z: float, beta_z: float) -> Tensor:
    """Any grid: all pairs inside blocks of :data:`BLOCK` rows, state carried across blocks."""
    n_steps, n_basis = features.shape[-2], features.shape[-1]
    increments = _increments(theta, features, alpha_z, beta_z)
    batch = increments.shape[:-3]
    state = features.new_zeros(*batch, 2, n_basis)
    blocks = [state[..., None, :, :]]
    for start in range(1, n_steps, BLOCK):
        stop = min(start + BLOCK, n_steps)
        size = stop - start
        rows = theta[..., start:stop]
        carried = transition(rows - theta[..., start - 1 : start], alpha_z, beta_z) @ state[..., None, :, :]
        lag = (rows[..., :, None] - rows[..., None, :]).clamp(min=0.0)
        causal = torch.ones(size, size, dtype=torch.bool, device=theta.device).tril()
        kernel = transition(lag, alpha_z, beta_z) * causal[:, :, None, None]
        kernel = kernel.transpose(-3, -2).reshape(*kernel.shape[:-4], 2 * size, 2 * size)
        local = kernel @ increments[..., start - 1 : stop - 1, :, :].reshape(*batch, 2 * size, n_basis)
        block = carried + local.reshape(*batch, size, 2, n_basis)
        blocks.append(block)
        state = block[..., -1, :, :]
    return torch.cat(blocks, dim=-3)


def _forced_response(theta: Tensor, features: Tensor, alpha_z: float, beta_z: float) -> Tensor:
    """Zero-state response of ``[e, z]`` to each forcing feature column, ``(..., T, 2, K)``.

    ``x_n = sum_{m < n} E(theta_n - theta_{m+1}) (G0_m u_m + G1_m u_{m+1})``: an FFT
    convolution on uniform grids (O(T log T K)), blocks of pairs otherwise (O(T BLOCK K)).

    Args:
        theta: ``(..., T)`` strictly increasing normalised times.
        features: ``(..., T, K)`` forcing features at those times.
    """
    if theta.shape[-1] < 2:
        return features.new_zeros(*features.shape[:-1], 2, features.shape[-1])
    if _is_uniform(theta):
        return _forced_response_uniform(theta, features, alpha_z, beta_z)
    return _forced_response_blocked(theta, features, alpha_z, beta_z)


@dataclass(frozen=True)
class RolloutOperator:
    """Linear map from (start state, goal, amplitude-scaled weights) to trajectories.

    Attributes:
        initial: ``(..., T, 2, 2)`` response of ``[y - g, z]`` to the start state ``[y0 - g, z0]``.
        forced: ``(..., T, 2, K)`` zero-state response of ``[y - g, z]`` to each feature.
        features: ``(..., T, K)`` forcing features at the samples (``f = features @ v``).
        tau: ``(...)`` temporal scaling in seconds.
        alpha_z, beta_z: transformation-system gains.

    The leading ``...`` is empty for a shared ``tau`` or ``(B,)`` for one ``tau`` per sample.
    """

    initial: Tensor
    forced: Tensor
    features: Tensor
    tau: Tensor
    alpha_z: float
    beta_z: float

    def to(self, dtype: torch.dtype, device: torch.device | str | None = None) -> RolloutOperator:
        """Copy of the operator with all tensors cast to ``dtype`` on ``device``."""
        return RolloutOperator(
            self.initial.to(dtype=dtype, device=device),
            self.forced.to(dtype=dtype, device=device),
            self.features.to(dtype=dtype, device=device),
            self.tau.to(dtype=dtype, device=device),
            self.alpha_z,
            self.beta_z,
        )

    def apply(
        self,
        y0: Tensor,
        goal: Tensor,
        v: Tensor,
        z0: Tensor | None = None,
        *,
        return_derivatives: bool = False,
    ):
        """Evaluate the trajectory.

        Every output is one matrix product: the rows ``[1, E_ee, E_ez, Phi_e]`` (positions;
        velocity and acceleration rows stacked below when requested) against the columns
        ``[g, y0 - g, z0, v]`` of every (sample, DoF) pair.

        Args:
            y0: ``(B, D)`` start positions.
            goal: ``(B, D)`` goals (spring targets).
            v: ``(B, D, K)`` forcing weights already multiplied by the amplitude
                (``w * (g - y0)`` for discrete DMPs, ``w * r`` for rhythmic ones).
            z0: ``(B, D)`` start scaled velocity ``tau * dy/dt(0)``; ``None`` means zero.
            return_derivatives: also return velocity and acceleration.

        Returns:
            Positions ``(B, T, D)``; with ``return_derivatives`` the tuple
            ``(y, dy/dt, d2y/dt2)`` in units of ``y``, ``y/s``, ``y/s^2``.
        """
        batch = torch.broadcast_shapes(
            y0.shape, goal.shape, v.shape[:-1], *([] if z0 is None else [z0.shape])
        )
        if any(x.requires_grad for x in (y0, goal, v, *([] if z0 is None else [z0]))):
            columns = [goal[..., None], (y0 - goal)[..., None], *([] if z0 is None else [z0[..., None]]), v]
            inputs = torch.cat([column.expand(*batch, column.shape[-1]) for column in columns], dim=-1)
        else:
            inputs, slot = self.input_buffer(y0, goal, z0, batch, v.shape[-1])
            slot.copy_(v)
        return self.apply_inputs(inputs, z0 is not None, return_derivatives=return_derivatives)

    def input_buffer(
        self, y0: Tensor, goal: Tensor, z0: Tensor | None, batch: torch.Size, n_weights: int
    ) -> tuple[Tensor, Tensor]:
        """The columns ``[g, y0 - g, (z0,) v]`` of :meth:`apply` as one new ``(*batch, C)`` tensor,
        the first ones written, and the ``(*batch, n_weights)`` view where ``v`` goes (to be
        filled in place, e.g. by :func:`lfd.dmp.formulation.scale_weights` with ``out=``).
        No autograd through the buffer: for inputs that need gradients use :meth:`apply`."""
        first = 2 + (z0 is not None)
        inputs = torch.empty(*batch, first + n_weights, dtype=goal.dtype, device=goal.device)
        inputs[..., 0] = goal
        inputs[..., 1] = y0 - goal
        if z0 is not None:
            inputs[..., 2] = z0
        return inputs, inputs[..., first:]

    def apply_inputs(self, inputs: Tensor, with_z0: bool, *, return_derivatives: bool = False):
        """:meth:`apply` on prepared columns ``inputs`` ``(..., D, C)`` (from :meth:`input_buffer`)."""
        response = self.initial[..., : 2 if with_z0 else 1]  # drop the z0 column when z0 is None
        zero = torch.zeros_like(response[..., 0, :1])

        def rows(first: Tensor, state: int) -> Tensor:
            return torch.cat([first, response[..., state, :], self.forced[..., state, :]], dim=-1)

        position = rows(torch.ones_like(zero), 0)
        if not return_derivatives:
            return _contract(position, inputs)
        tau = self.tau[..., None, None]
        scaled_velocity = rows(zero, 1)
        force = torch.nn.functional.pad(self.features, (inputs.shape[-1] - self.features.shape[-1], 0))
        acceleration = (
            force - self.alpha_z * self.beta_z * rows(zero, 0) - self.alpha_z * scaled_velocity
        ) / tau**2
        stacked = _contract(torch.cat([position, scaled_velocity / tau, acceleration], dim=-2), inputs)
        return stacked.split(position.shape[-2], dim=-2)


#: Outputs of at least this many elements are allocated by NumPy on the CPU (see :func:`_contract`).
LARGE_OUTPUT = 1 << 18


def _contract(rows: Tensor, inputs: Tensor) -> Tensor:
    """``(..., R, C)`` x ``(..., D, C)`` -> ``(..., R, D)`` as one (batched) GEMM.

    The result is a transposed view of ``inputs @ rows^T`` ``(..., D, R)``: no copy. A large
    CPU output without autograd for operator rows shared by the batch is computed as
    ``rows @ inputs^T`` ``(R, ... D)`` instead (a permuted view; faster for the skinny shapes of
    rollouts, 1.1-1.3x at R = 100..1000) into memory allocated by NumPy, which asks the kernel
    for huge pages (``madvise``): torch's first-touch page faults cost as much as the GEMM itself
    for 1000 rollouts of 1000 samples (benchmarks/dmp_speed.py). Values agree to rounding.
    """
    transposed = rows.transpose(-1, -2)
    dtypes = {torch.float64: np.float64, torch.float32: np.float32}
    plain = (
        inputs.device.type == "cpu"
        and rows.ndim == 2
        and inputs.dtype == rows.dtype in dtypes
        and not (torch.is_grad_enabled() and (inputs.requires_grad or rows.requires_grad))
    )
    if plain and inputs.numel() // inputs.shape[-1] * rows.shape[0] >= LARGE_OUTPUT:
        flat = inputs.reshape(-1, inputs.shape[-1])
        out = torch.from_numpy(np.empty((rows.shape[0], flat.shape[0]), dtype=dtypes[rows.dtype]))
        torch.mm(rows, flat.T, out=out)
        return out.view(rows.shape[0], *inputs.shape[:-1]).movedim(0, -2)
    return (inputs @ transposed).transpose(-1, -2)


def build_operator(
    theta: Tensor, features: Tensor, tau: Tensor, alpha_z: float, beta_z: float
) -> RolloutOperator:
    """Build the :class:`RolloutOperator` for one normalised time grid.

    Args:
        theta: ``(..., T)`` normalised times ``(t - t0) / tau``, strictly increasing, ``theta_0 = 0``.
        features: ``(..., T, K)`` forcing features at ``theta`` (see :mod:`lfd.dmp.canonical`).
        tau: ``(...)`` temporal scaling in seconds (only used for derivatives).
        alpha_z, beta_z: transformation-system gains.

    Returns:
        The operator, in the dtype of ``features`` (pass float64 for accuracy).
    """
    initial = transition(theta - theta[..., :1], alpha_z, beta_z)
    forced = _forced_response(theta, features, alpha_z, beta_z)
    return RolloutOperator(initial, forced, features, tau, alpha_z, beta_z)


def substeps(step: float, min_steps: int | None = None) -> int:
    """Equal subdivisions of an interval of normalised length ``step = dt / tau`` so that
    none exceeds ``1 / min_steps`` (default :data:`MIN_STEPS_PER_TAU`).

    Rounded with a relative slack of 1e-4, so that round steps (``dt / tau = 0.02``) do not
    sit on a switching point: the operator is smooth in ``tau`` (for gradients) except within
    1e-4 of the (non-round) values where the count changes.
    """
    min_steps = MIN_STEPS_PER_TAU if min_steps is None else min_steps
    return max(1, math.ceil(float(step) * min_steps * (1.0 - 1e-4)))


def grid_substeps(theta: Tensor) -> int:
    """:func:`substeps` for the largest interval of normalised times ``theta`` ``(..., T)``."""
    if theta.shape[-1] < 2:
        return 1
    return substeps(float((theta[..., 1:] - theta[..., :-1]).detach().max()))


def refine(theta: Tensor, factor: int) -> Tensor:
    """Split every interval of ``theta`` ``(..., T)`` into ``factor`` equal ones: ``(..., (T-1) factor + 1)``.

    Row ``n * factor`` of the result is ``theta[..., n]`` (differentiable w.r.t. ``theta``).
    """
    if factor == 1:
        return theta
    fractions = torch.arange(factor, dtype=theta.dtype, device=theta.device) / factor
    inner = theta[..., :-1, None] + (theta[..., 1:] - theta[..., :-1])[..., None] * fractions
    return torch.cat([inner.flatten(-2), theta[..., -1:]], dim=-1)


def build_refined_operator(
    theta: Tensor, features_of, tau: Tensor, alpha_z: float, beta_z: float, factor: int | None = None
) -> RolloutOperator:
    """:func:`build_operator` on ``theta`` refined ``factor`` times, keeping only the rows of ``theta``.

    Args:
        theta: ``(T,)`` or ``(B, T)`` normalised times, strictly increasing, ``theta_0 = 0``.
        features_of: ``theta (..., T') -> (..., T', K)`` forcing features.
        tau: ``()`` or ``(B,)`` temporal scaling in seconds.
        factor: subdivisions per interval; default :func:`grid_substeps` of each row of
            ``theta``, so that a batch with one ``tau`` per row equals one rollout per ``tau``.
    """
    if factor is None and theta.ndim == 2 and theta.shape[0] > 1 and theta.shape[-1] > 1:
        factors = [grid_substeps(row) for row in theta]
        if len(set(factors)) > 1:  # rows that need different subdivisions: one operator per group
            parts = {}
            for value in sorted(set(factors)):
                rows = torch.tensor([i for i, f in enumerate(factors) if f == value], device=theta.device)
                part = build_refined_operator(theta[rows], features_of, tau[rows], alpha_z, beta_z, value)
                parts[value] = (rows, part)
            order = torch.argsort(torch.cat([rows for rows, _ in parts.values()]))

            def gather(name: str) -> Tensor:
                return torch.cat([getattr(op, name) for _, op in parts.values()])[order]

            return RolloutOperator(
                gather("initial"), gather("forced"), gather("features"), tau, alpha_z, beta_z
            )
    factor = grid_substeps(theta) if factor is None else factor
    fine = refine(theta, factor)
    operator = build_operator(fine, features_of(fine), tau, alpha_z, beta_z)
    if factor == 1:
        return operator
    rows = slice(None, None, factor)
    return RolloutOperator(
        operator.initial[..., rows, :, :],
        operator.forced[..., rows, :, :],
        operator.features[..., rows, :],
        tau,
        alpha_z,
        beta_z,
    )
