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
from lfd.visuomotor.policies.control import PlanController
from lfd.visuomotor.policies.keypoint import KeypointPolicy
from lfd.visuomotor.policies.plots import joint_figure

LOSSES = ("trajectory", "params")


class CNNDMPPolicy(KeypointPolicy):
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
        rest_steps: the trajectory loss also covers this many samples after the
            demonstration's end, where the target is its last sample (the demonstrations end
            at rest). Without them the goal is a free parameter: the weights alone can bring
            the rollout to the demonstrated end point at ``t = tau`` with a goal elsewhere,
            and the DMP then runs off towards that goal once its forcing term dies out.
            The samples use the same DMP run on past ``tau`` (:meth:`layer`), as the closed
            loop does. 0 compares only the demonstrated ``T`` samples.
        n_basis: DMP basis functions per joint (must match the dataset's).
        alpha_z: DMP damping gain.
        **common: :class:`~lfd.visuomotor.policies.keypoint.KeypointPolicy` arguments (the
            keypoint head's and the harness's).
    """

    kind = "cnn_dmp"
    label = "CNN -> DMP"
    colour = "tab:blue"
    item_mode = "dmp"
    DATA_ARGUMENTS = (*KeypointPolicy.DATA_ARGUMENTS, "n_basis")

    def __init__(
        self,
        *,
        loss: str = "trajectory",
        ee_weight: float = 0.0,
        final_weight: float = 0.0,
        final_fraction: float = 0.25,
        rest_steps: int = 50,
        n_basis: int = 20,
        alpha_z: float = 25.0,
        **common,
    ) -> None:
        super().__init__(**common)
        if loss not in LOSSES:
            raise ValueError(f"CNNDMPPolicy.loss: expected one of {LOSSES}, got {loss!r}")
        if rest_steps < 0:
            raise ValueError(f"CNNDMPPolicy.rest_steps: expected an integer >= 0, got {rest_steps}")
        n = self.hparams.n_joints
        self.dmp = DMPLayer(
            n_basis=n_basis, n_steps=self.hparams.n_steps, dt=self.control_dt, alpha_z=alpha_z
        )
        self._horizon_layers: dict[int, DMPLayer] = {}  # longer closed-loop plans, same tau (not state)
        self._build(n + n * n_basis, {"joints": (n,), "goal": (n,), "weights": (n, n_basis)})

    def predict_params(self, image: torch.Tensor, joints: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Normalised DMP goal ``(B, n)`` and weights ``(B, n, K)``."""
        return self._split_params(self.features(image, joints))

    def _split_params(self, out: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Head output ``(B, n + n K)`` -> normalised goal ``(B, n)`` and weights ``(B, n, K)``."""
        n = self.hparams.n_joints
        return out[:, :n], out[:, n:].reshape(-1, n, self.hparams.n_basis)

    def layer(self, n_steps: int | None = None) -> DMPLayer:
        """The DMP layer giving ``n_steps`` samples (default: the demonstrations' ``T``) of the
        same DMP (same duration ``tau``): past ``tau`` the forcing term has died out and the
        spring-damper keeps converging to the goal, smoothly and at rest in the limit."""
        if n_steps is None or n_steps == self.hparams.n_steps:
            return self.dmp
        if n_steps < 2:
            raise ValueError(f"CNNDMPPolicy: n_steps must be >= 2, got {n_steps}")
        layer = self._horizon_layers.get(n_steps)
        if layer is None:
            d = self.dmp
            layer = DMPLayer(
                n_basis=d.n_basis, n_steps=n_steps, dt=self.control_dt, alpha_z=d.gains.alpha_z, tau=d.tau
            )
            self._horizon_layers[n_steps] = layer
        return layer.to(self.device)

    def rollout(
        self, joints: torch.Tensor, goal_n: torch.Tensor, weights_n: torch.Tensor, n_steps: int | None = None
    ) -> torch.Tensor:
        """Joint trajectory ``(B, T, n)`` rad from the start joints and normalised parameters
        (``T = n_steps``, default the demonstrations' length, see :meth:`layer`)."""
        goal = self.denormalise("goal", goal_n)
        weights = self.denormalise("weights", weights_n)
        return self.layer(n_steps)(joints, goal, weights)

    def forward(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Images ``(B, 3, H, W)`` in [0, 1], start joints ``(B, n)`` rad -> trajectory ``(B, T, n)`` rad."""
        return self.rollout(joints, *self.predict_params(image, joints))

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        joints = batch["joints"]
        params, aux = self.head_outputs(batch["image"], joints, top=batch.get("top"))
        goal_n, weights_n = self._split_params(params)
        goal_err = F.mse_loss(goal_n, self.normalise("goal", batch["goal"]))
        weights_err = F.mse_loss(weights_n, self.normalise("weights", batch["weights"]))
        rest = self.hparams.rest_steps
        trajectory = self.rollout(joints, goal_n, weights_n, n_steps=self.hparams.n_steps + rest)
        target, ee_target = _hold_last(batch["trajectory"], rest), _hold_last(batch["ee_path"], rest)
        sq = ((trajectory - target) ** 2).mean(dim=(0, 2))
        out = {
            "param_mse": goal_err + weights_err,
            "traj_mse": sq.mean(),
            "final_joint_err": (trajectory[:, -1] - target[:, -1]).norm(dim=-1).mean(),
        }
        need_ee = self.hparams.ee_weight > 0 or not self.training
        if need_ee:
            ee = self.robot.fk(trajectory.reshape(-1, trajectory.shape[-1]))[:, :3, 3].reshape(
                *trajectory.shape[:2], 3
            )
            out["ee_mse"] = ((ee - ee_target) ** 2).sum(-1).mean()
            out["final_ee_err_m"] = (ee[:, -1] - ee_target[:, -1]).norm(dim=-1).mean()
        if self.hparams.loss == "params":
            out["loss"] = out["param_mse"]
        else:
            weights = self.time_weights().to(sq)
            out["loss"] = (sq * weights).mean() / weights.mean()
            if self.hparams.ee_weight > 0:
                out["loss"] = out["loss"] + self.hparams.ee_weight * out["ee_mse"]
        return self.add_aux_losses(out, aux, batch)

    def time_weights(self) -> torch.Tensor:
        """``(T + rest_steps,)`` weights of the trajectory loss over time: ``1 + final_weight``
        on the last ``final_fraction`` of the demonstration and on the rest samples, else 1."""
        hp = self.hparams
        t = torch.cat(
            [torch.linspace(0.0, 1.0, hp.n_steps), torch.ones(hp.rest_steps)]
        )  # rest = end of the motion
        return 1.0 + hp.final_weight * (t >= 1.0 - hp.final_fraction).float()

    def sample_figure(self, batch: dict[str, torch.Tensor]):
        predicted = self(batch["image"][:1], batch["joints"][:1])[0].cpu().numpy()
        t = batch["t"][0].cpu().numpy()
        return joint_figure(
            t, predicted, batch["trajectory"][0].cpu().numpy(), f"CNN->DMP, episode {int(batch['index'][0])}"
        )

    def controller(self, dt: float) -> PlanController:
        """A :class:`~lfd.visuomotor.policies.control.PlanController`: one :meth:`plan` on the
        episode's first observation, then the plan tracked every ``dt`` (s)."""
        return PlanController(self, dt)

    @torch.inference_mode()
    def plan(self, image, joints, n_steps: int | None = None) -> np.ndarray:
        """The planning call of :meth:`controller`: camera image(s) uint8 ``(H, W, 3)`` / ``(B, H, W, 3)`` and
        current joints ``(n,)`` / ``(B, n)`` rad -> planned joint trajectory ``(T, n)`` /
        ``(B, T, n)`` rad (float64), sampled every :attr:`control_dt` seconds, starting at
        ``joints``; ``T = n_steps`` (default: the demonstrations' length; longer plans run the
        same DMP on past its duration, see :meth:`layer`)."""
        img, q, batched = self._observation(image, joints)
        traj = self.rollout(q, *self.predict_params(img, q), n_steps=n_steps).double().cpu().numpy()
        return traj if batched else traj[0]


def _hold_last(path: torch.Tensor, extra: int) -> torch.Tensor:
    """``(B, T, d)`` -> ``(B, T + extra, d)``: the path followed by ``extra`` copies of its last sample."""
    if extra == 0:
        return path
    return torch.cat([path, path[:, -1:].expand(-1, extra, -1)], dim=1)
