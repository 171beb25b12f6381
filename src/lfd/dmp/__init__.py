"""Dynamic movement primitives: fitting, batched rollouts, online stepping, coupling, Cartesian poses.

Public API (numpy + torch only)::

    DMP(n_basis=20, alpha_z=25.0, beta_z=None, alpha_s=None, overlap=0.8,
        formulation="pastor", ridge=1e-12)
        .fit(t (T,), y (T, D) | (B, T, D), method="trajectory", yd0=None) -> self
        .rollout(t=None, y0=None, goal=None, tau=None, weights=None,
                 return_derivatives=False, yd0=None, coupling=None) -> (T, D) | (B, T, D)
        .step(state: DMPState, dt, goal=None, *, y0=None, tau=None, weights=None,
              coupling=(), substeps=1) -> DMPState
        .save(path) / DMP.load(path)
    DMPRunner(dmp, y0=None, goal=None, tau=None, weights=None, yd0=None, coupling=(),
              substeps=1).step(dt, goal=None) -> DMPState(y, yd, t)      # online execution
    ObstacleAvoidance(points (N, D), kind="park" | "hoffmann", gain=None, beta=None, dims=None)
    JointLimits(lower (D,), upper (D,), margin=None, gain=500.0, damping=30.0)
    CartesianDMP(n_basis=20, ..., formulation="pastor", ridge=1e-12, orientation="log" | "ude")
        .fit(t (T,), pose (T, 7) | (B, T, 7))        # [x, y, z, qw, qx, qy, qz]
        .rollout(t=None, start=None, goal=None, tau=None, weights=None) -> (T, 7) | (B, T, 7)
    DualCartesianDMP(n_basis=20, ..., formulation="pastor")     # two arms, Ude orientation
        .fit(t (T,), pose (T, 14) | (B, T, 14))       # [left x y z qw qx qy qz, right ...]
        .rollout(t=None, start=None, goal=None, tau=None, weights=None,
                 coupling=RelativePoseCoupling(desired (7,), leader_follower=(1, 1), k, c1, c2))
    FinalVelocityDMP(n_basis=20, alpha_z=25.0, beta_z=None, alpha_s=None, overlap=0.8, ridge=1e-12)
        .fit(t (T,), y (T, D) | (B, T, D))        # hitting: reaches goal_ with goal_velocity_ at tau
        .rollout(t=None, y0=None, goal=None, goal_velocity=None, tau=None, weights=None,
                 return_derivatives=False, yd0=None, ydd0=None, goal_acceleration=None)
    RhythmicDMP(n_basis=20, alpha_z=25.0, beta_z=None, overlap=0.8, ridge=1e-12)
        .fit(t, y, period=None, method="trajectory")
        .rollout(t=None, y0=None, goal=None, tau=None, weights=None,
                 return_derivatives=False, yd0=None, r=1.0)
    DMPLayer(n_basis, n_steps, dt, alpha_z=25.0, beta_z=None, alpha_s=None, tau=None,
             overlap=0.8, formulation="pastor")(y0 (B, D), goal (B, D), weights (B, D, K),
             tau=None, return_derivatives=False, yd0=None) -> (B, T, D)
    rollout_batch(y0, goal, weights, t=None, *, n_steps=None, dt=None, tau=None, alpha_z=25.0,
                  beta_z=None, alpha_s=None, overlap=0.8, formulation="pastor", yd0=None,
                  coupling=None, return_derivatives=False)
    FORMULATIONS, DEFAULT_FORMULATION, DEFAULT_RIDGE, FIT_METHODS
    clear_caches()   # drop the per-time-grid operators cached by fits and rollouts
    ProMP(n_basis=10, overlap=0.7, ridge=1e-12, cov_reg=0.0)          # probabilistic MP
        .fit(t (T,) | (N, T) | [t_i], Y (N, T, D) | [(T_i, D)]) -> self   # mean_, cov_ of weights
        .mean_trajectory(t) (T, D), .var_trajectory(t) (T, D), .cov_trajectory(t) (T, D, T, D)
        .sample_trajectories(t, n, rng) (n, T, D), .condition(t_star, y_star, y_cov=0) -> ProMP
        .log_likelihood(t, y (T, D) | (B, T, D), noise=None) -> float | (B,)
        .save(path) / ProMP.load(path)
    DMPDistribution(cov_reg=0.0, **DMP params).fit(t, Y (N, T, D) | [(T_i, D)])
        .propagate(t=None, tau=None, y0=None, goal=None) -> mean (T, D), cov (T, D, T, D)  # closed form
        .sample_trajectories(n, t=None, tau=None, rng=None) (n, T, D)

Formulation (``formulation=``, :mod:`lfd.dmp.formulation`): ``"pastor"`` (default, Pastor et
al. 2009) ``tau dz = K (g - y) - D z - K (g - y0) s + K f(s)`` reproduces DoFs that end
where they began and keeps the demonstrated shape under a new goal; ``"ijspeert"`` (the thesis
section 1, the behaviour before the argument existed) scales ``f`` by ``g - y0``, so such a
DoF stays at rest. Files saved without a formulation load as ``"ijspeert"``.

Fitting (``method``): ``"trajectory"`` (default) is ridge least squares on the positions
through the exact linear rollout map (:mod:`lfd.dmp.fitting`, ``ridge`` relative to the
largest squared singular value); ``"lwr"`` is the thesis's per-basis locally weighted
regression of the forcing target (use a smaller ``overlap``, e.g. 0.3, with it).

Units: time and ``tau`` in seconds; positions in the units of the demonstration
(radians or metres), velocities in units/s. Shapes: ``B`` batch, ``T`` samples, ``D`` DoF,
``K`` bases.

All closed-form rollouts evaluate one exact linear map (:mod:`lfd.dmp.transform`): the
spring-damper is solved in closed form and the forcing term held piecewise-linearly on a grid
refined to at least 1000 steps per ``tau`` (only the requested samples are kept), so
``DMP.rollout``, :func:`rollout_batch`, :class:`DMPLayer` and step-wise integration
(:mod:`lfd.dmp.stepping`) agree to rounding and any sampling is close to the continuous
solution. Coupling terms (:mod:`lfd.dmp.coupling`) make the motion nonlinear; it is then
integrated step-wise with the same discretisation.

Example::

    >>> import numpy as np
    >>> from lfd.dmp import DMP, DMPRunner, ObstacleAvoidance
    >>> t = np.linspace(0.0, 2.0, 200)                       # seconds
    >>> y = np.stack([np.sin(t), t**2 / 4], axis=-1)         # (T, D) = (200, 2)
    >>> dmp = DMP(n_basis=20).fit(t, y)
    >>> bool(np.sqrt(np.mean((dmp.rollout() - y) ** 2)) < 1e-3)
    True
    >>> dmp.rollout(goal=[1.5, 2.0], tau=4.0).shape          # new goal, twice as slow
    (200, 2)
    >>> dmp.rollout(weights=dmp.weights_ + np.random.randn(1000, 2, 20)).shape
    (1000, 200, 2)
    >>> lift = np.stack([t**2 / 4, np.sin(np.pi * t / 2)], axis=-1)  # DoF 1 goes up and comes back
    >>> bool(np.sqrt(np.mean((DMP().fit(t, lift).rollout() - lift) ** 2)) < 5e-3)
    True
    >>> avoid = dmp.rollout(coupling=[ObstacleAvoidance([[0.8, 0.3]])])   # (200, 2), steps around it
    >>> runner = DMPRunner(dmp)
    >>> state = runner.step(0.01, goal=[1.0, 1.2])           # online: goal changed mid-motion
"""

from .cartesian import CartesianDMP
from .coupling import JointLimits, ObstacleAvoidance
from .discrete import DMP, FIT_METHODS
from .distribution import DMPDistribution
from .dual_cartesian import DualCartesianDMP, RelativePoseCoupling
from .final_velocity import FinalVelocityDMP
from .fitting import DEFAULT_RIDGE
from .formulation import DEFAULT_FORMULATION, FORMULATIONS
from .functional import clear_caches, rollout_batch
from .gains import DiscreteGains, Gains
from .layer import DMPLayer
from .promp import ProMP
from .rhythmic import RhythmicDMP
from .stepping import DMPRunner, DMPState
from .transform import RolloutOperator

__all__ = [
    "DEFAULT_FORMULATION",
    "DEFAULT_RIDGE",
    "DMP",
    "FIT_METHODS",
    "FORMULATIONS",
    "CartesianDMP",
    "DMPDistribution",
    "DMPLayer",
    "DMPRunner",
    "DMPState",
    "DiscreteGains",
    "DualCartesianDMP",
    "FinalVelocityDMP",
    "Gains",
    "JointLimits",
    "ObstacleAvoidance",
    "ProMP",
    "RelativePoseCoupling",
    "RhythmicDMP",
    "RolloutOperator",
    "clear_caches",
    "rollout_batch",
]
