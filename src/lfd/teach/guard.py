"""The collision rule every move of a teach session obeys, and the session's counters.

A move (a drag update, a slider change, an x/y/z entry, a stored waypoint's segment) is checked along
its straight joint-space segment (:func:`lfd.teach.checks.sweep`, every ``sweep_resolution`` rad), not only
at its end. :class:`MoveGuard` counts what happens: ``collisions`` counts collision *events* (a run of
consecutive refused updates is one; an accepted move ends the run), ``counters`` every update by outcome
(keys :data:`COUNTERS`), ``latencies`` the drag updates' IK + check times (s).
"""

from __future__ import annotations

import numpy as np

from lfd.sim.collision import CollisionReport, CollisionWorld

from .checks import sweep

__all__ = ["COUNTERS", "MoveGuard"]

#: The counters of a session, each counting updates (or stores) of one kind.
COUNTERS = (
    "drag_updates",
    "accepted",
    "refused_collision",
    "refused_jump",
    "refused_unreachable",
    "best_effort",
    "panel_moves",
    "stores",
    "refused_stores",
)


class MoveGuard:
    """Collision checks of moves and the counters (see the module docstring).

    Args:
        world: the collision world of the arm and the scene.
        sweep_resolution: rad (> 0), spacing of the checks along a move's joint-space segment.
    """

    def __init__(self, world: CollisionWorld, sweep_resolution: float) -> None:
        if not sweep_resolution > 0:
            raise ValueError("sweep_resolution must be positive (rad)")
        self.world = world
        self.sweep_resolution = float(sweep_resolution)
        self.collisions = 0
        self.counters: dict[str, int] = dict.fromkeys(COUNTERS, 0)
        self.latencies: list[float] = []
        self._refusing = False

    def sweep(self, q_from: np.ndarray, q_to: np.ndarray) -> CollisionReport:
        """Collision report of the joint-space segment ``q_from -> q_to`` (n,) rad."""
        return sweep(self.world, q_from, q_to, self.sweep_resolution)

    def count(self, key: str) -> None:
        """One more update of kind ``key`` (one of :data:`COUNTERS`)."""
        self.counters[key] += 1

    def refused(self, reason: str) -> None:
        """Count a refused update: ``"collision"`` (a new collision event unless the previous update was
        refused for a collision too), ``"joint_jump"`` or ``"unreachable"``."""
        if reason == "collision":
            self.counters["refused_collision"] += 1
            if not self._refusing:
                self.collisions += 1
            self._refusing = True
        else:
            self.counters[f"refused_{'jump' if reason == 'joint_jump' else 'unreachable'}"] += 1

    def accepted(self, reachable: bool) -> None:
        """Count an accepted update (``reachable`` False: a best effort at the workspace boundary)."""
        self.settle()
        self.counters["accepted"] += 1
        if not reachable:
            self.counters["best_effort"] += 1

    def settle(self) -> None:
        """End a run of refused updates: the next collision is a new event."""
        self._refusing = False
