"""The policy factory: policy classes by kind, and loading any policy checkpoint.

The registry is :data:`POLICIES` (kind -> class), filled as each policy class is defined
(:meth:`~lfd.visuomotor.policies.base.VisuomotorPolicy.__init_subclass__`); importing
:mod:`lfd.visuomotor.policies` registers the built-in ones. A checkpoint's kind is the ``kind``
hyper-parameter every policy saves; :func:`load_policy` picks the class from it, so a caller
never branches on file names.

Example::

    from lfd.visuomotor.policies.factory import load_policy

    policy = load_policy("outputs/train/.../checkpoints/last.ckpt")   # in eval mode
    controller = policy.controller(dt=0.02)                           # stepped by the evaluator
"""

from __future__ import annotations

from pathlib import Path

import torch

from lfd.training import CheckpointError, checkpoint_kind, load_checkpoint_module, read_checkpoint
from lfd.visuomotor.policies.base import POLICIES, VisuomotorPolicy

__all__ = ["POLICIES", "checkpoint_kind", "get_policy_class", "load_policy"]


def get_policy_class(kind: str) -> type[VisuomotorPolicy]:
    """The registered policy class of ``kind``.

    Raises:
        KeyError: no policy of that kind is registered (the message names the known kinds).
    """
    if kind not in POLICIES:
        raise KeyError(f"no policy kind {kind!r}; registered: {sorted(POLICIES)}")
    return POLICIES[kind]


def load_policy(path: str | Path, map_location: str | torch.device = "cpu") -> VisuomotorPolicy:
    """Load a policy checkpoint of any registered kind, in eval mode. The file is checked by
    :func:`lfd.training.read_checkpoint` (loaded with ``weights_only=True``: no code from it
    runs) and the policy built by :func:`lfd.training.load_checkpoint_module`: its
    hyper-parameters, the model's size and the state_dict's keys and shapes are checked before
    any weight is copied.

    Raises:
        FileNotFoundError: no file at ``path``.
        lfd.training.CheckpointError: not a Lightning checkpoint (empty, truncated, foreign,
            compressed, a pickled payload), its kind is no registered policy, or its
            hyper-parameters or state_dict do not fit its kind (an unknown or another kind's
            hyper-parameter, a refused value, a model over
            :data:`lfd.training.MAX_CHECKPOINT_MODEL_BYTES`, a missing, extra or reshaped
            tensor): one line naming the file, its kind and the key, field or shape.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"policy checkpoint not found: {path}")
    kind = read_checkpoint(path, keys=("state_dict", "hyper_parameters"))["hyper_parameters"].get("kind")
    if not isinstance(kind, str) or kind not in POLICIES:
        raise CheckpointError(
            f"{path}: checkpoint kind {kind!r} is not a policy; expected one of {sorted(POLICIES)}"
        )
    return load_checkpoint_module(POLICIES[kind], path, map_location, others=POLICIES)
