"""What a policy checkpoint records of the run that trained it, and one dataset per evaluation.

``train.py`` gives every policy the settings of its run before fitting
(:attr:`lfd.visuomotor.policies.VisuomotorPolicy.training_run`), and the checkpoint keeps them
under :data:`~lfd.visuomotor.policies.base.TRAINING_RUN_KEY`::

    {"experiment": "quick" | None,          # the experiment config of the run
     "data_config": "quick" | "lerobot" ..., # the data config group's choice
     "data": {...}}                         # the data config's plain values (resolved)

``evaluate.py`` uses them so that ``python train.py model=X`` then ``python evaluate.py`` scores
the checkpoint on the data it was trained for, with no override repeated. Nothing in them is
instantiated or run: they are plain values, read with ``weights_only=True``, and only keys the
evaluation's own data config already has are taken over (never a ``_target_``).

Example::

    >>> same_dataset({"name": "a", "seed": 1, "batch_size": 8}, {"name": "a", "seed": 1, "batch_size": 32})
    True
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

from lfd.training import read_checkpoint
from lfd.visuomotor.data.config import GeneratorConfig
from lfd.visuomotor.policies.base import TRAINING_RUN_KEY

#: Data settings that say which dataset a policy saw: the generator's (its content) and the name.
DATASET_KEYS = ("name", *(f.name for f in dataclasses.fields(GeneratorConfig)))


def training_run(path: str | Path) -> dict[str, Any] | None:
    """The training run a policy checkpoint recorded (module docstring), or None for a
    checkpoint that recorded none (an earlier release's) or a malformed record.

    Raises:
        FileNotFoundError, lfd.training.CheckpointError: see :func:`lfd.training.read_checkpoint`.
    """
    run = read_checkpoint(path).get(TRAINING_RUN_KEY)
    if not isinstance(run, Mapping) or not isinstance(run.get("data", {}), Mapping):
        return None
    experiment, choice = run.get("experiment"), run.get("data_config")
    if not (experiment is None or isinstance(experiment, str)) or not (
        choice is None or isinstance(choice, str)
    ):
        return None
    return {"experiment": experiment, "data_config": choice, "data": dict(run.get("data", {}))}


def same_dataset(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    """Whether two data configs' plain values name the same dataset (:data:`DATASET_KEYS`;
    loading settings such as the batch size or the input depth may differ)."""
    return all(a.get(k) == b.get(k) for k in DATASET_KEYS)


def shared_training_run(
    checkpoints: Mapping[str, Path], given: Collection[str] = ()
) -> tuple[dict[str, Any] | None, dict[str, Path], list[str]]:
    """The training run that an evaluation of ``checkpoints`` (``{kind: path}``) follows: that of
    the newest checkpoint among the ``given`` kinds (named on the command line), else among all.
    A found (not given) checkpoint trained on another dataset is left out with a note; checkpoints
    that recorded no run are kept as they are.

    Returns:
        ``(run or None, the checkpoints kept, notes)``: each note one line naming a left-out file.

    Raises:
        ValueError: a given checkpoint was trained on another dataset than the reference (one
            line naming both files).
    """
    runs = {kind: training_run(path) for kind, path in checkpoints.items()}
    recorded = [k for k, run in runs.items() if run is not None]
    pool = [k for k in recorded if k in given] or recorded
    if not pool:
        return None, dict(checkpoints), []
    ref = max(pool, key=lambda k: checkpoints[k].stat().st_mtime)
    reference = runs[ref]
    kept, notes = {}, []
    for kind, path in checkpoints.items():
        run = runs[kind]
        if run is None or same_dataset(run["data"], reference["data"]):
            kept[kind] = path
            continue
        why = (
            f"{kind} checkpoint {path} was trained on dataset {run['data'].get('name')!r}, "
            f"{ref} checkpoint {checkpoints[ref]} on {reference['data'].get('name')!r}"
        )
        if kind in given:
            raise ValueError(f"{why}: evaluate them apart")
        notes.append(f"left out: {why} (pass ckpt=PATH or eval.kinds=[...] to choose)")
    return reference, kept, notes
