"""The motion a teach session runs: a DMP fitted to the recording and passed exactly through the keyframes.

:func:`plan_skill` builds the :class:`Skill` that Export writes (``demo.dmp.json``) and Send runs:

1. **The path.** The (idle-trimmed) recording, or, with nothing recorded, the minimum-jerk path through
   the keyframes (:func:`lfd.teach.recording.waypoint_path`, timed by the panel speed). It is resampled
   on ``n_samples`` uniform times over its duration ``T`` and a :class:`lfd.dmp.DMP` (the export's
   formulation, :func:`lfd.teach.export.dmp_options`) is fitted to it.
2. **The via points.** Each keyframe gets a time (its recording sample's, or its knot on the keyframe
   path), snapped to the nearest sample of that grid and made strictly increasing in list order. A
   keyframe on the first sample becomes the DMP's start ``y0_``, one on the last its ``goal_``.
3. **Conditioning** (:func:`condition_dmp`): the rollout is affine in the forcing weights, ``y(t) =
   free(t) + Phi(t) w`` per joint, so passing the via points exactly is a linear constraint. The weights
   change by the smallest amount (Euclidean norm) that meets it: ``w' = w + Phi_v^T (Phi_v Phi_v^T)^-1 (y* -
   y(t_v))``, the Gaussian conditioning of ProMPs (:meth:`lfd.dmp.ProMP.condition`, zero observation noise)
   applied to DMP weights with an isotropic prior. The conditioned DMP's default rollout
   (``dmp.rollout()``, ``n_samples`` samples) passes each keyframe at one of its samples (to rounding).
4. **Speed.** ``dmp.tau_ = T / speed``: the same path, ``speed`` times faster (a DMP scales in time exactly).

The bases grow with the keyframes (``max(n_basis, 2 K)``) so that every via point can be met. Cost: one
fit and one batched rollout on a cached grid, about a millisecond (the drag update budget is 30 ms).
Units: s, rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lfd.dmp import DMP

from .export import dmp_options
from .recording import waypoint_path, waypoint_times
from .results import Recording

__all__ = ["Motion", "Skill", "condition_dmp", "plan_skill", "via_indices"]

#: Samples of the fitting grid and of the exported DMP's default rollout.
N_SAMPLES = 200
#: Basis functions per joint (more when there are many keyframes).
N_BASIS = 30


@dataclass(frozen=True)
class Motion:
    """The motion Export and Send run, sampled: ``t`` (n,) s from 0 to the duration (at the session's
    speed), ``q`` (n, n_dof) rad, ``tool`` (n, 3) m (tool positions, base frame), ``gripper`` (n,) 0 open
    / 1 closed."""

    t: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    gripper: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])


@dataclass(frozen=True)
class Skill:
    """A planned motion (see the module docstring).

    Attributes:
        dmp: the conditioned DMP; ``tau_`` is the duration at the speed, s; its default rollout has
            ``n_steps_`` samples and passes keyframe ``k`` at sample ``via_index[k]``.
        via_index: (K,) int, the keyframes' samples on that grid.
        duration: s at speed 1 (the path's duration ``T``).
        source: ``"recording"`` or ``"keyframes"`` (nothing recorded).
    """

    dmp: DMP
    via_index: np.ndarray
    duration: float
    source: str

    @property
    def via_t(self) -> np.ndarray:
        """(K,) s: when the motion (at its speed) passes each keyframe."""
        return self.via_index * float(self.dmp.tau_) / (int(self.dmp.n_steps_) - 1)


def via_indices(times: np.ndarray, duration: float, n_samples: int) -> np.ndarray:
    """``(K,)`` int: the grid samples (``n_samples`` uniform over ``[0, duration]``) nearest ``times`` (K,) s,
    made strictly increasing in order (a keyframe timed before its predecessor comes one sample after it).

    Raises:
        ValueError: more keyframes than samples.
    """
    k = len(times)
    if k > n_samples:
        raise ValueError(f"{k} keyframes do not fit a motion of {n_samples} samples")
    last = n_samples - 1
    idx = np.clip(np.rint(np.asarray(times, float) / duration * last), 0, last).astype(int)
    for i in range(1, k):
        idx[i] = max(idx[i], idx[i - 1] + 1)
    for i in range(k - 1, -1, -1):  # pushed past the end: back off from it
        idx[i] = min(idx[i], last - (k - 1 - i))
    return idx


def condition_dmp(dmp: DMP, index: np.ndarray, targets: np.ndarray) -> DMP:
    """Change ``dmp``'s weights (in place) by the least amount that makes its default rollout pass
    ``targets`` (M, D) at samples ``index`` (M,) (each > 0: the first sample is the start ``y0_``).

    Returns:
        ``dmp``.

    Raises:
        ValueError: more via points than basis functions, or a via point on sample 0.
    """
    index = np.asarray(index, dtype=int)
    if len(index) == 0:
        return dmp
    if np.any(index <= 0):
        raise ValueError("a via point on the first sample is the DMP's start: set y0_ instead")
    if len(index) > dmp.n_basis:
        raise ValueError(
            f"{len(index)} via points need at least as many basis functions (have {dmp.n_basis})"
        )
    k = dmp.n_basis
    # the forced response of one DoF to each basis weight (start = goal = 0): (T, K)
    phi = dmp.rollout(y0=np.zeros(1), goal=np.zeros(1), weights=np.eye(k)[:, None, :])[:, :, 0].T
    rows = phi[index]  # (M, K)
    residual = np.asarray(targets, float) - dmp.rollout()[index]  # (M, D)
    gram = rows @ rows.T
    gram += 1e-12 * np.trace(gram) / len(index) * np.eye(len(index))
    dmp.weights_ = dmp.weights_ + (rows.T @ np.linalg.solve(gram, residual)).T
    return dmp


def plan_skill(
    rec: Recording | None,
    keyframes: np.ndarray,
    keyframe_t: np.ndarray | None,
    speed: float,
    panel_speed: float,
    n_samples: int = N_SAMPLES,
    n_basis: int = N_BASIS,
) -> Skill:
    """The :class:`Skill` of a recording and keyframes (module docstring).

    Args:
        rec: the trimmed recording, or None / fewer than 3 samples: the keyframes alone.
        keyframes: (K, n) rad, in visiting order.
        keyframe_t: (K,) s, the keyframes' recording times (ignored without a recording).
        speed: > 0, divides the duration.
        panel_speed: rad/s timing the keyframe path without a recording.
        n_samples, n_basis: the fitting grid and the bases per joint (at least ``2 K`` are used).

    Raises:
        ValueError: nothing to plan (fewer than 3 recorded samples and fewer than 2 keyframes).
    """
    kq = np.asarray(keyframes, dtype=float)
    if rec is not None and len(rec) >= 3:
        t, q, times, source = rec.t, rec.q, np.asarray(keyframe_t, dtype=float), "recording"
    elif len(kq) >= 2:
        t, q = waypoint_path(list(kq), kq.shape[1], panel_speed)
        times, source = waypoint_times(kq, panel_speed), "keyframes"
    else:
        raise ValueError("nothing to plan: record a motion (at least 3 samples) or add at least 2 keyframes")
    duration = float(t[-1] - t[0])
    grid = np.linspace(0.0, duration, n_samples)
    path = np.stack([np.interp(grid, t - t[0], q[:, j]) for j in range(q.shape[1])], axis=1)
    kq = kq.reshape(len(kq), q.shape[1])
    idx = via_indices(times, duration, n_samples) if len(kq) else np.zeros(0, dtype=int)

    dmp = DMP(n_basis=max(n_basis, 2 * len(kq)), **dmp_options()).fit(grid, path)
    if len(idx) and idx[0] == 0:
        dmp.y0_ = kq[0].copy()
    if len(idx) and idx[-1] == n_samples - 1:
        dmp.goal_ = kq[-1].copy()
    inner = idx > 0
    condition_dmp(dmp, idx[inner], kq[inner])
    dmp.tau_ = duration / float(speed)
    return Skill(dmp, idx, duration, source)
