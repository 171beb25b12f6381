"""The 2-D joint panel of a teach session (the baseline interface).

:meth:`PanelMixin.set_joints` (the sliders) and :meth:`PanelMixin.move_to` (the x/y/z
entry, IK) move the arm under the same collision rule as a drag; :meth:`PanelMixin.store`
appends the current configuration as a waypoint, refused when the joint-space segment
from the previous waypoint passes through a collision. :class:`~lfd.teach.session.TeachSession`
provides the state (``q``, ``robot``, ``ik``, ``kin``, counters) and the shared
``_accept`` / ``_refuse`` / ``_sweep`` rule.
"""

from __future__ import annotations

import time

from .checks import check_joint_limits, check_vector
from .drag_ik import DragIK, IKStep
from .results import DragResult

__all__ = ["PanelMixin"]


class PanelMixin:
    """The panel's actions (see the module docstring)."""

    def set_joints(self, q) -> DragResult:
        """The sliders: put the arm at ``q`` (n,) rad if it is collision-free (else refused).

        Raises:
            ValueError: wrong length, NaN, a joint outside its limits (named).
        """
        q = check_vector(q, self.n_dof, "q")
        check_joint_limits(self.robot, q)
        q = self.ik._clamp(q)
        tic = time.perf_counter()
        self.counters["panel_moves"] += 1
        report = self._sweep(self.q, q)
        latency = time.perf_counter() - tic
        target = self.kin.tool_position(q)
        if report.in_collision:
            return self._refuse("collision", target, None, latency, report.kind or "")
        return self._accept(q, target, True, latency)

    def move_to(self, position, orientation=None) -> DragResult:
        """The x/y/z entry: IK (from the current configuration, with restarts if that
        fails) to ``position`` (3,) m, then the same rule as :meth:`set_joints`;
        refused (``"unreachable"``) when no configuration reaches it within 1 mm."""
        target = self._check_vector(position, 3, "position")
        tic = time.perf_counter()
        rot = None if orientation is None else orientation
        step = DragIK(self.robot, time_budget=0.2, wam_q3=self.ik.wam_q3).solve(self.q, target, rot)
        if not step.reached:
            res = self.robot.ik(target[None], self.q[None], restarts=32, tol_pos=1e-4)
            if bool(res.success[0]):
                step = IKStep(res.q[0].numpy(), True, float(res.pos_error[0]), 0.0, 0, False, "lm")
        if not step.reached:
            self.counters["panel_moves"] += 1
            return self._refuse("unreachable", target, step, time.perf_counter() - tic, "no IK solution")
        result = self.set_joints(step.q)
        return result

    def store(self) -> bool:
        """Store the current configuration as a waypoint (2-D). Returns False (and counts a
        collision) when the joint-space segment from the previous waypoint collides."""
        if self._mode != "2d":
            raise ValueError("store() is the 2-D panel's action; this session is in mode '3d'")
        if self.recording_state == "done":
            return False
        if self.recording_state == "idle":
            self._begin()
        self.counters["stores"] += 1
        if self._sweep(self._waypoints[-1], self.q).in_collision:
            self.counters["refused_stores"] += 1
            self._refuse("collision", self.tool_position, None, 0.0, "segment")
            return False
        self._refusing = False
        self._waypoints.append(self.q.copy())
        if self.in_goal:
            self._finish("goal")
        return True

    def go_home(self) -> None:
        """Put the arm back at the scene's start pose (not recorded)."""
        self.q = self.start.copy()
