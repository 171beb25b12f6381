"""CNN -> DMP policy: one camera image and the start joints -> a whole joint trajectory.

Network: conv trunk + spatial soft-argmax keypoints, concatenated with the normalised
start joints and a learned bias input, 3 x 200 ReLU units, then the DMP goal ``(n,)`` and
forcing weights ``(n, K)`` in normalised units (de-normalised with the training split's
statistics). The parameters go through the differentiable :class:`lfd.dmp.DMPLayer`, so
the default loss compares the resulting joint trajectory with the demonstration (plus,
optionally, the end-effector path through the robot's batched forward kinematics). The
goal is predicted from the image: no object pose and no IK solution is used.
"""

from __future__ import annotations

import numpy as np
import torch
from torch.nn import functional as F

from lfd.dmp import DMPLayer
from lfd.models.policy import VisuomotorPolicy, joint_figure

LOSSES = ("trajectory", "params")


class CNNDMPPolicy(VisuomotorPolicy):
    """Image + start joints -> DMP parameters -> joint trajectory ``(T, n)``.

    Args:
        loss: ``"trajectory"``: mean squared joint error (rad^2) of the DMP rollout against
            the demonstrated trajectory; ``"params"``: mean squared error of the normalised
            goal and weights (the original's objective, kept for the ablation).
        ee_weight: weight of the end-effector path term (mean squared tool position error,
            m^2, through batched FK) added to the trajectory loss.
        final_weight: extra weight of the last ``final_fraction`` of the trajectory (where
            the arm closes in on the object) in the trajectory loss.
        final_fraction: fraction of the samples at the end that ``final_weight`` applies to.
        n_basis: DMP basis functions per joint (must match the dataset's).
        alpha_z: DMP damping gain.
        **common: :class:`~lfd.models.policy.VisuomotorPolicy` arguments.
    """

    kind = "cnn_dmp"
    item_mode = "dmp"

    def __init__(
        self,
        *,
        loss: str = "trajectory",
        ee_weight: float = 0.0,
        final_weight: float = 0.0,
        final_fraction: float = 0.25,
        n_basis: int = 20,
        alpha_z: float = 25.0,
        **common,
    ) -> None:
        super().__init__(**common)
        if loss not in LOSSES:
            raise ValueError(f"CNNDMPPolicy.loss: expected one of {LOSSES}, got {loss!r}")
        n = self.hparams.n_joints
        self.dmp = DMPLayer(n_basis=n_basis, n_steps=self.hparams.n_steps, dt=self.control_dt, alpha_z=alpha_z)
        self._build(n + n * n_basis, {"joints": (n,), "goal": (n,), "weights": (n, n_basis)})
        t = torch.linspace(0.0, 1.0, self.hparams.n_steps)
        self.register_buffer("time_weights", 1.0 + final_weight * (t >= 1.0 - final_fraction).float(), persistent=False)

    def predict_params(self, image: torch.Tensor, joints: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Normalised DMP goal ``(B, n)`` and weights ``(B, n, K)``."""
        out = self.features(image, joints)
        n = self.hparams.n_joints
        return out[:, :n], out[:, n:].reshape(-1, n, self.hparams.n_basis)

    def rollout(self, joints: torch.Tensor, goal_n: torch.Tensor, weights_n: torch.Tensor) -> torch.Tensor:
        """Joint trajectory ``(B, T, n)`` rad from the start joints and normalised parameters."""
        goal = self.denormalise("goal", goal_n)
        weights = self.denormalise("weights", weights_n)
        return self.dmp(joints, goal, weights)

    def forward(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Images ``(B, 3, H, W)`` in [0, 1], start joints ``(B, n)`` rad -> trajectory ``(B, T, n)`` rad."""
        return self.rollout(joints, *self.predict_params(image, joints))

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        joints = batch["joints"]
        goal_n, weights_n = self.predict_params(batch["image"], joints)
        goal_err = F.mse_loss(goal_n, self.normalise("goal", batch["goal"]))
        weights_err = F.mse_loss(weights_n, self.normalise("weights", batch["weights"]))
        trajectory = self.rollout(joints, goal_n, weights_n)
        sq = ((trajectory - batch["trajectory"]) ** 2).mean(dim=(0, 2))
        out = {
            "param_mse": goal_err + weights_err,
            "traj_mse": sq.mean(),
            "final_joint_err": (trajectory[:, -1] - batch["trajectory"][:, -1]).norm(dim=-1).mean(),
        }
        need_ee = self.hparams.ee_weight > 0 or not self.training
        if need_ee:
            ee = self.robot.fk(trajectory.reshape(-1, trajectory.shape[-1]))[:, :3, 3].reshape(*trajectory.shape[:2], 3)
            out["ee_mse"] = ((ee - batch["ee_path"]) ** 2).sum(-1).mean()
            out["final_ee_err_m"] = (ee[:, -1] - batch["ee_path"][:, -1]).norm(dim=-1).mean()
        if self.hparams.loss == "params":
            out["loss"] = out["param_mse"]
        else:
            out["loss"] = (sq * self.time_weights).mean() / self.time_weights.mean()
            if self.hparams.ee_weight > 0:
                out["loss"] = out["loss"] + self.hparams.ee_weight * out["ee_mse"]
        return out

    def sample_figure(self, batch: dict[str, torch.Tensor]):
        predicted = self(batch["image"][:1], batch["joints"][:1])[0].cpu().numpy()
        t = batch["t"][0].cpu().numpy()
        return joint_figure(t, predicted, batch["trajectory"][0].cpu().numpy(), f"CNN->DMP, episode {int(batch['index'][0])}")

    @torch.inference_mode()
    def plan(self, image, joints) -> np.ndarray:
        """Closed-loop entry point: camera image(s) uint8 ``(H, W, 3)`` / ``(B, H, W, 3)`` and
        current joints ``(n,)`` / ``(B, n)`` rad -> planned joint trajectory ``(T, n)`` /
        ``(B, T, n)`` rad (float64), sampled every :attr:`control_dt` seconds, starting at ``joints``."""
        img, q, batched = self._observation(image, joints)
        traj = self(img, q).double().cpu().numpy()
        return traj if batched else traj[0]
