"""The policies' closed-loop controllers (:class:`lfd.visuomotor.protocols.Controller`), one per
kind, returned by :meth:`lfd.visuomotor.policies.VisuomotorPolicy.controller`.

* :class:`PlanController` (CNN -> DMP): one ``policy.plan(image, joints, n_steps=S + 1)``
  call on the first observation of an episode of ``S`` control steps, then the planned
  trajectory is tracked sample by sample (position control with velocity feed-forward,
  like the demonstrations); the DMP plan covers the whole episode (past its duration it
  keeps converging to its goal), and a shorter plan is held at its last sample. With
  ``replan_every=k`` the DMP's goal is re-predicted from the camera every ``k`` steps and
  changed online (the DMP keeps its position, velocity and phase), and the rest of the plan
  is integrated anew.
* :class:`VelocityController` (velocity baseline): ``policy.act(image, joints, time)``
  every control step, executed by *velocity control*: the commanded joint velocity is the
  velocity the joints move at for the control period, as the policy's labels are the
  demonstrations' joint motion per period, ``(q[t+1] - q[t]) / dt``
  (:func:`lfd.visuomotor.data.datasets.command_velocities`); commanding the labels reproduces a
  demonstration (``tests/visuomotor/eval/test_eval_velocity_labels.py``).
* :class:`ChunkController` (ACT, Diffusion Policy): ``policy.act_chunk(image, joints)`` every
  ``replan_every`` steps (receding horizon), each chunk tracked like a plan (position control
  with velocity feed-forward); with ``ensemble_m`` the commands of every stored chunk that
  covers the step are averaged with ACT's temporal-ensembling weights.

A controller reads from its policy only the closed-loop method and the input it was built
for (``input_channels``, ``depth_encoding``).
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np

from lfd.visuomotor.protocols import Observation

__all__ = ["ChunkController", "PlanController", "VelocityController"]


class _PolicyController:
    """Shared state: the policy, the control period ``dt`` (s) and the policy's input."""

    actuation: Literal["position", "velocity"] = "position"

    def __init__(self, policy, dt: float) -> None:
        self.policy, self.dt = policy, dt
        self.input_channels = int(policy.input_channels)
        self.depth_encoding = str(policy.depth_encoding)


class PlanController(_PolicyController):
    """Runs a trajectory-planning policy (``plan(image, joints, n_steps) -> (T, n)`` rad) in
    closed loop: plans on the first observation, then tracks the plan (position control).

    Args:
        policy: the policy (``plan``; with ``replan_every`` also ``plan_dmp``, ``predict_goal``
            and ``change_goal``, as :class:`~lfd.visuomotor.policies.cnn_dmp.CNNDMPPolicy`).
        dt: control period, s (the plan's sample spacing).
        replan_every: None: plan once. An int ``k >= 1``: at steps ``k, 2k, ...`` (where
            :attr:`needs_image` is True) ``policy.predict_goal(image, start_joints)`` gives a new
            goal from the new image, conditioned on the episode's start joints (the network's
            input in training), and ``policy.change_goal(plan, step, goal)`` switches the
            DMP's goal at this step, keeping its state, weights, phase and ``tau``; the plan
            from this step to the horizon is integrated anew and tracked as before.
        replan_weights: with ``replan_every``, re-predict the forcing weights too, not only the
            goal: ``policy.replan(plan, step, image, start_joints)`` switches the DMP to the new
            image's goal and weights from its current position and velocity.

    Raises:
        ValueError: ``replan_every`` is not an int >= 1 or None.
    """

    def __init__(
        self, policy, dt: float, replan_every: int | None = None, replan_weights: bool = False
    ) -> None:
        super().__init__(policy, dt)
        self.replan_every, _ = chunk_execution(replan_every, None, "PlanController")
        if not isinstance(replan_weights, bool):
            raise ValueError(f"PlanController: replan_weights must be a bool, got {replan_weights!r}")
        if replan_weights and self.replan_every is None:
            raise ValueError("PlanController: replan_weights=True needs replan_every (an int >= 1)")
        self.replan_weights = replan_weights
        self.plan: np.ndarray | None = None
        self.velocity: np.ndarray | None = None
        self.horizon: int | None = None
        self.dmp_plan = None  # the policy's DMPPlan while re-planning
        self.start_joints: np.ndarray | None = None
        self._step = 0

    @property
    def needs_image(self) -> bool:
        """Whether :meth:`command` will look at the image this step (before it has planned and,
        with ``replan_every``, at the steps that change the goal)."""
        return self.plan is None or self._replans(self._step)

    def _replans(self, step: int) -> bool:
        """Whether step ``step`` changes the goal (a multiple of ``replan_every`` that the plan covers)."""
        k = self.replan_every
        return k is not None and step > 0 and step % k == 0 and step + 1 < len(self.plan)

    def start(self, steps: int | None = None) -> None:
        """A new episode of ``steps`` control steps (None: plan the policy's default length)."""
        self.plan = self.velocity = self.dmp_plan = self.start_joints = None
        self.horizon = None if steps is None else steps + 1
        self._step = 0

    def command(self, obs: Observation, step: int, latencies: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """Joint position and velocity targets ``(n,)`` for control step ``step`` (0-based)."""
        if self.plan is None:
            t0 = time.perf_counter()
            if self.replan_every is not None:
                self.start_joints = np.array(obs.joints, dtype=np.float64)
                self.dmp_plan = self.policy.plan_dmp(obs.image, obs.joints, n_steps=self.horizon)
                plan = self.dmp_plan.trajectory
            elif self.horizon is None:
                plan = self.policy.plan(obs.image, obs.joints)
            else:
                plan = self.policy.plan(obs.image, obs.joints, n_steps=self.horizon)
            self.plan = np.asarray(plan, dtype=np.float64)
            latencies.append((time.perf_counter() - t0) * 1e3)
            self.velocity = np.gradient(self.plan, self.dt, axis=0)
        elif self._replans(step):
            t0 = time.perf_counter()
            if self.replan_weights:
                self.dmp_plan = self.policy.replan(self.dmp_plan, step, obs.image, self.start_joints)
            else:
                goal = self.policy.predict_goal(obs.image, self.start_joints)
                self.dmp_plan = self.policy.change_goal(self.dmp_plan, step, goal)
            self.plan = np.asarray(self.dmp_plan.trajectory, dtype=np.float64)
            latencies.append((time.perf_counter() - t0) * 1e3)
            self.velocity = np.gradient(self.plan, self.dt, axis=0)
        self._step = step + 1
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


def chunk_execution(
    replan_every: int | None, ensemble_m: float | None, owner: str, max_replan: int | None = None
) -> tuple[int | None, float | None]:
    """Checked chunk-execution settings (:class:`ChunkController`'s): ``replan_every`` an int in
    ``1..max_replan`` (no upper bound without it) or None, ``ensemble_m`` a finite number >= 0 or None.

    Raises:
        ValueError: either is out of range (bools are refused), naming ``owner``'s field.
    """
    if replan_every is not None and (
        isinstance(replan_every, bool)
        or not (
            isinstance(replan_every, (int, np.integer)) and 1 <= replan_every <= (max_replan or replan_every)
        )
    ):
        bound = f"in 1..chunk_size={max_replan}" if max_replan else ">= 1"
        raise ValueError(f"{owner}.replan_every: expected an int {bound} or None, got {replan_every!r}")
    if ensemble_m is not None and (
        isinstance(ensemble_m, bool)
        or not (
            isinstance(ensemble_m, (int, float, np.number)) and np.isfinite(ensemble_m) and ensemble_m >= 0
        )
    ):
        raise ValueError(f"{owner}.ensemble_m: expected a number >= 0 or None, got {ensemble_m!r}")
    return (
        None if replan_every is None else int(replan_every),
        None if ensemble_m is None else float(ensemble_m),
    )


class ChunkController(_PolicyController):
    """Runs an action-chunking policy (``act_chunk(image, joints) -> (k, n)`` rad, sample ``i``
    the position target of the command ``i`` steps after the query) in closed loop.

    Args:
        policy: the policy (``act_chunk``, ``input_channels``, ``depth_encoding``).
        dt: control period, s.
        replan_every: query the policy every this many steps (Diffusion Policy's action
            horizon; None: the chunk length, i.e. each chunk is executed to its end).
        ensemble_m: temporal ensembling (ACT, Zhao et al. 2023, Sec. 3.3): query every
            ``replan_every`` steps (1 in the paper) and command, at step ``s``, the weighted mean
            of the targets for ``s`` of every chunk that covers it, ``w_i = exp(-m i)`` with
            ``i = 0`` the *oldest* chunk; None: the newest chunk alone.

    Each chunk ``c`` queried at step ``s0`` on joints ``q0`` gives at step ``s`` the position
    target ``c[s - s0]`` and the velocity feed-forward ``np.gradient([q0, c...], dt)[s - s0 + 1]``
    (as :class:`PlanController`'s plan); with ensembling both are averaged with the same weights.
    Past the end of every stored chunk the last target is held at zero velocity.
    """

    def __init__(
        self, policy, dt: float, replan_every: int | None = None, ensemble_m: float | None = None
    ) -> None:
        super().__init__(policy, dt)
        self.replan_every, self.ensemble_m = chunk_execution(replan_every, ensemble_m, "ChunkController")
        self.chunks: list[tuple[int, np.ndarray, np.ndarray]] = []  # (start step, targets, velocities)
        self._next_query = self._step = 0

    def start(self, steps: int | None = None) -> None:
        """A new episode: forget the stored chunks and query at the first step."""
        self.chunks = []
        self._next_query = self._step = 0

    @property
    def needs_image(self) -> bool:
        """Whether the next :meth:`command` queries the policy (and so looks at the image)."""
        return self._step >= self._next_query

    def command(self, obs: Observation, step: int, latencies: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """Joint position and velocity targets ``(n,)`` for control step ``step`` (0-based)."""
        if step >= self._next_query:
            t0 = time.perf_counter()
            chunk = np.asarray(self.policy.act_chunk(obs.image, obs.joints), dtype=np.float64)
            latencies.append((time.perf_counter() - t0) * 1e3)
            path = np.concatenate([np.asarray(obs.joints, dtype=np.float64)[None], chunk])
            self.chunks.append((step, chunk, np.gradient(path, self.dt, axis=0)[1:]))
            self._next_query = step + (self.replan_every or len(chunk))
            if self.ensemble_m is None:
                self.chunks = self.chunks[-1:]
        self._step = step + 1
        live = [(s0, c, v) for s0, c, v in self.chunks if step - s0 < len(c)]
        self.chunks = live or self.chunks[-1:]
        if not live:
            s0, c, _ = self.chunks[-1]
            return c[-1].copy(), np.zeros_like(c[-1])
        if self.ensemble_m is None:
            s0, c, v = live[-1]
            return c[step - s0].copy(), v[step - s0].copy()
        w = np.exp(-self.ensemble_m * np.arange(len(live)))
        w = w / w.sum()
        q = sum(wi * c[step - s0] for wi, (s0, c, _) in zip(w, live))
        qd = sum(wi * v[step - s0] for wi, (s0, _, v) in zip(w, live))
        return q, qd
