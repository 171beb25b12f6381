"""A synthetic batch of the chunking policies (ACT, Diffusion Policy): images, joints and a smooth chunk of
future joint positions starting at them. Imported by the tests in this folder (not a conftest: several
conftest modules share that name)."""

from __future__ import annotations

import torch


def chunk_batch(b: int = 4, k: int = 5, seed: int = 1) -> dict[str, torch.Tensor]:
    """``image (b, 3, 32, 32)``, ``joints (b, 7)`` and ``chunk (b, k, 7)`` (a random walk from the joints)."""
    g = torch.Generator().manual_seed(seed)
    joints = torch.randn(b, 7, generator=g) * 0.3
    chunk = joints[:, None] + torch.cumsum(torch.randn(b, k, 7, generator=g) * 0.1, dim=1)
    return {"image": torch.rand(b, 3, 32, 32, generator=g), "joints": joints, "chunk": chunk}
