"""A synthetic batch of the chunking policies (ACT, Diffusion Policy): images, joints and a smooth chunk of
future joint positions starting at them; the tiny networks their entry-point tests train (on the
``tiny_data`` fixture's dataset).
Imported by the tests in this folder (not a conftest: several conftest modules share that name)."""

from __future__ import annotations

import torch


def chunk_batch(b: int = 4, k: int = 5, seed: int = 1) -> dict[str, torch.Tensor]:
    """``image (b, 3, 32, 32)``, ``joints (b, 7)`` and ``chunk (b, k, 7)`` (a random walk from the joints)."""
    g = torch.Generator().manual_seed(seed)
    joints = torch.randn(b, 7, generator=g) * 0.3
    chunk = joints[:, None] + torch.cumsum(torch.randn(b, k, 7, generator=g) * 0.1, dim=1)
    return {"image": torch.rand(b, 3, 32, 32, generator=g), "joints": joints, "chunk": chunk}


#: The networks shrunk to seconds of CPU (the trunk; ResNet-18 is covered in the unit tests).
TINY_MODELS = {
    "act": [
        "model.backbone=trunk",
        "model.channels=[4,4,8]",
        "model.chunk_size=6",
        "model.d_model=32",
        "model.n_heads=4",
        "model.dim_feedforward=64",
        "model.n_encoder_layers=1",
        "model.n_vae_layers=1",
    ],
    "diffusion": [
        "model.backbone=trunk",
        "model.channels=[4,4,8]",
        "model.horizon=8",
        "model.n_action_steps=4",
        "model.down_dims=[16,32]",
        "model.n_keypoints=8",
        "model.image_feature_dim=16",
        "model.step_embed_dim=16",
        "model.n_inference_steps=4",
    ],
}
