"""Normalisation statistics of a dataset, computed on the train split only."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # the episode reader pulls in the simulator's discard reasons
    from lfd.visuomotor.data.episodes import EpisodeRecord

#: Smallest standard deviation written (a constant quantity gets std = STD_FLOOR).
STD_FLOOR = 1e-6

#: Statistic name -> (episode array, how samples are taken from it).
_SOURCES = {
    "joints": "joints",  # every step of every episode, (7,)
    "velocity": "velocities",  # every step, (7,)
    "goal": "dmp_goal",  # one per episode, (7,)
    "weights": "dmp_weights",  # one per episode, (7, K)
    "target_point": "target_point",  # one per episode, (3,)
}
_PER_STEP = ("joints", "velocity")


def compute_stats(train: Sequence[EpisodeRecord]) -> dict[str, dict[str, list]]:
    """``{name: {"mean": ..., "std": ...}}`` for ``joints`` and ``velocity`` (over all steps,
    shape ``(7,)``), ``goal`` ``(7,)``, ``weights`` ``(7, K)`` and ``target_point`` ``(3,)``
    (over episodes), as nested lists; std is the population std floored at
    :data:`STD_FLOOR`."""
    if not train:
        raise ValueError("compute_stats: the train split is empty")
    out = {}
    for name, key in _SOURCES.items():
        values = np.stack([rec.arrays[key] for rec in train]).astype(np.float64)
        if name in _PER_STEP:
            values = values.reshape(-1, values.shape[-1])
        out[name] = {
            "mean": values.mean(axis=0).tolist(),
            "std": np.maximum(values.std(axis=0), STD_FLOOR).tolist(),
            "count": int(values.shape[0]),
        }
    return out
