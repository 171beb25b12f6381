"""The scripted experts of Meta-World (``metaworld.policies``) recorded as lfd demonstrations."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lfd.metaworld.env import MetaWorldTask

__all__ = ["ExpertEpisode", "record_expert"]


@dataclass(frozen=True)
class ExpertEpisode:
    """One expert episode of ``T`` control steps.

    Attributes:
        frames: ``(T, H, W, 3)`` uint8 upright camera images, frame ``t`` seen at state ``t``.
        states: ``(T, 4)`` float64 robot states (hand xyz m, last gripper command) before each action.
        actions: ``(T, 4)`` float32 Meta-World actions the expert sent.
        solved: ``(T,)`` bool, the task's success flag after each action.
        placement: the task's random reset vector.
        reset_seed: the seed the placement was drawn from.
    """

    frames: np.ndarray
    states: np.ndarray
    actions: np.ndarray
    solved: np.ndarray
    placement: np.ndarray
    reset_seed: int

    @property
    def success(self) -> bool:
        """Solved at any step."""
        return bool(self.solved.any())

    @property
    def first_success(self) -> int:
        """Index of the first solved step, -1 if none."""
        hits = np.flatnonzero(self.solved)
        return int(hits[0]) if hits.size else -1


def record_expert(task: MetaWorldTask, reset_seed: int, n_steps: int, render: bool = True) -> ExpertEpisode:
    """Run the task's scripted expert for ``n_steps`` control steps from the placement of
    ``reset_seed`` (the episode runs to the end, also after success). ``render=False`` leaves
    ``frames`` empty ``(0, H, W, 3)``.

    Raises:
        ValueError: ``n_steps`` not an int in 2..the task's ``max_path_length``.
    """
    if isinstance(n_steps, bool) or not isinstance(n_steps, int) or not 2 <= n_steps <= task.max_path_length:
        raise ValueError(f"n_steps: expected an int in 2..{task.max_path_length}, got {n_steps!r}")
    state = task.reset(reset_seed)
    size = task.image_size
    frames = np.zeros((n_steps if render else 0, size, size, 3), np.uint8)
    states = np.zeros((n_steps, 4))
    actions = np.zeros((n_steps, 4), np.float32)
    solved = np.zeros(n_steps, bool)
    for t in range(n_steps):
        states[t] = state
        if render:
            frames[t] = task.render()
        actions[t] = task.expert_action()
        solved[t] = task.step(actions[t])
        state = task.state()
    return ExpertEpisode(frames, states, actions, solved, task.placement.copy(), int(reset_seed))
