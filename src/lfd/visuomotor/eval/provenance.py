"""What a policy checkpoint records of the run that trained it, and one dataset per evaluation.

``train.py`` gives every policy the settings of its run before fitting
(:attr:`lfd.visuomotor.policies.VisuomotorPolicy.training_run`), and the checkpoint keeps them
under :data:`~lfd.visuomotor.policies.base.TRAINING_RUN_KEY`::

    {"experiment": "quick" | None,          # the experiment config of the run
     "data_config": "quick" | "lerobot" ..., # the data config group's choice
     "seed": 42,                            # the run's seed
     "data": {...}}                         # the data config's plain values (resolved)

``evaluate.py`` uses them so that ``python train.py model=X`` then ``python evaluate.py`` scores
the checkpoint on the data it was trained for, with no override repeated. Nothing in them is
instantiated or run: they are plain values, read with ``weights_only=True`` and checked by
:func:`training_run` (names, one-component dataset names, scalars without interpolations), and
only keys the evaluation's own data config already has, with values of the same type, are taken
over (never a ``_target_`` or a nested mapping).

Example::

    >>> same_dataset({"name": "a", "seed": 1, "batch_size": 8}, {"name": "a", "seed": 1, "batch_size": 32})
    True
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Collection, Mapping
from pathlib import Path
from typing import Any

from lfd.training import read_checkpoint
from lfd.visuomotor.data.config import GeneratorConfig
from lfd.visuomotor.policies.base import TRAINING_RUN_KEY

#: Data settings that say which dataset a policy saw: the generator's (its content) and the name.
DATASET_KEYS = ("name", *(f.name for f in dataclasses.fields(GeneratorConfig)))


#: A recorded config choice (experiment, data config): a config file's name, nothing else.
CHOICE = re.compile(r"[A-Za-z0-9_]+")


def _plain(value: Any) -> bool:
    """A scalar, or a list of scalars, with no interpolation (``${...}``) in any string."""
    if isinstance(value, (list, tuple)):
        return all(_plain(v) and not isinstance(v, (list, tuple)) for v in value)
    if isinstance(value, str):
        return "${" not in value
    return value is None or isinstance(value, (bool, int, float))


def training_run(path: str | Path) -> dict[str, Any] | None:
    """The training run a policy checkpoint recorded (module docstring), or None for a
    checkpoint of an earlier release, which recorded none.

    Only plain values pass: config choices that are names (``[A-Za-z0-9_]+``), a dataset ``name``
    that is one path component, data values that are scalars or lists of scalars without
    interpolations (a ``_target_``-style key or a nested mapping never reaches Hydra).

    Raises:
        FileNotFoundError, lfd.training.CheckpointError: see :func:`lfd.training.read_checkpoint`.
        ValueError: a malformed record (one line naming the file and the field).
    """
    run = read_checkpoint(path).get(TRAINING_RUN_KEY)
    if run is None:
        return None

    def bad(field: str, expected: str) -> ValueError:
        return ValueError(f"{path}: the recorded training run's {field} must be {expected}")

    if not isinstance(run, Mapping):
        raise bad("record", "a mapping")
    for field in ("experiment", "data_config"):
        value = run.get(field)
        if value is not None and not (isinstance(value, str) and CHOICE.fullmatch(value)):
            raise bad(field, "a config name ([A-Za-z0-9_]+) or null")
    seed = run.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int)):
        raise bad("seed", "an integer or null")
    data = run.get("data", {})
    if not isinstance(data, Mapping) or not all(isinstance(k, str) for k in data):
        raise bad("data", "a mapping of settings")
    for key, value in data.items():
        if not key.startswith("_") and not _plain(value):
            raise bad(f"data.{key}", "a plain value (a number, a string without ${...}, a list of them)")
    name = data.get("name")
    if name is not None and (not isinstance(name, str) or Path(name).name != name or name in ("", ".", "..")):
        raise bad("data.name", "a dataset folder's name (one path component)")
    return {
        "experiment": run.get("experiment"),
        "data_config": run.get("data_config"),
        "seed": seed,
        "data": {k: v for k, v in data.items() if not k.startswith("_")},
    }


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
