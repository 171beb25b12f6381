"""The only owner of MuJoCo and Meta-World (the optional extra ``pip install -e ".[metaworld]"``):
any of Meta-World's 50 tasks by name, with lfd's robot state, seeded placements per split, upright
camera images, position targets as Meta-World actions, and the scripted experts recorded as
demonstrations.

Names are loaded on first use (PEP 562): ``import lfd.metaworld`` needs neither package.

Example (runnable with the extra)::

    from lfd.metaworld import MetaWorldTask, placement_seed, record_expert

    with MetaWorldTask("push-v3", image_size=96) as task:
        episode = record_expert(task, placement_seed(seed=0, split="train", index=0), n_steps=150)
    episode.frames.shape, episode.states.shape, episode.success   # (150, 96, 96, 3), (150, 4), True
"""

from typing import TYPE_CHECKING

from lfd._lazy import exports, lazy_getattr

_EXPORTS = exports(
    {
        "env": [
            "CAMERAS",
            "CONTROL_DT",
            "GOAL_MARKER_RADIUS",
            "MT10",
            "SPLIT_KEYS",
            "MetaWorldTask",
            "check_task",
            "placement_seed",
            "task_names",
        ],
        "expert": ["ExpertEpisode", "record_expert"],
    }
)
__getattr__, __dir__ = lazy_getattr(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)

if TYPE_CHECKING:
    from lfd.metaworld.env import (
        CAMERAS,
        CONTROL_DT,
        GOAL_MARKER_RADIUS,
        MT10,
        SPLIT_KEYS,
        MetaWorldTask,
        check_task,
        placement_seed,
        task_names,
    )
    from lfd.metaworld.expert import ExpertEpisode, record_expert
