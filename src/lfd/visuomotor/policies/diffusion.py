"""Diffusion Policy, CNN-based (Chi et al. 2023, "Diffusion Policy: Visuomotor Policy Learning
via Action Diffusion"), written here (lfd cannot depend on LeRobot; ``diffusers`` is not a
dependency: :mod:`~lfd.visuomotor.policies.noise_schedule`).

* Observation encoder: image backbone (ResNet-18 from scratch with group norm, as the paper,
  or the project's trunk) -> 1x1 conv to ``n_keypoints`` maps -> spatial soft-argmax (the
  paper replaces the global average pooling by it) -> linear -> ReLU, concatenated with the
  normalised joints: the global condition.
* Noise predictor: :class:`~lfd.visuomotor.policies.diffusion_unet.ConditionalUnet1D` over the
  normalised action sequence of ``horizon`` steps (prediction horizon ``T_p``), FiLM-conditioned
  on the global condition and the diffusion step.
* Training: DDPM, ``n_train_steps`` steps, squared-cosine schedule, mean squared error of the
  predicted noise (or of the predicted clean sequence, ``prediction="sample"``). Inference:
  DDIM with ``n_inference_steps`` steps from Gaussian noise
  (``seed``-able through torch's global generator).
* Receding horizon: the observation horizon is ``T_o = 1`` (the dataset items carry one
  frame; the paper uses 2), the predicted sequence is ``q[t+1..t+T_p]`` and the controller
  executes its first ``n_action_steps`` (``T_a``) samples before it queries again.

Not done (said): the paper's exponential moving average of the weights (a callback for the
later training session).
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from lfd.visuomotor.policies.backbones import ImageBackbone
from lfd.visuomotor.policies.base import check_sizes
from lfd.visuomotor.policies.chunking import ChunkPolicy
from lfd.visuomotor.policies.diffusion_unet import ConditionalUnet1D
from lfd.visuomotor.policies.noise_schedule import NoiseSchedule
from lfd.visuomotor.policies.vision import SpatialSoftmax


class DiffusionPolicy(ChunkPolicy):
    """Image + joints at step t -> ``horizon`` joint positions ``q[t+1..t+T_p]`` (rad) by DDIM.

    Args:
        horizon: ``T_p``, predicted steps (the paper: 16); a multiple of ``2 ** (len(down_dims) - 1)``.
        n_action_steps: ``T_a``, steps executed per query (the paper: 8).
        backbone: ``"resnet18"`` or ``"trunk"``.
        n_keypoints: spatial soft-argmax keypoints of the image features (LeRobot: 32).
        image_feature_dim: size of the image features after the keypoints' linear layer.
        down_dims, step_embed_dim, kernel_size, n_groups: the U-Net's
            (:class:`~lfd.visuomotor.policies.diffusion_unet.ConditionalUnet1D`).
        n_train_steps, schedule, clip_sample: the noise schedule's
            (:class:`~lfd.visuomotor.policies.noise_schedule.NoiseSchedule`; the paper: 100,
            squared cosine, clipping at 1 of min-max-normalised actions; here the actions are
            z-scored, so the default clips at 5 standard deviations).
        prediction: ``"epsilon"`` (the paper's: the U-Net predicts the noise) or ``"sample"`` (it
            predicts the clean action sequence; an option of the paper's code).
        n_inference_steps: DDIM steps at inference (the paper's real-robot runs: 10 to 16; here 8
            and the smaller U-Net keep a query near 50 ms on 2 CPU cores, docs/policies.md).
        **common: :class:`~lfd.visuomotor.policies.chunking.ChunkPolicy` arguments.
    """

    kind = "diffusion"
    label = "Diffusion Policy"
    colour = "tab:red"

    def __init__(
        self,
        *,
        horizon: int = 16,
        n_action_steps: int = 8,
        backbone: str = "resnet18",
        n_keypoints: int = 32,
        image_feature_dim: int = 64,
        down_dims: tuple[int, ...] | list[int] = (32, 64, 128),
        step_embed_dim: int = 64,
        kernel_size: int = 5,
        n_groups: int = 8,
        n_train_steps: int = 100,
        schedule: str = "squaredcos_cap_v2",
        clip_sample: float | None = 5.0,
        n_inference_steps: int = 8,
        prediction: str = "epsilon",
        **common,
    ) -> None:
        check_sizes(
            "DiffusionPolicy",
            horizon=horizon,
            n_keypoints=n_keypoints,
            image_feature_dim=image_feature_dim,
            down_dims=down_dims,
            step_embed_dim=step_embed_dim,
            kernel_size=kernel_size,
            n_groups=n_groups,
            n_train_steps=n_train_steps,
        )
        saved = common.pop("chunk_size", horizon)  # a checkpoint's hyper-parameters repeat it
        if saved != horizon:
            raise ValueError(f"DiffusionPolicy.chunk_size: must equal horizon={horizon}, got {saved}")
        super().__init__(chunk_size=horizon, **common)
        if not (isinstance(n_action_steps, int) and 1 <= n_action_steps <= horizon):
            raise ValueError(
                f"DiffusionPolicy.n_action_steps: expected an int in 1..horizon={horizon}, got {n_action_steps!r}"
            )
        if horizon % (2 ** (len(down_dims) - 1)):
            raise ValueError(
                f"DiffusionPolicy.horizon: expected a multiple of 2 ** (len(down_dims) - 1) = "
                f"{2 ** (len(down_dims) - 1)}, got {horizon}"
            )
        n = self.hparams.n_joints
        norm = "group" if backbone == "resnet18" else "batch"
        self.backbone = ImageBackbone(backbone, self.input_channels, self.hparams.channels, norm=norm)
        self.keypoints = nn.Sequential(
            nn.Conv2d(self.backbone.out_channels, n_keypoints, 1), SpatialSoftmax(self.hparams.temperature)
        )
        self.image_features = nn.Sequential(nn.Linear(2 * n_keypoints, image_feature_dim), nn.ReLU())
        self.unet = ConditionalUnet1D(
            n, image_feature_dim + n, down_dims, step_embed_dim, kernel_size, n_groups
        )
        self.noise = NoiseSchedule(n_train_steps, schedule, clip_sample, prediction)
        NoiseSchedule.timesteps(self.noise, n_inference_steps)  # checks n_inference_steps
        self.replan_every = n_action_steps

    def condition(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Global condition ``(B, image_feature_dim + n)``: image features and normalised joints."""
        feats = self.image_features(self.keypoints(self.backbone(self.scene_image(image))))
        return torch.cat([feats, self.normalise("joints", joints)], dim=-1)

    def predict_chunk(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        cond = self.condition(image, joints)
        hp = self.hparams
        x = torch.randn(joints.shape[0], hp.horizon, hp.n_joints, device=joints.device)
        x = self.noise.sample(lambda xt, t: self.unet(xt, t, cond), x, hp.n_inference_steps)
        return self.denormalise("joints", x)

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        target_n = self.normalise("joints", self.chunk_targets(batch))
        cond = self.condition(batch["image"], self.input_joints(batch))
        noise = torch.randn_like(target_n)
        t = torch.randint(0, self.hparams.n_train_steps, (target_n.shape[0],), device=target_n.device)
        pred = self.unet(self.noise.add_noise(target_n, noise, t), t, cond)
        return {"loss": F.mse_loss(pred, self.noise.target(target_n, noise))}
