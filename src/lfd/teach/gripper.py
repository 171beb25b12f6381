"""Gripper events of a taught motion: open or close the gripper at a time of the motion.

A :class:`GripperEvent` says that from ``t`` seconds of the motion on the gripper is closed
(``closed=True``) or open. Before the first event the gripper is open. :func:`gripper_state` gives
the state along a time grid (0 open, 1 closed). The session keeps the events in the motion's time at
speed 1 so that a change of speed moves them with the motion (see
:attr:`lfd.teach.session.TeachSession.gripper_events`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["GripperEvent", "gripper_state"]


@dataclass(frozen=True)
class GripperEvent:
    """From ``t`` s of the motion on, the gripper is closed (``closed``) or open."""

    t: float
    closed: bool


def gripper_state(events: Sequence[GripperEvent], t: np.ndarray) -> np.ndarray:
    """``(T,)`` float, 1.0 where the gripper is closed at the times ``t`` (T,) s, else 0.0 (open before the
    first event; an event at exactly ``t`` already holds there; events need not be sorted)."""
    t = np.asarray(t, dtype=float)
    state = np.zeros(t.shape)
    for e in sorted(events, key=lambda e: e.t):
        state[t >= e.t] = 1.0 if e.closed else 0.0
    return state
