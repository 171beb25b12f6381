"""Importance-sampling memory of PoWER: the best rollouts seen so far.

PoWER re-uses old rollouts: every evaluated parameter vector is kept with its return,
and each update averages the ``M`` best of *all* rollouts so far (not only those of the
current batch), each weighted by its return. Storing absolute parameter vectors (not
perturbations) lets an old rollout be re-expressed as a perturbation ``theta_k - theta``
of the current policy.
"""

from __future__ import annotations

import numpy as np

from lfd.checks import check_int

__all__ = ["keep_best"]


def keep_best(params, returns, new_params, new_returns, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Merge new rollouts into the memory and keep the ``m`` with the highest returns.

    Ties keep the older rollout first (stable order), so the selection is deterministic.
    Inputs are not modified.

    Args:
        params: ``(N, P)`` parameter vectors already in memory (``N`` may be 0).
        returns: ``(N,)`` their returns.
        new_params: ``(B, P)`` parameter vectors of the new rollouts.
        new_returns: ``(B,)`` their returns.
        m: memory size (>= 1).

    Returns:
        ``(params (M', P), returns (M',))`` with ``M' = min(m, N + B)``, sorted by
        decreasing return.
    """
    m = check_int(m, "m", minimum=1)
    params = np.concatenate([np.asarray(params, dtype=np.float64), np.asarray(new_params, dtype=np.float64)])
    returns = np.concatenate(
        [np.asarray(returns, dtype=np.float64), np.asarray(new_returns, dtype=np.float64)]
    )
    if params.ndim != 2 or returns.shape != params.shape[:1]:
        raise ValueError(f"params {params.shape} and returns {returns.shape} must be (N, P) and (N,)")
    order = np.argsort(-returns, kind="stable")[:m]
    return params[order], returns[order]
