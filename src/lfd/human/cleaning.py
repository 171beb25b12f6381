"""Gap handling and left/right swap repair on joint trajectories.

* :func:`fill_gaps`: untracked / inferred joints and NaNs are interpolated over gaps no
  longer than ``max_gap`` seconds (cubic where both sides have enough support, else
  linear); longer gaps stay NaN and are reported.
* :func:`repair_swaps`: the depth camera's body fit sometimes labels the left arm as the
  right one for a few frames. A frame is taken as swapped (relative to the previous one)
  when exchanging the left and right joint of a pair explains the motion much better than
  keeping them, and the exchange is undone; the parity of such events is tracked, so a
  swap that lasts many frames is repaired as a whole.

All functions are vectorised over frames and joints; positions are ``(T, J, 3)`` metres.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["Gap", "fill_gaps", "find_gaps", "repair_swaps", "side_pairs"]


@dataclasses.dataclass(frozen=True)
class Gap:
    """A run of missing frames ``[start, stop)`` of one joint; ``filled`` if interpolated."""

    joint: str
    start: int
    stop: int
    duration: float
    filled: bool


def find_gaps(missing: np.ndarray) -> list[tuple[int, int, int]]:
    """Runs of True in ``missing (T, J)`` as ``(joint, start, stop)``, stop exclusive."""
    t, j = missing.shape
    padded = np.zeros((t + 2, j), bool)
    padded[1:-1] = missing
    edges = np.diff(padded.astype(np.int8), axis=0)
    starts = np.argwhere(edges == 1)
    stops = np.argwhere(edges == -1)
    # argwhere sorts by row (time) first: sort both by joint, then time, to pair them.
    starts = starts[np.lexsort((starts[:, 0], starts[:, 1]))]
    stops = stops[np.lexsort((stops[:, 0], stops[:, 1]))]
    return [(int(s[1]), int(s[0]), int(e[0])) for s, e in zip(starts, stops)]


def fill_gaps(
    t: np.ndarray, positions: np.ndarray, valid: np.ndarray, names: tuple[str, ...], max_gap: float = 0.2
) -> tuple[np.ndarray, list[Gap]]:
    """Interpolate short gaps.

    Args:
        t: (T,) s. positions: (T, J, 3) m. valid: (T, J) bool, False = missing/untracked.
        names: J joint names (for the report). max_gap: longest gap (s) that is filled;
            gaps at the start or end of the recording are never filled (no support).

    Returns:
        ``(filled (T, J, 3), gaps)``: missing frames become the linear interpolation of
        the neighbouring valid frames where the gap is short enough, NaN elsewhere.
    """
    if max_gap < 0 or not np.isfinite(max_gap):
        raise ValueError(f"max_gap must be a non-negative number of seconds, got {max_gap!r}")
    out = np.where(valid[..., None], positions, np.nan)
    gaps = []
    for j, start, stop in find_gaps(~valid):
        interior = start > 0 and stop < len(t)
        duration = float(t[stop] - t[start - 1]) if interior else float(t[min(stop, len(t) - 1)] - t[start])
        # The gap's duration is the time without data between the two valid neighbours,
        # minus one frame period: a single missing frame at 30 Hz lasts 1/30 s.
        duration = max(duration - (float(np.median(np.diff(t))) if len(t) > 1 and interior else 0.0), 0.0)
        fill = interior and duration <= max_gap + 1e-9
        if fill:
            w = (t[start:stop] - t[start - 1]) / (t[stop] - t[start - 1])
            out[start:stop, j] = (1 - w)[:, None] * out[start - 1, j] + w[:, None] * out[stop, j]
        gaps.append(Gap(names[j], start, stop, duration, fill))
    return out, gaps


def side_pairs(names: tuple[str, ...]) -> list[tuple[int, int]]:
    """Index pairs ``(left, right)`` of joints present on both sides (``x_left``/``x_right``)."""
    pairs = []
    for i, name in enumerate(names):
        if name.endswith("_left"):
            other = name[: -len("_left")] + "_right"
            if other in names:
                pairs.append((i, names.index(other)))
    return pairs


def _forward_fill(x: np.ndarray) -> np.ndarray:
    """Carry the last finite row of ``x (T, ...)`` forward over NaN rows (per trailing element)."""
    finite = np.isfinite(x)
    idx = np.where(finite, np.arange(len(x)).reshape(-1, *([1] * (x.ndim - 1))), 0)
    idx = np.maximum.accumulate(idx, axis=0)
    out = np.take_along_axis(x, idx, axis=0)
    return np.where(np.maximum.accumulate(finite, axis=0), out, np.nan)


def repair_swaps(
    positions: np.ndarray,
    names: tuple[str, ...],
    groups: tuple[tuple[str, ...], ...] = (
        ("shoulder", "elbow", "wrist", "hand", "hand_tip", "thumb", "collar"),
        ("hip", "knee", "ankle", "foot"),
    ),
    ratio: float = 0.5,
    min_jump: float = 0.05,
) -> tuple[np.ndarray, np.ndarray]:
    """Detect and undo left/right label swaps.

    For each group of paired joints (an arm, a leg) and each frame ``t`` the cost of keeping
    the labels, ``sum |L_t - L_prev| + |R_t - R_prev|``, is compared with the cost of
    exchanging them, ``sum |L_t - R_prev| + |R_t - L_prev|`` (``prev`` = the last frame with
    data, labels already repaired). A swap event is declared when the exchange costs less
    than ``ratio`` x keeping and keeping costs more than ``min_jump`` m per joint; the
    running parity of events says which frames are exchanged.

    Args:
        positions: (T, J, 3) m, NaN = missing. names: J canonical names.

    Returns:
        ``(repaired (T, J, 3), swapped (T, G) bool)``: ``swapped[t, g]`` marks frames whose
        labels in group ``g`` were exchanged.
    """
    out = positions.copy()
    pairs = side_pairs(names)
    swapped = np.zeros((len(positions), len(groups)), bool)
    for g, group in enumerate(groups):
        members = [(li, ri) for li, ri in pairs if names[li][: -len("_left")] in group]
        if not members or len(positions) < 2:
            continue
        left = positions[:, [li for li, _ in members]]
        right = positions[:, [ri for _, ri in members]]
        prev_l, prev_r = _forward_fill(left)[:-1], _forward_fill(right)[:-1]
        cur_l, cur_r = left[1:], right[1:]

        def dist(a, b):
            d = np.linalg.norm(a - b, axis=-1)  # (T-1, P)
            return d

        keep_d, cross_d = dist(cur_l, prev_l) + dist(cur_r, prev_r), dist(cur_l, prev_r) + dist(cur_r, prev_l)
        usable = np.isfinite(keep_d) & np.isfinite(cross_d)
        count = usable.sum(1)
        keep = np.where(usable, keep_d, 0).sum(1)
        cross = np.where(usable, cross_d, 0).sum(1)
        event = (count > 0) & (cross < ratio * keep) & (keep > 2 * min_jump * np.maximum(count, 1))
        parity = np.concatenate([[False], np.cumsum(event) % 2 == 1])
        swapped[:, g] = parity
        li = [li for li, _ in members]
        ri = [ri for _, ri in members]
        out[np.ix_(parity, li)] = positions[np.ix_(parity, ri)]
        out[np.ix_(parity, ri)] = positions[np.ix_(parity, li)]
    return out, swapped
