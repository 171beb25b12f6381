"""What a teach session returns: one update's :class:`DragResult` and a :class:`Recording`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["DragResult", "Recording"]


@dataclass(frozen=True)
class DragResult:
    """Outcome of one drag update (or panel move).

    Attributes:
        accepted: the arm moved to the new configuration.
        q: (n,) configuration after the update (the old one when refused), rad.
        in_collision: the candidate configuration was in collision (so it was refused).
        reached_goal: the tool is inside the goal region after the update.
        reachable: IK put the tool on the target (False: workspace boundary, best effort).
        reason: ``"ok"``, ``"best_effort"`` (accepted, target out of reach),
            ``"collision"``, ``"joint_jump"``, ``"unreachable"``.
        tool: (3,) tool position after the update, m.
        target: (3,) requested tool position, m.
        latency: seconds spent in IK + collision check.
        detail: collision kind or IK note, for the UI.
    """

    accepted: bool
    q: np.ndarray
    in_collision: bool
    reached_goal: bool
    reachable: bool = True
    reason: str = "ok"
    tool: np.ndarray = field(default_factory=lambda: np.zeros(3))
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    latency: float = 0.0
    detail: str = ""


@dataclass(frozen=True)
class Recording:
    """A recorded demonstration: ``t`` (N,) s from 0, strictly increasing; ``q`` (N, n) rad;
    ``tool`` (N, 3) m (tool positions, base frame)."""

    t: np.ndarray
    q: np.ndarray
    tool: np.ndarray

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def path_length(self) -> float:
        """Length of the tool path, m."""
        return float(np.linalg.norm(np.diff(self.tool, axis=0), axis=1).sum()) if len(self) > 1 else 0.0
