"""The policies' closed-loop controllers (:class:`lfd.visuomotor.protocols.Controller`), one per
kind, returned by :meth:`lfd.visuomotor.policies.VisuomotorPolicy.controller`.

* :class:`PlanController` (CNN -> DMP): one ``policy.plan(image, joints, n_steps=S + 1)``
  call on the first observation of an episode of ``S`` control steps, then the planned
  trajectory is tracked sample by sample (position control with velocity feed-forward,
  like the demonstrations); the DMP plan covers the whole episode (past its duration it
  keeps converging to its goal), and a shorter plan is held at its last sample.
* :class:`VelocityController` (velocity baseline): ``policy.act(image, joints, time)``
  every control step, executed by *velocity control*: the commanded joint velocity is the
  velocity the joints move at for the control period, as the policy's labels are the
  demonstrations' joint motion per period, ``(q[t+1] - q[t]) / dt``
  (:func:`lfd.visuomotor.data.datasets.command_velocities`); commanding the labels reproduces a
  demonstration (``tests/visuomotor/eval/test_eval_velocity_labels.py``).

A controller reads from its policy only the closed-loop method and the input it was built
for (``input_channels``, ``depth_encoding``).
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np

from lfd.visuomotor.protocols import Observation

__all__ = ["PlanController", "VelocityController"]


class _PolicyController:
    """Shared state: the policy, the control period ``dt`` (s) and the policy's input."""

    actuation: Literal["position", "velocity"] = "position"

    def __init__(self, policy, dt: float) -> None:
        self.policy, self.dt = policy, dt
        self.input_channels = int(policy.input_channels)
        self.depth_encoding = str(policy.depth_encoding)


class PlanController(_PolicyController):
    """Runs a trajectory-planning policy (``plan(image, joints, n_steps) -> (T, n)`` rad) in
    closed loop: plans on the first observation, then tracks the plan (position control)."""

    def __init__(self, policy, dt: float) -> None:
        super().__init__(policy, dt)
        self.plan: np.ndarray | None = None
        self.velocity: np.ndarray | None = None
        self.horizon: int | None = None

    @property
    def needs_image(self) -> bool:
        """Whether :meth:`command` will look at the image this step (only before it has planned)."""
        return self.plan is None

    def start(self, steps: int | None = None) -> None:
        """A new episode of ``steps`` control steps (None: plan the policy's default length)."""
        self.plan = self.velocity = None
        self.horizon = None if steps is None else steps + 1

    def command(self, obs: Observation, step: int, latencies: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """Joint position and velocity targets ``(n,)`` for control step ``step`` (0-based)."""
        if self.plan is None:
            t0 = time.perf_counter()
            if self.horizon is None:
                plan = self.policy.plan(obs.image, obs.joints)
            else:
                plan = self.policy.plan(obs.image, obs.joints, n_steps=self.horizon)
            self.plan = np.asarray(plan, dtype=np.float64)
            latencies.append((time.perf_counter() - t0) * 1e3)
            self.velocity = np.gradient(self.plan, self.dt, axis=0)
        k = step + 1
        if k < len(self.plan):
            return self.plan[k], self.velocity[k]
        return self.plan[-1], np.zeros_like(self.plan[-1])


class VelocityController(_PolicyController):
    """Runs a velocity policy (``act(image, joints, time) -> (n,)`` rad/s) every control step;
    :meth:`command` returns the position one period ahead and the velocity, executed by
    velocity control (:attr:`actuation`)."""

    needs_image = True
    actuation = "velocity"

    def start(self, steps: int | None = None) -> None:
        """Nothing to reset: the controller is stateless (it acts until the episode ends)."""

    def command(self, obs: Observation, step: int, latencies: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """``(joints + qd dt, qd)`` for the policy's velocity ``qd`` (rad/s) at this observation."""
        t0 = time.perf_counter()
        qd = np.asarray(self.policy.act(obs.image, obs.joints, obs.time), dtype=np.float64)
        latencies.append((time.perf_counter() - t0) * 1e3)
        return obs.joints + qd * self.dt, qd
