"""What the imitation stages hand each other: the fitted DMP (:class:`DMPFit`) and its execution
(:class:`Execution`). Units: s, rad, m."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["DMPFit", "Execution"]


@dataclass(frozen=True)
class DMPFit:
    """The fit stage's result: the ``dmp`` fitted on robot time ``t_robot (T,)`` s, its rollout
    ``q_dmp (T, n)`` rad clipped into the limits, the time-scale ``factor`` of the DMP rollout
    and ``factor_retargeted`` (the one the raw retargeted samples would need)."""

    dmp: Any
    t_robot: np.ndarray
    q_dmp: np.ndarray
    factor: float
    factor_retargeted: float


@dataclass(frozen=True)
class Execution:
    """The execution stage's result: executed joints ``q_exec (T, n)`` rad at the DMP's times, the robot
    renders (one per sample when frames were asked for) and the goal result (None without
    a goal): ``goal_m``, ``ik_success``, ``final_tool_error_m``."""

    q_exec: np.ndarray
    images: list
    goal: dict | None
