"""Velocity baseline: the current image, joints and clock -> the joint velocity to command now.

Same trunk and head as :class:`~lfd.visuomotor.policies.cnn_dmp.CNNDMPPolicy`; the output is the
normalised joint velocity ``(n,)``, trained by mean squared error against the
demonstration's velocity *command* at that step (the items' ``command``,
``(q[t+1] - q[t]) / dt``: :func:`lfd.visuomotor.data.datasets.command_velocities`), and executed every
control step in closed loop by velocity control for one period, so that commanding the
labels reproduces the demonstration (``tests/visuomotor/eval/test_eval_velocity_labels.py``).

The label is not the recorded ``velocities``: those are the joints' instantaneous
velocities at the sample instants, a fraction of their motion per period under the
demonstrations' position control (the joints move in a burst at the start of each period;
docs/decisions.md). The output statistics (``velocity_mean`` /
``velocity_std``) are those of the commands over the train split, computed at fit time.

By default the head also sees the phase ``min(t / duration, 1)`` (``t``: seconds since the
episode started, the robot's own clock). Without it the baseline cannot leave the start
pose: every demonstration starts at rest, so at the start image and joints the learned
velocity is ~0 and the closed loop stays at that fixed point (docs/decisions.md).

Trained on the demonstrated states only, the closed loop falls behind the demonstration
and never sees how to catch up (covariate shift). With ``state_noise`` the training joints
are perturbed by Gaussian noise and the label becomes the expert's corrective command at
that state, ``qd_demo(t) + correction_gain * (q_demo(t) - q_noisy)`` (noise injection with
the time-indexed demonstration as the expert, as in DART, Laskey et al. 2017).
"""

from __future__ import annotations

import numpy as np
import torch
from torch.nn import functional as F

from lfd.visuomotor.data.stats import STD_FLOOR
from lfd.visuomotor.policies.control import VelocityController
from lfd.visuomotor.policies.keypoint import KeypointPolicy
from lfd.visuomotor.policies.plots import joint_figure

#: Item key of the training label (rad/s, the velocity to command for the next period).
LABEL = "command"


class VelocityPolicy(KeypointPolicy):
    """Image ``(3, H, W)`` + joints ``(n,)`` (+ time) at step t -> joint velocity ``(n,)`` rad/s at step t.

    Args:
        phase_input: give the head the phase ``min(t / duration, 1)`` as one more input.
        state_noise: std (rad) of the Gaussian noise added to the training joints (0: none).
        correction_gain: gain (1/s) of the corrective term of the perturbed labels.
        **common: :class:`~lfd.visuomotor.policies.keypoint.KeypointPolicy` arguments (the
            keypoint head's and the harness's).
    """

    kind = "velocity"
    label = "velocity CNN"
    colour = "tab:orange"
    item_mode = "velocity"

    def __init__(
        self, *, phase_input: bool = True, state_noise: float = 0.1, correction_gain: float = 2.0, **common
    ) -> None:
        super().__init__(**common)
        for name, value in (("state_noise", state_noise), ("correction_gain", correction_gain)):
            if not value >= 0:
                raise ValueError(f"VelocityPolicy.{name}: expected a number >= 0, got {value}")
        n = self.hparams.n_joints
        self._build(n, {"joints": (n,), "velocity": (n,)}, extra_inputs=int(phase_input))

    def phase(self, time: torch.Tensor | None, batch: int) -> torch.Tensor | None:
        """Head input ``(B, 1)`` from ``time`` (``(B,)`` or scalar, s since the start), or None
        when the policy was built without ``phase_input``."""
        if not self.hparams.phase_input:
            return None
        if time is None:
            raise ValueError("VelocityPolicy(phase_input=True) needs `time` (s since the episode started)")
        t = torch.as_tensor(time, dtype=torch.float32, device=self.device).reshape(-1, 1)
        if t.shape[0] not in (1, batch):
            raise ValueError(f"VelocityPolicy: {t.shape[0]} times for a batch of {batch}")
        return (t / self.hparams.duration).clamp(max=1.0).expand(batch, 1)

    def forward(
        self, image: torch.Tensor, joints: torch.Tensor, time: torch.Tensor | None = None
    ) -> torch.Tensor:
        """Images ``(B, 3, H, W)`` in [0, 1], joints ``(B, n)`` rad, time ``(B,)`` s since the
        episode started (needed with ``phase_input``) -> joint velocities ``(B, n)`` rad/s."""
        return self.denormalise("velocity", self.features(image, joints, self.phase(time, image.shape[0])))

    def setup(self, stage: str) -> None:
        """Lightning hook: the dataset's statistics, then those of the label (the train
        split's velocity commands) for the output normalisation."""
        super().setup(stage)
        if stage != "fit":
            return
        train = self.trainer.datamodule.datasets.get("train")  # PolicyData, checked by super().setup
        tensors = train.tensors if train is not None else {}
        if LABEL not in tensors:
            raise ValueError(
                f"VelocityPolicy: the train items have no '{LABEL}' (velocity command) key; got {sorted(tensors)}"
            )
        command = tensors[LABEL].double()
        self.velocity_mean.copy_(command.mean(0).float())
        self.velocity_std.copy_(command.std(0).clamp(min=STD_FLOOR).float())

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        if LABEL not in batch:
            raise ValueError(
                f"VelocityPolicy: batches need the '{LABEL}' key (rad/s, (B, n)), got {sorted(batch)}"
            )
        noise = self.perturbation(batch["joints"])
        target = batch[LABEL] - self.hparams.correction_gain * noise  # the expert's correction
        pred_n, aux = self.head_outputs(
            batch["image"],
            batch["joints"] + noise,
            self.phase(batch["t"], batch["image"].shape[0]),
            top=batch.get("top"),
        )
        loss = F.mse_loss(pred_n, self.normalise("velocity", target))
        rad_s = (self.denormalise("velocity", pred_n) - target).norm(dim=-1).mean()
        return self.add_aux_losses({"loss": loss, "velocity_err": rad_s}, aux, batch)

    def sample_figure(self, batch: dict[str, torch.Tensor]):
        """Open-loop integral of the predicted velocities along the first episode of the
        batch, against the demonstrated joints (the same frames and joints as inputs)."""
        first = batch["index"] == batch["index"][0]
        qd = self(batch["image"][first], batch["joints"][first], batch["t"][first]).cpu().numpy()
        demo = batch["joints"][first].cpu().numpy()
        predicted = demo[0] + np.concatenate(
            [np.zeros((1, qd.shape[1])), np.cumsum(qd[:-1], axis=0) * self.control_dt]
        )
        t = batch["t"][first].cpu().numpy()
        return joint_figure(
            t, predicted, demo, f"velocity policy (integrated), episode {int(batch['index'][0])}"
        )

    def controller(self, dt: float) -> VelocityController:
        """A :class:`~lfd.visuomotor.policies.control.VelocityController`: :meth:`act` every
        control period ``dt`` (s), executed by velocity control."""
        return VelocityController(self, dt)

    @torch.inference_mode()
    def act(self, image, joints, time=None) -> np.ndarray:
        """The per-step call of :meth:`controller`: camera image(s) uint8 ``(H, W, 3)`` / ``(B, H, W, 3)``,
        current joints ``(n,)`` / ``(B, n)`` rad and the time since the episode started (s,
        scalar or ``(B,)``; needed with ``phase_input``) -> joint velocity command ``(n,)`` /
        ``(B, n)`` rad/s (float64) for the next control period."""
        img, q, batched = self._observation(image, joints)
        if time is not None and not (np.all(np.isfinite(time)) and np.all(np.asarray(time) >= 0)):
            raise ValueError(f"VelocityPolicy.act: time must be finite and >= 0 s, got {time}")
        qd = self(img, q, time).double().cpu().numpy()
        return qd if batched else qd[0]
