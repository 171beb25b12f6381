"""LightningModules: the visuomotor policies (CNN -> DMP, velocity baseline) and their parts,
and the Sawyer forward + inverse models (:class:`SawyerModels`, :mod:`lfd.models.sawyer`).
Shared training helpers (activations, optimiser, hyper-parameters) are in
:mod:`lfd.models.training`.

Example (closed loop from a checkpoint)::

    from lfd.models import load_policy

    policy = load_policy("outputs/train/.../checkpoints/last.ckpt")   # kind read from the checkpoint
    if policy.kind == "cnn_dmp":
        trajectory = policy.plan(image, joints)    # uint8 (H, W, 3), (7,) rad -> (T, 7) rad
    else:
        qd = policy.act(image, joints, t)          # t: s since the start -> (7,) rad/s, every control step
"""

from __future__ import annotations

from pathlib import Path

import torch

from lfd.models.cnn_dmp import CNNDMPPolicy
from lfd.models.policy import VisuomotorPolicy
from lfd.models.sawyer import SawyerModels, load_sawyer_models
from lfd.models.velocity import VelocityPolicy
from lfd.models.vision import KeypointEncoder, SpatialSoftmax, image_to_tensor

__all__ = [
    "POLICIES",
    "CNNDMPPolicy",
    "KeypointEncoder",
    "SawyerModels",
    "SpatialSoftmax",
    "VelocityPolicy",
    "VisuomotorPolicy",
    "checkpoint_kind",
    "image_to_tensor",
    "load_policy",
    "load_sawyer_models",
]

#: Policy kind (``Policy.kind``, stored in the checkpoint's hyper-parameters) -> class.
POLICIES: dict[str, type[VisuomotorPolicy]] = {cls.kind: cls for cls in (CNNDMPPolicy, VelocityPolicy)}


def checkpoint_kind(path: str | Path) -> str | None:
    """The policy kind stored in a Lightning checkpoint's hyper-parameters (None if it has none)."""
    ckpt = torch.load(path, map_location="cpu", weights_only=False, mmap=True)
    return ckpt.get("hyper_parameters", {}).get("kind")


def load_policy(path: str | Path, map_location: str | torch.device = "cpu") -> VisuomotorPolicy:
    """Load a policy checkpoint of any kind, in eval mode.

    Raises:
        FileNotFoundError: no file at ``path``.
        ValueError: the checkpoint holds no known policy kind.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"policy checkpoint not found: {path}")
    kind = checkpoint_kind(path)
    if kind not in POLICIES:
        raise ValueError(f"{path}: checkpoint kind {kind!r} is not a policy; expected one of {sorted(POLICIES)}")
    return POLICIES[kind].load_from_checkpoint(path, map_location=map_location, weights_only=False).eval()
