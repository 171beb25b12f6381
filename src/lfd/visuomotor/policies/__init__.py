"""Visuomotor policies (LightningModules): CNN -> DMP, the velocity CNN, ACT and Diffusion Policy
(action chunking, :mod:`~lfd.visuomotor.policies.chunking`), their vision parts,
and the factory that loads any of them from a checkpoint.

Every policy has one inference interface: :meth:`VisuomotorPolicy.controller` returns a
controller that the closed-loop evaluator starts once per episode and steps every control
period (:mod:`lfd.visuomotor.eval.rollout`).

Example (closed loop from a checkpoint)::

    from lfd.visuomotor.policies import load_policy

    policy = load_policy("outputs/train/.../checkpoints/last.ckpt")   # kind read from the checkpoint
"""

from __future__ import annotations

# isort: off
# The built-in policies register themselves in this order, the order of every evaluation table.
from lfd.visuomotor.policies.cnn_dmp import CNNDMPPolicy
from lfd.visuomotor.policies.velocity import VelocityPolicy
from lfd.visuomotor.policies.act import ACTPolicy
from lfd.visuomotor.policies.diffusion import DiffusionPolicy

# isort: on
from lfd.visuomotor.policies.base import VisuomotorPolicy
from lfd.visuomotor.policies.chunking import ChunkPolicy
from lfd.visuomotor.policies.factory import POLICIES, checkpoint_kind, get_policy_class, load_policy
from lfd.visuomotor.policies.keypoint import KeypointPolicy
from lfd.visuomotor.policies.vision import KeypointEncoder, SpatialSoftmax, image_to_tensor

__all__ = [
    "POLICIES",
    "ACTPolicy",
    "CNNDMPPolicy",
    "ChunkPolicy",
    "DiffusionPolicy",
    "KeypointEncoder",
    "KeypointPolicy",
    "SpatialSoftmax",
    "VelocityPolicy",
    "VisuomotorPolicy",
    "checkpoint_kind",
    "get_policy_class",
    "image_to_tensor",
    "load_policy",
]
