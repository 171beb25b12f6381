"""Keyframes of a teach session: configurations the taught motion must pass through, in order.

A :class:`Keyframe` is a configuration ``q`` (n,) rad and, when a recording exists, the recording
sample it belongs to (``anchor``, an index into the raw recording): the motion passes the keyframe
at that sample's time. A keyframe added before anything was recorded has no anchor; it takes the
time of the recorded sample nearest to it in joint space (:func:`keyframe_times`). Without a
recording the keyframes alone define the motion: a minimum-jerk path through them, each segment
timed by the panel speed (:func:`lfd.teach.recording.waypoint_times`).

The list order is the order the motion visits them; :func:`reordered` keeps the times (the slots)
and changes which keyframe fills each. Times are made strictly increasing in list order by
:func:`lfd.teach.motion.plan_skill`. Units: s, rad.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Keyframe", "check_index", "keyframe_times", "nearest_sample", "reordered"]


@dataclass(frozen=True)
class Keyframe:
    """One keyframe: ``q`` (n,) rad; ``anchor`` the raw recording sample it is timed by, or None."""

    q: np.ndarray
    anchor: int | None = None


def check_index(i, count: int, name: str = "keyframe", insert: bool = False) -> int:
    """``i`` as an index into ``count`` items (``insert``: ``0..count``), else one ``ValueError`` line."""
    last = count if insert else count - 1
    if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i <= last:
        have = f"0..{last}" if last >= 0 else "none (there are no keyframes)"
        raise ValueError(f"{name} index must be an integer in {have}, got {i!r}")
    return int(i)


def nearest_sample(q: np.ndarray, raw_q: np.ndarray) -> int:
    """Index of the raw recording sample (rows of ``raw_q`` (N, n) rad) nearest ``q`` (n,) in joint space
    (the largest joint difference); the latest of equally near ones."""
    d = np.max(np.abs(raw_q - q), axis=1)
    return int(len(d) - 1 - np.argmin(d[::-1]))


def keyframe_times(keyframes: Sequence[Keyframe], raw_q: np.ndarray, raw_times: np.ndarray) -> np.ndarray:
    """``(K,)`` s: the recording time of each keyframe (its anchor's time in ``raw_times``, else the nearest
    sample's); ``raw_q`` (N, n) rad and ``raw_times`` (N,) s are the raw samples and their (trimmed) times."""
    out = np.empty(len(keyframes))
    for k, kf in enumerate(keyframes):
        i = kf.anchor if kf.anchor is not None and kf.anchor < len(raw_q) else nearest_sample(kf.q, raw_q)
        out[k] = raw_times[i]
    return out


def reordered(
    keyframes: Sequence[Keyframe], order: Sequence[int], raw_q: np.ndarray | None
) -> list[Keyframe]:
    """The keyframes visited in ``order`` (a permutation of ``0..K-1``: new position ``j`` holds old keyframe
    ``order[j]``). With a recording (``raw_q`` (N, n)) the time slots stay: the anchors, sorted, are handed
    out in the new order.

    Raises:
        ValueError: ``order`` is not a permutation of ``0..K-1``.
    """
    k = len(keyframes)
    try:
        perm = [int(i) for i in order]
    except (TypeError, ValueError):
        raise ValueError(f"order must be a permutation of 0..{k - 1}, got {order!r}") from None
    if sorted(perm) != list(range(k)) or any(isinstance(i, bool) for i in order):
        raise ValueError(f"order must be a permutation of 0..{k - 1}, got {list(order)!r}")
    moved = [keyframes[i] for i in perm]
    if raw_q is None or len(raw_q) == 0:
        return [Keyframe(kf.q, None) for kf in moved]
    slots = sorted(
        kf.anchor if kf.anchor is not None and kf.anchor < len(raw_q) else nearest_sample(kf.q, raw_q)
        for kf in keyframes
    )
    return [Keyframe(kf.q, a) for kf, a in zip(moved, slots, strict=True)]
