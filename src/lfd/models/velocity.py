"""Velocity baseline: the current image and joints -> the joint velocity to command now.

Same trunk and head as :class:`~lfd.models.cnn_dmp.CNNDMPPolicy`; the output is the
normalised joint velocity ``(n,)``, trained by mean squared error against the
demonstration's velocity at that step, and executed every control step in closed loop.
"""

from __future__ import annotations

import numpy as np
import torch
from torch.nn import functional as F

from lfd.models.policy import VisuomotorPolicy, joint_figure


class VelocityPolicy(VisuomotorPolicy):
    """Image ``(3, H, W)`` + joints ``(n,)`` at step t -> joint velocity ``(n,)`` rad/s at step t.

    Args:
        **common: :class:`~lfd.models.policy.VisuomotorPolicy` arguments.
    """

    kind = "velocity"
    item_mode = "velocity"

    def __init__(self, **common) -> None:
        super().__init__(**common)
        n = self.hparams.n_joints
        self._build(n, {"joints": (n,), "velocity": (n,)})

    def forward(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Images ``(B, 3, H, W)`` in [0, 1], joints ``(B, n)`` rad -> joint velocities ``(B, n)`` rad/s."""
        return self.denormalise("velocity", self.features(image, joints))

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        pred_n = self.features(batch["image"], batch["joints"])
        loss = F.mse_loss(pred_n, self.normalise("velocity", batch["velocity"]))
        rad_s = (self.denormalise("velocity", pred_n) - batch["velocity"]).norm(dim=-1).mean()
        return {"loss": loss, "velocity_err": rad_s}

    def sample_figure(self, batch: dict[str, torch.Tensor]):
        """Open-loop integral of the predicted velocities along the first episode of the
        batch, against the demonstrated joints (the same frames and joints as inputs)."""
        first = batch["index"] == batch["index"][0]
        qd = self(batch["image"][first], batch["joints"][first]).cpu().numpy()
        demo = batch["joints"][first].cpu().numpy()
        predicted = demo[0] + np.concatenate([np.zeros((1, qd.shape[1])), np.cumsum(qd[:-1], axis=0) * self.control_dt])
        t = batch["t"][first].cpu().numpy()
        return joint_figure(t, predicted, demo, f"velocity policy (integrated), episode {int(batch['index'][0])}")

    @torch.inference_mode()
    def act(self, image, joints) -> np.ndarray:
        """Closed-loop entry point: camera image(s) uint8 ``(H, W, 3)`` / ``(B, H, W, 3)`` and
        current joints ``(n,)`` / ``(B, n)`` rad -> joint velocity command ``(n,)`` / ``(B, n)``
        rad/s (float64) for the next control period."""
        img, q, batched = self._observation(image, joints)
        qd = self(img, q).double().cpu().numpy()
        return qd if batched else qd[0]
