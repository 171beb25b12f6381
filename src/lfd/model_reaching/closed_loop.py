"""The models' closed loop (thesis ch. 5): a forward model estimates the tool position from the
measured joints and an inverse model turns the estimated error into joint velocities, for a
batch of simulated arms (:mod:`lfd.sim.arms`); no camera.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

__all__ = ["ReachTrace", "closed_loop_reach"]


@dataclass(frozen=True)
class ReachTrace:
    """One closed-loop reach driven by the models.

    Attributes:
        t: ``(T,)`` times (s). q: ``(T, n)`` joints (rad).
        x: ``(T, 3)`` true end-effector positions (robot FK, m).
        x_model: ``(T, 3)`` forward-model estimates (m).
        reached: the estimated error fell below the threshold before the step cap.
    """

    t: np.ndarray
    q: np.ndarray
    x: np.ndarray
    x_model: np.ndarray
    reached: bool

    def final_error(self, goal: np.ndarray) -> float:
        """True final distance (m) to ``goal``."""
        return float(np.linalg.norm(self.x[-1] - goal))


def closed_loop_reach(
    forward: Callable[[Tensor], Tensor],
    inverse: Callable[[Tensor], Tensor],
    robot,
    goals: np.ndarray,
    q_start: np.ndarray,
    arm,
    max_steps: int = 300,
    threshold: float = 0.02,
) -> list[ReachTrace]:
    """Drive ``B`` arms from ``q_start (n,)`` towards ``goals (B, 3)`` (m).

    Every step: ``x_hat = forward(q)``; arms whose ``||x_hat - goal||`` is below
    ``threshold`` (m) stop; the others get ``qd = inverse(x_hat - goal)`` clamped to the
    robot's velocity limits. ``forward`` maps float32 joints ``(B, n)`` to positions
    ``(B, 3)`` (the forward model), ``inverse`` errors ``(B, 3)`` to joint velocities
    ``(B, n)`` (a task's inverse model); ``arm`` is a :class:`~lfd.sim.arms.KinematicArm`
    or :class:`~lfd.sim.arms.PyBulletArm` (its ``dt`` is the control period).

    Returns:
        One :class:`ReachTrace` per goal, each ending at its stop (or at the cap).
    """
    goals = np.asarray(goals, dtype=np.float64)
    if goals.ndim != 2 or goals.shape[1] != 3 or not np.all(np.isfinite(goals)):
        raise ValueError(
            f"closed_loop_reach: goals must be finite (B, 3) positions (m), got shape {goals.shape}"
        )
    if max_steps < 0 or not threshold > 0:
        raise ValueError(
            f"closed_loop_reach: need max_steps >= 0 and threshold > 0 m, got {max_steps}, {threshold}"
        )
    limit = robot.velocity_limits.numpy()
    q = arm.reset(np.repeat(np.asarray(q_start, dtype=np.float64)[None], len(goals), axis=0))
    active = np.ones(len(goals), dtype=bool)
    stop = np.full(len(goals), max_steps)
    qs, estimates = [q], []
    with torch.no_grad():
        for step in range(max_steps + 1):
            x_hat = forward(torch.from_numpy(q).float()).double().numpy()
            estimates.append(x_hat)
            arrived = active & (np.linalg.norm(x_hat - goals, axis=1) < threshold)
            stop[arrived] = step
            active &= ~arrived
            if step == max_steps or not active.any():
                break
            qd = np.clip(inverse(torch.from_numpy(x_hat - goals).float()).double().numpy(), -limit, limit)
            q = arm.step(np.where(active[:, None], qd, 0.0))
            qs.append(q)
    arm.close()
    qs, estimates = np.stack(qs, axis=1), np.stack(estimates, axis=1)
    truth = robot.fk_positions(qs).numpy()
    return [
        ReachTrace(
            t=np.arange(n + 1) * arm.dt,
            q=qs[b, : n + 1],
            x=truth[b, : n + 1],
            x_model=estimates[b, : n + 1],
            reached=not active[b],
        )
        for b, n in enumerate(stop)
    ]
