"""Reconciling the views before triangulating: each view's left/right labels, and which views show
the person at all (:func:`reconcile_left_right`).

A 2-D estimator can label a view's left and right side the wrong way round: MediaPipe's
front/back confusion swaps every left landmark with its right one, and in side views the far arm
or leg can take the near one's label. Triangulating such a view with the others pulls both
sides' points together and reprojects tens of pixels off. Pose2Sim (``triangulation_from_best_cameras``
with ``handle_LR_swap``) tries, per keypoint and frame, swapping the labels of fewer than half of
the views and keeps the swap with the lowest reprojection error. Here the same search runs over
every pattern of swapped views, per group of left/right pairs, and the pattern of each frame is
chosen by dynamic programming over the whole recording: the cost of a pattern is the mean over
views of its reprojection error (px, each view's capped at ``cap_px``), plus ``switch_px`` per view
whose state changes from one frame to the next (so an ambiguous frame, a person seen side-on, does
not toggle it). Swapping every view relabels the 3-D person and costs the same; of a pattern and
its complement the one keeping the estimator's labels for most views and frames is kept.

A single-person estimator in a scene with several people can follow a different person in
different views (MediaPipe takes the most prominent one in each). With ``other_person_px`` the
first group (the anchor, e.g. shoulders and hips) also has an *off* state per view, costing
``other_person_px`` instead of its reprojection error: a view that fits the others worse than that
shows someone else in that frame and is left out of every joint (confidence 0). A view starting or
ending to show someone else also costs ``other_person_px`` (the estimator rarely changes person), so
when two people are seen by two views each, one of them is followed throughout.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence

import numpy as np

from .calibration import Calibration
from .triangulation import dlt_rows

__all__ = ["LabelReconciliation", "reconcile_left_right"]

#: Most views searched: 2^C patterns (3^C with ``other_person_px``).
MAX_VIEWS = 8
MAX_VIEWS_WITH_OFF = 6
#: Entries of the per-state DLT rows held at once (frames are processed in chunks).
CHUNK = 2_000_000


@dataclasses.dataclass
class LabelReconciliation:
    """Result of :func:`reconcile_left_right`.

    Attributes:
        pixels: (C, T, J, 2) px with the chosen swaps applied. confidence: (C, T, J), likewise,
            and 0 in the views left out (``other_person``).
        swapped: (C, T, G) bool, the labels of group ``g`` were swapped in view ``c`` at frame ``t``.
        other_person: (C, T) bool, the view was left out at that frame (it shows someone else).
        groups: G groups of (left, right) joint index pairs.
        cost_px: (T, G) cost of the chosen state: mean over the views of the capped reprojection
            error (px) or ``other_person_px`` (NaN: fewer than 2 views see the group).
        cost_as_given_px: (T, G) the same with every view as given.
    """

    pixels: np.ndarray
    confidence: np.ndarray
    swapped: np.ndarray
    other_person: np.ndarray
    groups: tuple[tuple[tuple[int, int], ...], ...]
    cost_px: np.ndarray
    cost_as_given_px: np.ndarray

    @property
    def swapped_joints(self) -> np.ndarray:
        """(C, T, J) bool: the joint's label was exchanged with its partner's in that view and frame."""
        out = np.zeros(self.confidence.shape, bool)
        for g, group in enumerate(self.groups):
            for pair in group:
                out[:, :, list(pair)] |= self.swapped[:, :, g, None]
        return out


def _states(n_views: int, k: int) -> np.ndarray:
    """(k^C, C) every state of the views: 0 as given, 1 swapped, 2 off."""
    return (np.arange(k**n_views)[:, None] // k ** np.arange(n_views)) % k


def _costs(calib, rows, used, px, left, right, states, cap_px, off_px):
    """(S, T) cost of each state of the views for one group (NaN: fewer than 2 views see it)."""
    idx, perm = left + right, right + left
    swap, on = states == 1, states != 2  # (S, C)
    r = np.where(swap[:, :, None, None, None, None], rows[:, :, perm][None], rows[:, :, idx][None])
    u = np.where(swap[:, :, None, None], used[:, :, perm][None], used[:, :, idx][None])
    u &= on[:, :, None, None]  # (S, C, T, K)
    q = np.where(swap[:, :, None, None, None], px[:, :, perm][None], px[:, :, idx][None])
    n_s, C, T, K = u.shape
    a = (r * u[..., None, None]).transpose(0, 2, 3, 1, 4, 5).reshape(n_s, T, K, 2 * C, 4)
    h = np.linalg.svd(a)[2][..., -1, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        X = h[..., :3] / h[..., 3:]  # (S, T, K, 3)
    X[u.sum(1) < 2] = np.nan
    err = np.where(u, np.linalg.norm(np.moveaxis(calib.project(X), 0, 1) - q, axis=-1), np.nan)
    seen = used[:, :, idx].any(2)  # (C, T) views that see any joint of the group
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        per_view = np.minimum(np.nanmean(err, axis=3), cap_px)  # (S, C, T)
    per_view = np.where(on[:, :, None], per_view, off_px)
    per_view = np.where(seen[None], per_view, np.nan)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        cost = np.nanmean(per_view, axis=1)  # (S, T)
    n_on = (on[:, :, None] & seen[None]).sum(1)  # (S, T)
    cost = np.where(n_on >= 2, np.nan_to_num(cost, nan=np.inf), np.inf)  # a state must keep 2 views
    cost[:, seen.sum(0) < 2] = np.nan
    return cost


def _viterbi(cost: np.ndarray, n_views: int, change: np.ndarray) -> np.ndarray:
    """(T,) state per frame minimising the summed cost plus ``change[a, b]`` px per view going from a to b.

    The transition cost is a sum over views, so the minimum over predecessors is found one view
    at a time (a separable distance transform): O(S C k) per frame instead of O(S^2).
    """
    n_s, T = cost.shape
    k = len(change)
    unary = np.nan_to_num(cost, nan=0.0)
    total = unary[:, 0].copy()
    back = np.zeros((T, n_s), int)
    for t in range(1, T):
        best, arg = total.copy(), np.arange(n_s)
        for c in range(n_views):
            shape = (k ** (n_views - 1 - c), k, k**c)
            b, a = best.reshape(shape), arg.reshape(shape)
            step = b[:, :, None, :] + change[None, :, :, None]  # from value p (axis 1) to q (axis 2)
            j = np.argmin(step, axis=1)  # (.., k, ..) best p for each q
            best = np.take_along_axis(step, j[:, None], 1)[:, 0].ravel()
            arg = np.take_along_axis(a, j, 1).ravel()
        back[t] = arg
        total = best + unary[:, t]
    state = np.zeros(T, int)
    state[-1] = int(np.argmin(total))
    for t in range(T - 1, 0, -1):
        state[t - 1] = back[t, state[t]]
    return state


def reconcile_left_right(
    calib: Calibration,
    pixels: np.ndarray,
    confidence: np.ndarray,
    pairs: Sequence[tuple[int, int]],
    *,
    groups: Sequence[Sequence[tuple[int, int]]] | None = None,
    min_confidence: float = 0.3,
    switch_px: float = 10.0,
    cap_px: float = 100.0,
    other_person_px: float | None = None,
) -> LabelReconciliation:
    """Choose, per view, frame and group of left/right pairs, whether the labels are swapped (module docstring).

    Args:
        calib: C cameras (at most 8; 6 with ``other_person_px``). pixels: (C, T, J, 2) px (NaN =
            missing). confidence: (C, T, J).
        pairs: (left, right) joint indices, e.g. MediaPipe's (11, 12) shoulders.
        groups: pairs decided together (each a subset of ``pairs``; the first is the anchor for
            ``other_person_px``); None = every pair on its own (what Pose2Sim does per keypoint).
        min_confidence: views below are not used. switch_px: px per view whose state changes
            between frames. cap_px: px, largest per-view error counted.
        other_person_px: px; None = every view shows the person. Else the cost of leaving a view
            out of a frame (it shows someone else), decided on the first group.

    Returns:
        :class:`LabelReconciliation`.

    Raises:
        ValueError: wrong shapes, too many views, a joint index out of range or in two pairs,
            a group with a pair not in ``pairs``, ``switch_px`` < 0, ``cap_px`` or
            ``other_person_px`` <= 0.
    """
    px = np.asarray(pixels, float)
    conf = np.asarray(confidence, float)
    C = calib.n_cameras
    if px.ndim != 4 or px.shape[0] != C or px.shape[-1] != 2 or conf.shape != px.shape[:3]:
        raise ValueError(
            f"pixels must have shape (C={C}, T, J, 2) and confidence (C, T, J); got {px.shape}, {conf.shape}"
        )
    limit = MAX_VIEWS if other_person_px is None else MAX_VIEWS_WITH_OFF
    if calib.n_cameras > limit:
        raise ValueError(
            f"left/right reconciliation searches every state of the views: at most {limit} views, got {C}"
        )
    J = px.shape[2]
    pairs = tuple((int(a), int(b)) for a, b in pairs)
    flat = [j for pair in pairs for j in pair]
    if any(not 0 <= j < J for j in flat) or len(set(flat)) != len(flat):
        raise ValueError(f"pairs must be distinct joint indices in [0, {J}), each in one pair; got {pairs}")
    if groups is None:
        groups = tuple((p,) for p in pairs)
    else:
        groups = tuple(tuple((int(a), int(b)) for a, b in g) for g in groups)
    if not groups or any(p not in pairs for g in groups for p in g) or any(not g for g in groups):
        raise ValueError(f"groups must be non-empty lists of pairs from pairs={pairs}; got {groups}")
    if not (switch_px >= 0 and cap_px > 0 and (other_person_px is None or other_person_px > 0)):
        raise ValueError(
            "switch_px must be >= 0, cap_px and other_person_px > 0; "
            f"got {switch_px!r}, {cap_px!r}, {other_person_px!r}"
        )
    T, G = px.shape[1], len(groups)
    swapped, other = np.zeros((C, T, G), bool), np.zeros((C, T), bool)
    cost_px, given_px = np.full((T, G), np.nan), np.full((T, G), np.nan)
    out_px, out_conf = px.copy(), conf.copy()
    for g, group in enumerate(groups):
        k = 3 if g == 0 and other_person_px is not None else 2
        states = _states(C, k)
        rows, used = dlt_rows(calib, px, out_conf, min_confidence)
        left, right = [a for a, _ in group], [b for _, b in group]
        off = other_person_px or np.inf
        step = max(1, CHUNK // (len(states) * C * 2 * len(group)))  # frames per chunk, bounded memory
        cost = np.concatenate(
            [
                _costs(calib, rows[:, t : t + step], used[:, t : t + step], px[:, t : t + step], left, right,
                       states, cap_px, off)
                for t in range(0, T, step)
            ], axis=1,
        )  # fmt: skip
        change = np.array([[0.0, switch_px, off], [switch_px, 0.0, off], [off, off, 0.0]])[:k, :k]
        state = _viterbi(cost, C, change)
        seen = used[:, :, left + right].any(2)  # (C, T)
        on = (states[state] != 2).T  # (C, T)
        chosen = (states[state] == 1).T & seen & on
        if chosen.sum() > 0.5 * (seen & on).sum():  # the complement: same points, the majority's labels
            flipped = np.where(states[state] == 2, 2, 1 - states[state])
            state = (flipped * k ** np.arange(C)).sum(1)
            chosen = (states[state] == 1).T & seen & on
        swapped[:, :, g] = chosen
        cost_px[:, g], given_px[:, g] = cost[state, np.arange(T)], cost[0]
        if k == 3:
            other = ~on & seen
            out_conf[other] = 0.0
        for a, b in group:
            for arr in (out_px, out_conf):
                sel = chosen[(...,) + (None,) * (arr.ndim - 2)]
                arr[:, :, [a, b]] = np.where(sel, arr[:, :, [b, a]], arr[:, :, [a, b]])
    return LabelReconciliation(out_px, out_conf, swapped, other, groups, cost_px, given_px)
