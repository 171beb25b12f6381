"""Shared helpers for the teach tests (scripted clock and drags)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
BOXES = ROOT / "configs" / "teach" / "boxes.yaml"


class FakeClock:
    """A clock that advances ``dt`` seconds per call (scripted users move at a fixed rate)."""

    def __init__(self, dt: float = 0.04) -> None:
        self.now, self.dt = 0.0, dt

    def __call__(self) -> float:
        self.now += self.dt
        return self.now


def drag_line(session, a, b, n: int = 20) -> list:
    """Drag the tool from ``a`` to ``b`` in ``n`` equal updates; the list of DragResults."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return [session.drag(a + (b - a) * s) for s in np.linspace(0.0, 1.0, n + 1)[1:]]
