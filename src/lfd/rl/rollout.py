"""Batched rollouts of one fitted DMP for many weight and goal sets.

A discrete DMP (SPEC section 1) started at rest is, for every DoF ``d``,

.. code-block:: text

    y_d(t) = y0_d + (g_d - y0_d) * (u(t) + Phi(t) @ w_d)

where ``u`` (the unforced step response) and ``Phi`` (``(T, K)``, the response to each
basis feature) depend only on the time grid, ``tau`` and the gains: the forcing term
scales with ``g - y0`` and the system is linear. :class:`DMPRollout` obtains ``u`` and
``Phi`` once from :meth:`lfd.dmp.DMP.rollout` itself (a unit start-to-goal DMP with
``K + 1`` weight sets) and then evaluates any batch of ``(weights, goal)`` with one
stacked product ``Phi (T, K) @ w^T (B, K, D)``, which is what PoWER needs for its ``K``
perturbed rollouts per iteration.
"""

from __future__ import annotations

import numpy as np

from ._checks import as_finite_array

__all__ = ["DMPRollout"]


class DMPRollout:
    """Evaluate a fitted :class:`lfd.dmp.DMP` for batches of weights and goals on one time grid.

    Args:
        dmp: a fitted single-demonstration DMP (``weights_`` of shape ``(D, K)``).
        t: ``(T,)`` output times in seconds (default: the DMP's own grid,
            ``linspace(0, tau_, n_steps_)``).
        y0: ``(D,)`` start position (default ``dmp.y0_``); the motion starts at rest.

    Attributes:
        n_dof, n_basis: ``D`` and ``K``.
        t: ``(T,)`` times (s). y0: ``(D,)`` start.
        free: ``(T,)`` unforced response ``u`` of a unit start-to-goal DMP (0 -> ~1).
        forced: ``(T, K)`` response ``Phi`` of a unit DMP to each basis weight.
    """

    def __init__(self, dmp, t=None, y0=None):
        weights = getattr(dmp, "weights_", None)
        if weights is None or np.ndim(weights) != 2:
            raise ValueError("dmp must be a DMP fitted to one demonstration (weights_ of shape (D, K))")
        self.n_dof, self.n_basis = np.shape(weights)
        if t is None:
            t = np.linspace(0.0, float(dmp.tau_), int(dmp.n_steps_))
        self.t = as_finite_array(t, "t", ndim=1)
        self.y0 = as_finite_array(dmp.y0_ if y0 is None else y0, "y0", shape=(self.n_dof,))
        unit = np.zeros((self.n_basis + 1, self.n_dof, self.n_basis))
        unit[np.arange(1, self.n_basis + 1), :, np.arange(self.n_basis)] = 1.0
        response = np.asarray(
            dmp.rollout(t=self.t, y0=np.zeros(self.n_dof), goal=np.ones(self.n_dof), weights=unit), dtype=np.float64
        )[:, :, 0]
        self.free = response[0].copy()
        self.forced = np.ascontiguousarray((response[1:] - response[0]).T)

    def weight_scale(self, goal) -> np.ndarray:
        """Largest trajectory displacement per unit change of one weight, for each DoF.

        ``max_{i, t} |dy_d(t) / dw_{d,i}| = |g_d - y0_d| * max_{i, t} |Phi_i(t)|`` (units of ``y``):
        the forcing term scales with the goal displacement, and the most influential basis
        is an early one (the phase ``s`` leaves little to late bases).

        Args:
            goal: ``(D,)`` goal.

        Returns:
            ``(D,)`` non-negative scales; zero for a DoF whose goal equals its start.
        """
        goal = as_finite_array(goal, "goal", shape=(self.n_dof,))
        return np.abs(goal - self.y0) * np.abs(self.forced).max()

    def __call__(self, weights: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Roll out ``B`` parameter sets.

        Args:
            weights: ``(B, D, K)`` forcing weights.
            goal: ``(B, D)`` goals (units of ``y``).

        Returns:
            ``(B, T, D)`` positions, float64.

        Only shapes are checked here (this is PoWER's inner loop); values are the caller's.
        """
        weights, goal = np.asarray(weights, dtype=np.float64), np.asarray(goal, dtype=np.float64)
        batch = weights.shape[0] if weights.ndim == 3 else -1
        if weights.shape != (batch, self.n_dof, self.n_basis) or goal.shape != (batch, self.n_dof):
            raise ValueError(
                f"weights and goal must have shapes (B, {self.n_dof}, {self.n_basis}) and (B, {self.n_dof}), "
                f"got {weights.shape} and {goal.shape}"
            )
        # A stack of B small (T, K) @ (K, D) products: each is below BLAS's threading
        # threshold, so a busy machine does not stall it on thread hand-offs (one
        # (B * D, K) @ (K, T) product took 20-40 ms there instead of 0.6 ms).
        shape = np.matmul(self.forced, weights.transpose(0, 2, 1))
        shape += self.free[:, None]
        shape *= goal[:, None, :] - self.y0
        shape += self.y0
        return shape
