"""Batched rollouts of one fitted DMP for many weight and goal sets.

A discrete DMP started at rest is linear in its forcing weights for a
fixed start and goal. For both forcing formulations of :mod:`lfd.dmp` the map has one
of two closed forms, for every DoF ``d``:

.. code-block:: text

    "ijspeert" (forcing scaled by g - y0):  y_d(t) = y0_d + (g_d - y0_d) * (u(t) + Phi(t) @ w_d)
    "pastor"   (forcing independent of g):  y_d(t) = y0_d + (g_d - y0_d) * u(t) + Phi(t) @ w_d

where ``u`` (the response to the goal with zero weights) and ``Phi`` (``(T, K)``, the
response to each basis weight) depend only on the time grid, ``tau`` and the gains.
:class:`DMPRollout` obtains ``u`` and ``Phi`` from :meth:`lfd.dmp.DMP.rollout` itself (unit
start-to-goal DMPs with ``K + 1`` weight sets, at two goal distances, which tells the two
forms apart), checks the closed form against ``DMP.rollout`` once, and then evaluates any
batch of ``(weights, goal)`` with one stacked product ``Phi (T, K) @ w^T (B, K, D)``:
PoWER, PI^BB and CMA-ES evaluate their ``K`` perturbed rollouts per iteration this way.
"""

from __future__ import annotations

import numpy as np

from lfd.checks import finite_array

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
        free: ``(T,)`` response ``u`` of a unit start-to-goal DMP with zero weights (0 -> ~1).
        forced: ``(T, K)`` response ``Phi`` to each basis weight (of a unit DMP when scaled).
        goal_scaled: True when the weights' effect scales with ``g - y0`` (``"ijspeert"``).

    Example::

        rollout = DMPRollout(dmp)
        batch = rollout(dmp.weights_[None].repeat(4, 0), dmp.goal_[None].repeat(4, 0))  # (4, T, D)
    """

    def __init__(self, dmp, t=None, y0=None):
        weights = getattr(dmp, "weights_", None)
        if weights is None or np.ndim(weights) != 2:
            raise ValueError("dmp must be a DMP fitted to one demonstration (weights_ of shape (D, K))")
        self.n_dof, self.n_basis = np.shape(weights)
        if t is None:
            t = np.linspace(0.0, float(dmp.tau_), int(dmp.n_steps_))
        self.t = finite_array(t, "t", ndim=1)
        self.y0 = finite_array(dmp.y0_ if y0 is None else y0, "y0", shape=(self.n_dof,))
        unit = np.zeros((self.n_basis + 1, self.n_dof, self.n_basis))
        unit[np.arange(1, self.n_basis + 1), :, np.arange(self.n_basis)] = 1.0
        zero = np.zeros(self.n_dof)

        def response(distance: float) -> np.ndarray:
            goal = np.full(self.n_dof, distance)
            out = dmp.rollout(t=self.t, y0=zero, goal=goal, weights=unit)
            return np.asarray(out, dtype=np.float64)[:, :, 0]

        near, far = response(1.0), response(2.0)
        self.free = near[0].copy()
        self.forced = np.ascontiguousarray((near[1:] - near[0]).T)
        far_forced = (far[1:] - far[0]).T
        scale = max(np.abs(self.forced).max(), 1e-300)
        self.goal_scaled = bool(np.abs(far_forced - 2.0 * self.forced).max() <= 1e-6 * scale)
        if not self.goal_scaled and np.abs(far_forced - self.forced).max() > 1e-6 * scale:
            raise ValueError("dmp's rollout is neither goal-scaled nor goal-independent in its weights")
        # one check of the closed form against the DMP's own rollout, at the DMP's parameters
        expected = np.asarray(
            dmp.rollout(t=self.t, y0=self.y0, goal=dmp.goal_, weights=dmp.weights_), dtype=np.float64
        )
        got = self(
            np.asarray(dmp.weights_, dtype=np.float64)[None], np.asarray(dmp.goal_, dtype=np.float64)[None]
        )[0]
        if not np.allclose(got, expected, rtol=1e-6, atol=1e-6 * (1.0 + np.abs(expected).max())):
            raise ValueError("dmp's rollout is not the linear map DMPRollout assumes (unsupported DMP)")

    def basis_scale(self, goal, floor: float = 0.0) -> np.ndarray:
        """Largest trajectory displacement per unit change of each weight.

        ``max_t |dy_d(t) / dw_{d,i}|`` (units of ``y`` per weight unit): ``max_t |Phi_i(t)|``,
        times ``max(|g_d - y0_d|, floor)`` when the forcing term scales with the goal
        displacement. Late bases act where the phase ``s`` is small, so their weights move
        the trajectory much less than early ones: exploring every weight with
        ``sigma / basis_scale`` gives every basis the same effect.

        Args:
            goal: ``(D,)`` goal.
            floor: smallest goal displacement used (units of ``y``, >= 0), so that a DoF whose
                goal equals its start still gets a finite, non-zero scale.

        Returns:
            ``(D, K)`` non-negative scales (zero only for a goal-scaled DoF with ``g == y0``
            and ``floor == 0``).
        """
        goal = finite_array(goal, "goal", shape=(self.n_dof,))
        per_basis = np.abs(self.forced).max(axis=0)
        if not self.goal_scaled:
            return np.broadcast_to(per_basis, (self.n_dof, self.n_basis)).copy()
        return np.maximum(np.abs(goal - self.y0), floor)[:, None] * per_basis

    def weight_scale(self, goal) -> np.ndarray:
        """Largest trajectory displacement per unit change of one weight, for each DoF.

        ``max_{i, t} |dy_d(t) / dw_{d,i}|`` (units of ``y``): the most influential basis is an
        early one. See :meth:`basis_scale` for the per-basis scales.

        Args:
            goal: ``(D,)`` goal.

        Returns:
            ``(D,)`` non-negative scales; zero for a goal-scaled DoF whose goal equals its start.
        """
        return self.basis_scale(goal).max(axis=1)

    def __call__(self, weights: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Roll out ``B`` parameter sets.

        Args:
            weights: ``(B, D, K)`` forcing weights.
            goal: ``(B, D)`` goals (units of ``y``).

        Returns:
            ``(B, T, D)`` positions, float64.

        Only shapes are checked here (this is the search's inner loop); values are the caller's.
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
        displacement = goal[:, None, :] - self.y0
        if self.goal_scaled:
            shape += self.free[:, None]
            shape *= displacement
        else:
            shape += self.free[:, None] * displacement
        shape += self.y0
        return shape
