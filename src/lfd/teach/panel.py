"""The 2-D joint panel of a teach session (the baseline interface): what its inputs mean.

:class:`Panel` turns the panel's inputs into configurations: :meth:`Panel.joints` checks the
sliders' configuration (length, finite, within the limits) and clamps it like the drag IK;
:meth:`Panel.solve` is the x/y/z entry's IK (the drag IK with a 0.2 s budget from the current
configuration, then the batched IK with 32 restarts). The session
(:class:`~lfd.teach.session.TeachSession`) moves the arm there under the same collision rule as a
drag (:class:`~lfd.teach.guard.MoveGuard`) and records the stored waypoints
(:class:`~lfd.teach.recording.Recorder`). Units: rad, m.
"""

from __future__ import annotations

import numpy as np

from lfd.robots import Robot

from .checks import check_joint_limits, check_vector
from .drag_ik import DragIK, IKStep

__all__ = ["Panel"]


class Panel:
    """The panel's input rules (see the module docstring).

    Args:
        robot: the arm.
        ik: the session's drag IK (its clamp and its ``wam_q3`` choice are shared).
    """

    def __init__(self, robot: Robot, ik: DragIK) -> None:
        self.robot, self.ik = robot, ik

    def joints(self, q) -> np.ndarray:
        """The sliders' configuration ``q (n,)`` rad, checked and clamped.

        Raises:
            ValueError: wrong length, NaN, a joint outside its limits (named).
        """
        q = check_vector(q, self.robot.n_dof, "q")
        check_joint_limits(self.robot, q)
        return self.ik.clamp(q)

    def solve(self, q_current: np.ndarray, target: np.ndarray, orientation=None) -> IKStep:
        """IK to the tool position ``target (3,)`` m from ``q_current (n,)`` rad, with restarts if that
        fails; ``reached`` False when no configuration puts the tool within 1 mm."""
        step = DragIK(self.robot, time_budget=0.2, wam_q3=self.ik.wam_q3).solve(
            q_current, target, orientation
        )
        if not step.reached:
            res = self.robot.ik(target[None], q_current[None], restarts=32, tol_pos=1e-4)
            if bool(res.success[0]):
                step = IKStep(res.q[0].numpy(), True, float(res.pos_error[0]), 0.0, 0, False, "lm")
        return step
