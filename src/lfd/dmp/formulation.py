"""How the forcing term of a discrete DMP is scaled: the ``formulation=`` argument.

Both formulations share the spring-damper ``tau dz = alpha_z (beta_z (g - y) - z) + F``,
``tau dy = z`` and the features ``x_i(s) = s psi_i(s) / sum_j psi_j(s)``; they differ in
the forcing input ``F``:

- ``"pastor"`` (default; Pastor et al. 2009, also Hoffmann et al. 2009):
  ``F = K f(s) - K (g - y0) s`` with ``K = alpha_z beta_z`` and ``f(s) = x(s) @ w``. The
  forcing term does not depend on ``g - y0``, so a DoF that moves and returns to its start
  (``g == y0``: lift over an obstacle and put down) is reproduced like any other, and the
  ``- K (g - y0) s`` term removes the jump of the acceleration at the start. A new goal
  adds the goal offset through a smooth transient (``y' - y`` is the same for every
  weight vector); the demonstrated shape is kept, not rescaled. Weights are in the units
  of ``y``.
- ``"ijspeert"`` (Ijspeert et al. 2013, as in the thesis, the behaviour before the
  ``formulation`` argument existed): ``F = f(s) (g - y0)``. A new goal rescales the
  motion per DoF by ``(g' - y0) / (g - y0)`` (it mirrors when the sign flips); a DoF with
  ``g == y0`` cannot move at all (zero weights, and ``fit`` warns when it did move).
  Weights are dimensionless.

Since ``sum_i x_i(s) = s``, both are the linear rollout map of :mod:`lfd.dmp.transform`
with *amplitude-scaled weights* ``v`` (``F = x(s) @ v``):

.. code-block:: text

    ijspeert:  v = w (g - y0)
    pastor:    v = K (w - (g - y0))

so every rollout (:class:`~lfd.dmp.DMP`, :func:`~lfd.dmp.rollout_batch`,
:class:`~lfd.dmp.DMPLayer`, step-wise integration) stays one exact linear map, and fitting
(which estimates ``v``) inverts these relations. The default was chosen by measurement
(``docs/dmp.md``, section "Formulation").
"""

from __future__ import annotations

import warnings

import numpy as np
import torch
from torch import Tensor

from lfd import checks

__all__ = ["DEFAULT_FORMULATION", "FORMULATIONS", "check_formulation", "scale_weights", "unscale_weights"]

#: Accepted values of ``formulation=``; the first is the default.
FORMULATIONS = ("pastor", "ijspeert")
DEFAULT_FORMULATION = FORMULATIONS[0]

#: Relative size (w.r.t. the demonstration's extent) at or below which a start-to-goal
#: displacement ``g - y0`` counts as zero in the ``"ijspeert"`` formulation.
ZERO_DISPLACEMENT = 1e-8


def check_formulation(formulation) -> str:
    """``formulation`` if it is one of :data:`FORMULATIONS`, else ``ValueError``."""
    return checks.check_choice(formulation, "formulation", FORMULATIONS)


def scale_weights(
    weights: Tensor,
    y0: Tensor,
    goal: Tensor,
    formulation: str,
    stiffness: float,
    *,
    out: Tensor | None = None,
) -> Tensor:
    """Amplitude-scaled weights ``v`` ``(B, D, K)`` fed to the rollout operator.

    Args:
        weights: ``(B, D, K)`` forcing weights ``w`` (tensors or numpy arrays).
        y0, goal: ``(B, D)`` start and goal (any of the three may have batch 1).
        formulation: one of :data:`FORMULATIONS`.
        stiffness: ``K = alpha_z * beta_z`` (used by ``"pastor"``).
        out: tensors only, no autograd: a ``(B, D, K)`` tensor (e.g. a view into the
            operator's input buffer) written in place and returned, saving an allocation.
    """
    displacement = (goal - y0)[..., None]
    if out is not None:
        if formulation == "ijspeert":
            return torch.mul(weights, displacement, out=out)
        return torch.add(displacement * -stiffness, weights, alpha=stiffness, out=out)  # one pass
    if formulation == "ijspeert":
        return weights * displacement
    return stiffness * (weights - displacement)


def unscale_weights(
    v: np.ndarray, y: np.ndarray, y0: np.ndarray, goal: np.ndarray, formulation: str, stiffness: float
) -> np.ndarray:
    """Weights ``w`` ``(..., D, K)`` from fitted amplitude-scaled weights ``v`` (inverse of :func:`scale_weights`).

    For ``"ijspeert"`` a DoF with ``|g - y0| <= ZERO_DISPLACEMENT * extent`` gets zero
    weights (it stays at rest; exact for a stationary DoF) and a ``RuntimeWarning`` is issued
    when such a DoF moved during the demonstration, which that formulation cannot represent.

    Args:
        v: ``(..., D, K)`` amplitude-scaled weights from :mod:`lfd.dmp.fitting`.
        y: ``(..., T, D)`` the demonstration (for the zero-length test).
        y0, goal: ``(..., D)``.
    """
    displacement = goal - y0
    if formulation == "pastor":
        return v / stiffness + displacement[..., None]
    extent = np.max(np.abs(y - y0[..., None, :]), axis=(-2, -1))
    threshold = ZERO_DISPLACEMENT * extent[..., None]
    zero_length = np.abs(displacement) <= threshold
    moved = np.max(np.abs(y - y0[..., None, :]), axis=-2) > threshold
    if np.any(zero_length & moved):
        warnings.warn(
            "a demonstrated DoF moves but ends at its start (g == y0); the 'ijspeert' forcing term "
            "scales with (g - y0), so that DoF is reproduced as staying at rest (use formulation='pastor')",
            RuntimeWarning,
            stacklevel=3,
        )
    inverse = np.divide(1.0, displacement, out=np.zeros_like(displacement), where=~zero_length)
    return v * inverse[..., None]
