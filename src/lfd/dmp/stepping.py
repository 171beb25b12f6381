"""Step-wise integration of discrete DMPs, for online execution (goal or obstacles that change).

One step advances the transformation system over ``dt`` seconds with the same exact
discretisation as the closed-form rollout (:mod:`lfd.dmp.transform`): the spring-damper in
closed form, the forcing input held piecewise-linearly over each of ``substeps`` equal
sub-steps (:func:`lfd.dmp.transform.substeps`). Coupling terms (:mod:`lfd.dmp.coupling`)
are evaluated at the start of each sub-step and held there; a term with a ``project``
method (joint limits) then constrains the state after the sub-step. With no coupling and a
fixed goal, stepping through a grid with
``substeps = transform.substeps(dt / tau)`` reproduces :meth:`lfd.dmp.DMP.rollout` on that
grid to rounding (tested to 1e-6).

The goal may change between steps: the spring pulls towards the new goal at once, and in
the ``"pastor"`` formulation the ``- K (g - y0) s`` term uses it too, so the motion blends
smoothly to the new goal; ``y0`` (the start of the movement) stays fixed.

Shapes: ``B`` batch (optional), ``D`` DoF, ``K`` bases; positions in the units of the
demonstration, velocities in units/s, times in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch

from lfd import checks

from .canonical import discrete_centres, discrete_widths
from .formulation import scale_weights
from .gains import DiscreteGains
from .transform import _hold_gains, grid_substeps, transition

__all__ = ["DMPRunner", "DMPState", "advance", "coupled_rollout", "integrate"]


@dataclass(frozen=True)
class DMPState:
    """State of a running discrete DMP.

    Attributes:
        y: ``(D,)`` or ``(B, D)`` positions.
        yd: same shape, velocities in units/s.
        t: elapsed time since the start of the movement, seconds.
    """

    y: np.ndarray
    yd: np.ndarray
    t: float = 0.0


def _coupling_acceleration(coupling, y: np.ndarray, yd: np.ndarray) -> np.ndarray:
    total = np.zeros_like(y)
    for term in coupling:
        total = total + np.asarray(term(y, yd), dtype=np.float64)
    return total


class _Stepper:
    """Per-(step length) matrices and per-phase features of one DMP, reused across steps."""

    def __init__(self, n_basis: int, gains: DiscreteGains):
        self.n_basis, self.gains = n_basis, gains
        self._matrices: dict[float, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        centres = discrete_centres(n_basis, gains.alpha_s)
        self._centres, self._widths = centres.numpy(), discrete_widths(centres, gains.overlap).numpy()

    def matrices(self, h: float):
        if h not in self._matrices:
            if len(self._matrices) > 64:  # many distinct step lengths (jittery control loop)
                self._matrices.clear()
            step = torch.tensor(h, dtype=torch.float64)
            e = transition(step, self.gains.alpha_z, self.gains.beta_z).numpy()
            g0, g1 = (g.numpy() for g in _hold_gains(step, self.gains.alpha_z, self.gains.beta_z))
            self._matrices[h] = (e, g0, g1)
        return self._matrices[h]

    def features(self, theta: np.ndarray) -> np.ndarray:
        """``(T, K)`` features ``s softmax(log psi)`` at normalised times ``theta`` ``(T,)``, as
        :func:`lfd.dmp.canonical.discrete_features` (numpy, for the per-step loop)."""
        s = np.exp(-self.gains.alpha_s * theta)[:, None]
        log_psi = -self._widths * (s - self._centres) ** 2
        psi = np.exp(log_psi - log_psi.max(axis=-1, keepdims=True))
        return s * psi / psi.sum(axis=-1, keepdims=True)

    def advance(self, y, yd, theta0, h, v, goal, tau, coupling):
        """One sub-step of normalised length ``h`` from normalised time ``theta0``."""
        e, g0, g1 = self.matrices(h)
        x = self.features(np.array([theta0, theta0 + h]))  # (2, K)
        force0 = np.einsum("k,...dk->...d", x[0], v)
        force1 = np.einsum("k,...dk->...d", x[1], v)
        if coupling:
            extra = tau**2 * _coupling_acceleration(coupling, y, yd)
            force0, force1 = force0 + extra, force1 + extra
        err, z = y - goal, tau * yd
        err1 = e[0, 0] * err + e[0, 1] * z + g0[0] * force0 + g1[0] * force1
        z1 = e[1, 0] * err + e[1, 1] * z + g0[1] * force0 + g1[1] * force1
        y1, yd1 = goal + err1, z1 / tau
        for term in coupling:
            project = getattr(term, "project", None)
            if project is not None:  # hard constraints (e.g. joint limits)
                y1, yd1 = project(y1, yd1)
        return y1, yd1


def advance(
    state: DMPState,
    dt: float,
    *,
    y0,
    goal,
    weights,
    tau: float,
    n_basis: int,
    gains: DiscreteGains,
    formulation: str,
    coupling=(),
    substeps: int = 1,
    stepper: _Stepper | None = None,
) -> DMPState:
    """Advance ``state`` by ``dt`` seconds (pure function; see the module docstring).

    Args:
        state: current :class:`DMPState`.
        dt: step in seconds (> 0).
        y0: ``(D,)``/``(B, D)`` start of the movement; goal: ``(D,)``/``(B, D)`` current goal.
        weights: ``(D, K)``/``(B, D, K)``; tau: duration in seconds.
        coupling: iterable of coupling terms ``(y, yd) -> acceleration`` (units/s^2).
        substeps: equal sub-steps per step (>= 1).
    """
    dt = checks.positive_float(dt, "dt")
    substeps = checks.positive_int(substeps, "substeps")
    stepper = _Stepper(n_basis, gains) if stepper is None else stepper
    v = scale_weights(
        np.asarray(weights, dtype=np.float64),
        np.asarray(y0),
        np.asarray(goal),
        formulation,
        gains.alpha_z * gains.beta_z,
    )
    y, yd = np.asarray(state.y, dtype=np.float64), np.asarray(state.yd, dtype=np.float64)
    h = dt / tau / substeps
    theta = state.t / tau
    coupling = tuple(coupling)
    for i in range(substeps):
        y, yd = stepper.advance(y, yd, theta + i * h, h, v, np.asarray(goal, dtype=np.float64), tau, coupling)
    return DMPState(y, yd, state.t + dt)


def integrate(
    t: np.ndarray,
    *,
    y0,
    goal,
    weights,
    tau: float,
    yd0,
    n_basis: int,
    gains: DiscreteGains,
    formulation: str,
    coupling=(),
    substeps: int = 1,
):
    """Positions and velocities ``(..., T, D)`` on the grid ``t`` (seconds, from ``t[0]``) by stepping.

    Inputs broadcast like :func:`lfd.dmp.rollout_batch`; used when coupling terms make the
    motion nonlinear (then the closed-form map does not apply).
    """
    y0, goal, weights = (np.asarray(x, dtype=np.float64) for x in (y0, goal, weights))
    batch = np.broadcast_shapes(
        y0.shape, goal.shape, weights.shape[:-1], () if yd0 is None else np.shape(yd0)
    )
    start = np.broadcast_to(y0, batch).copy()
    velocity = (
        np.zeros(batch) if yd0 is None else np.broadcast_to(np.asarray(yd0, dtype=np.float64), batch).copy()
    )
    state = DMPState(start, velocity, 0.0)
    stepper = _Stepper(n_basis, gains)
    positions, velocities = [state.y], [state.yd]
    for dt in np.diff(t):
        state = advance(
            state,
            float(dt),
            y0=y0,
            goal=goal,
            weights=weights,
            tau=tau,
            n_basis=n_basis,
            gains=gains,
            formulation=formulation,
            coupling=coupling,
            substeps=substeps,
            stepper=stepper,
        )
        positions.append(state.y)
        velocities.append(state.yd)
    return np.stack(positions, axis=-2), np.stack(velocities, axis=-2)


def coupled_rollout(
    times: np.ndarray,
    y0,
    goal,
    tau,
    weights,
    yd0,
    coupling,
    return_derivatives: bool,
    *,
    n_basis: int,
    gains: DiscreteGains,
    formulation: str,
):
    """The rollout of :meth:`lfd.dmp.DMP.rollout` and :func:`lfd.dmp.rollout_batch` with coupling terms.

    Integrated step-wise (:func:`integrate`) on the validated grid ``times`` ``(T,)`` (seconds,
    the motion starting at ``times[0]``), refined like the closed form
    (:func:`lfd.dmp.transform.grid_substeps`); numpy in and out, vectorised over the batch.
    Returns positions ``(..., T, D)``, or with ``return_derivatives`` also velocities (units/s)
    and accelerations (units/s^2, by finite differences).

    Raises:
        ValueError: a tensor input (the coupled rollout is not differentiable), bad shapes,
            NaN/inf, ``tau <= 0``, or fewer than 3 samples with ``return_derivatives``.
    """
    if isinstance(tau, torch.Tensor) or any(isinstance(x, torch.Tensor) for x in (y0, goal, weights, yd0)):
        raise ValueError("coupling terms need numpy inputs (the coupled rollout is not differentiable)")
    arrays = {"y0": (y0, (1, 2)), "goal": (goal, (1, 2)), "weights": (weights, (2, 3))}
    if yd0 is not None:
        arrays["yd0"] = (yd0, (1, 2))
    values = {name: checks.finite_array(x, name, ndim=dims) for name, (x, dims) in arrays.items()}
    tau = checks.positive_float(float(tau), "tau")
    positions, velocities = integrate(
        times - times[0],
        y0=values["y0"],
        goal=values["goal"],
        weights=values["weights"],
        tau=tau,
        yd0=values.get("yd0"),
        n_basis=n_basis,
        gains=gains,
        formulation=formulation,
        coupling=coupling,
        substeps=grid_substeps(torch.from_numpy(times / tau)),
    )
    if not return_derivatives:
        return positions
    if times.shape[0] < 3:
        raise ValueError("return_derivatives with coupling needs at least 3 samples")
    return positions, velocities, np.gradient(velocities, times, axis=-2, edge_order=2)


class DMPRunner:
    """Online execution of a fitted :class:`lfd.dmp.DMP`: call :meth:`step` once per control cycle.

    The goal (``runner.goal``, or ``step(dt, goal=...)``) and the coupling terms
    (``runner.coupling``, a list; obstacles may be moved by changing their ``points``) may
    change between steps; everything else is fixed when the runner is made.

    Args:
        dmp: a fitted (or fully specified) :class:`lfd.dmp.DMP`.
        y0, goal, tau, weights: as in :meth:`lfd.dmp.DMP.rollout` (default the learned ones).
        yd0: start velocity in units/s (default the learned ``yd0_``, at rest).
        coupling: coupling terms, see :mod:`lfd.dmp.coupling`.
        substeps: equal sub-steps per :meth:`step`; with
            ``lfd.dmp.transform.substeps(dt / tau)`` stepping through a grid of step ``dt``
            seconds reproduces ``dmp.rollout(t=t)``.

    Example:
        >>> import numpy as np
        >>> from lfd.dmp import DMP, DMPRunner
        >>> t = np.linspace(0.0, 1.0, 101)
        >>> dmp = DMP(n_basis=10).fit(t, np.stack([np.sin(t), t**2], -1))
        >>> runner = DMPRunner(dmp, substeps=transform.substeps(0.01))
        >>> for k in range(100):
        ...     state = runner.step(0.01, goal=[1.0, 1.5] if k >= 50 else None)  # new goal mid-motion
        >>> state.y.shape
        (2,)
    """

    def __init__(
        self, dmp, y0=None, goal=None, tau=None, weights=None, yd0=None, coupling=(), substeps: int = 1
    ):
        self.dmp = dmp
        self.y0 = checks.finite_array(dmp._fitted("y0", y0), "y0", ndim=(1, 2))
        self.goal = checks.finite_array(dmp._fitted("goal", goal), "goal", ndim=(1, 2))
        self.tau = checks.positive_float(float(dmp._fitted("tau", tau)), "tau")
        self.weights = checks.finite_array(dmp._fitted("weights", weights), "weights", ndim=(2, 3))
        if self.weights.shape[-1] != dmp.n_basis:
            raise ValueError(
                f"weights must end with K = {dmp.n_basis} basis functions, got {self.weights.shape}"
            )
        for name, value in (("y0", self.y0), ("goal", self.goal)):
            if value.shape[-1] != self.weights.shape[-2]:
                raise ValueError(f"{name} must have {self.weights.shape[-2]} DoF, got shape {value.shape}")
        if yd0 is None:
            yd0 = getattr(dmp, "yd0_", None)
        start_velocity = (
            np.zeros_like(self.y0) if yd0 is None else checks.finite_array(yd0, "yd0", ndim=(1, 2))
        )
        batch = np.broadcast_shapes(
            self.y0.shape, self.goal.shape, self.weights.shape[:-1], start_velocity.shape
        )
        self.coupling = list(coupling)
        self.substeps = checks.positive_int(substeps, "substeps")
        self._start = DMPState(
            np.broadcast_to(self.y0, batch).copy(), np.broadcast_to(start_velocity, batch).copy()
        )
        self.state = self._start
        self._stepper = _Stepper(dmp.n_basis, dmp.gains)

    def step(self, dt: float, goal=None) -> DMPState:
        """Advance by ``dt`` seconds (optionally switching to a new ``goal`` first); returns the new state."""
        if goal is not None:
            goal = checks.finite_array(goal, "goal", ndim=(1, 2))
            if goal.shape[-1] != self.goal.shape[-1]:
                raise ValueError(f"goal must have {self.goal.shape[-1]} DoF, got shape {goal.shape}")
            self.goal = goal
        self.state = advance(
            self.state,
            dt,
            y0=self.y0,
            goal=self.goal,
            weights=self.weights,
            tau=self.tau,
            n_basis=self.dmp.n_basis,
            gains=self.dmp.gains,
            formulation=self.dmp.formulation,
            coupling=self.coupling,
            substeps=self.substeps,
            stepper=self._stepper,
        )
        return self.state

    def reset(self, state: DMPState | None = None) -> DMPState:
        """Restart from ``state`` (default: the start, at the start velocity)."""
        self.state = self._start if state is None else replace(state)
        return self.state
