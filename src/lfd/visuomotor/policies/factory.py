"""The policy factory: policy classes by kind, and loading any policy checkpoint.

A checkpoint's kind is the ``kind`` hyper-parameter every :class:`VisuomotorPolicy` saves;
:func:`load_policy` picks the class from it, so a caller never branches on file names.

Example::

    from lfd.visuomotor.policies.factory import load_policy

    policy = load_policy("outputs/train/.../checkpoints/last.ckpt")   # in eval mode
    controller = policy.controller(dt=0.02)                           # stepped by the evaluator
"""

from __future__ import annotations

from pathlib import Path

import torch

from lfd.training import CheckpointError, checkpoint_kind, read_checkpoint
from lfd.visuomotor.policies.act import ACTPolicy
from lfd.visuomotor.policies.base import VisuomotorPolicy
from lfd.visuomotor.policies.cnn_dmp import CNNDMPPolicy
from lfd.visuomotor.policies.diffusion import DiffusionPolicy
from lfd.visuomotor.policies.velocity import VelocityPolicy

__all__ = ["POLICIES", "checkpoint_kind", "load_policy"]

#: Policy kind (``Policy.kind``, stored in the checkpoint's hyper-parameters) -> class.
POLICIES: dict[str, type[VisuomotorPolicy]] = {
    cls.kind: cls for cls in (CNNDMPPolicy, VelocityPolicy, ACTPolicy, DiffusionPolicy)
}


def load_policy(path: str | Path, map_location: str | torch.device = "cpu") -> VisuomotorPolicy:
    """Load a policy checkpoint of any kind, in eval mode. The file is checked by
    :func:`lfd.training.read_checkpoint` and loaded with ``weights_only=True``: no code
    from it runs.

    Raises:
        FileNotFoundError: no file at ``path``.
        lfd.training.CheckpointError: not a Lightning checkpoint (empty, truncated, foreign,
            a pickled payload), or its kind is no known policy (one line naming the file).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"policy checkpoint not found: {path}")
    kind = read_checkpoint(path, keys=("state_dict", "hyper_parameters"))["hyper_parameters"].get("kind")
    if not isinstance(kind, str) or kind not in POLICIES:
        raise CheckpointError(
            f"{path}: checkpoint kind {kind!r} is not a policy; expected one of {sorted(POLICIES)}"
        )
    return POLICIES[kind].load_from_checkpoint(path, map_location=map_location, weights_only=True).eval()
