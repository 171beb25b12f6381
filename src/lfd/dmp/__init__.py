"""Dynamic movement primitives: fitting, batched rollouts and a differentiable layer.

Public API (numpy + torch only)::

    DMP(n_basis=20, alpha_z=25.0, beta_z=None, alpha_s=None, overlap=0.8)
        .fit(t (T,), y (T, D) | (B, T, D), method="trajectory") -> self
        .rollout(t=None, y0=None, goal=None, tau=None, weights=None,
                 return_derivatives=False) -> (T, D) | (B, T, D)
        .save(path) / DMP.load(path)
    RhythmicDMP(n_basis=20, alpha_z=25.0, beta_z=None, overlap=0.8)
        .fit(t, y, period=None, method="trajectory"); .rollout(..., r=1.0, yd0=None)
    DMPLayer(n_basis, n_steps, dt, alpha_z=25.0, beta_z=None, alpha_s=None, tau=None,
             overlap=0.8)(y0 (B, D), goal (B, D), weights (B, D, K), tau=None) -> (B, T, D)
    rollout_batch(y0, goal, weights, t=None, *, n_steps=None, dt=None, tau=None, alpha_z=25.0,
                  beta_z=None, alpha_s=None, overlap=0.8, return_derivatives=False)
    clear_caches()   # drop the per-time-grid operators cached by fits and rollouts

Fitting (``method``): ``"trajectory"`` (default) is least squares on the positions through
the exact linear rollout map; ``"lwr"`` is SPEC section 1's per-basis locally weighted
regression of the forcing target (use a smaller ``overlap``, e.g. 0.3, with it). See
:mod:`lfd.dmp.fitting`. A DoF with ``g == y0`` gets zero weights (the forcing term scales
with ``g - y0``): it stays at rest, and a ``RuntimeWarning`` flags a DoF that moved and
came back, which this formulation cannot represent.

Units: time and ``tau`` in seconds; positions in the units of the demonstration
(radians or metres). Shapes: ``B`` batch, ``T`` samples, ``D`` DoF, ``K`` bases.

All rollouts evaluate one exact linear map (:mod:`lfd.dmp.transform`): the spring-damper
is solved in closed form and the forcing term is held piecewise-linearly between samples,
so ``DMP.rollout``, :func:`rollout_batch` and :class:`DMPLayer` agree to rounding.

Example::

    >>> import numpy as np
    >>> from lfd.dmp import DMP
    >>> t = np.linspace(0.0, 2.0, 200)                       # seconds
    >>> y = np.stack([np.sin(t), t**2 / 4], axis=-1)         # (T, D) = (200, 2)
    >>> dmp = DMP(n_basis=20).fit(t, y)
    >>> bool(np.sqrt(np.mean((dmp.rollout() - y) ** 2)) < 1e-3)
    True
    >>> dmp.rollout(goal=[1.5, 2.0], tau=4.0).shape          # new goal, twice as slow
    (200, 2)
    >>> dmp.rollout(weights=dmp.weights_ + np.random.randn(1000, 2, 20)).shape
    (1000, 200, 2)
"""

from .cartesian import CartesianDMP
from .coupling import JointLimits, ObstacleAvoidance
from .discrete import DMP, FIT_METHODS
from .fitting import DEFAULT_RIDGE
from .formulation import DEFAULT_FORMULATION, FORMULATIONS
from .functional import DiscreteGains, Gains, clear_caches, rollout_batch
from .layer import DMPLayer
from .rhythmic import RhythmicDMP
from .stepping import DMPRunner, DMPState
from .transform import RolloutOperator

__all__ = [
    "CartesianDMP",
    "DEFAULT_FORMULATION",
    "DEFAULT_RIDGE",
    "DMP",
    "FIT_METHODS",
    "FORMULATIONS",
    "DMPLayer",
    "DMPRunner",
    "DMPState",
    "DiscreteGains",
    "Gains",
    "JointLimits",
    "ObstacleAvoidance",
    "RhythmicDMP",
    "RolloutOperator",
    "clear_caches",
    "rollout_batch",
]
