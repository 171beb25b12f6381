"""Base LightningModule of the visuomotor policies: normalisation, optimisation, logging.

A policy sees only what a robot's own sensors give it: the fixed camera's RGB image and
the arm's joint angles. Subclasses define the network, the loss, the dataset item mode
they train on and their one inference interface, :meth:`VisuomotorPolicy.controller`
(a :class:`~lfd.visuomotor.protocols.Controller` the closed-loop evaluator steps).

Normalisation statistics (train split of the dataset, see :mod:`lfd.visuomotor.data.stats`) are
copied from the datamodule (:class:`~lfd.visuomotor.protocols.PolicyData`) at ``setup("fit")``
into persistent buffers, so a checkpoint
carries them and ``Policy.load_from_checkpoint(path)`` runs on its own.
"""

from __future__ import annotations

from typing import Any

import lightning as L
import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from lfd.sim.depth import DEPTH_ENCODINGS
from lfd.training import SCHEDULERS, make_optimizer
from lfd.visuomotor.policies.plots import log_sample_figure
from lfd.visuomotor.policies.vision import (
    COLOUR_ORDERS,
    KeypointEncoder,
    all_colour_orders,
    brightness_range,
    image_to_tensor,
    mlp,
    permute_colour_channels,
    scale_foreground_brightness,
)
from lfd.visuomotor.protocols import Controller, GeneratedPolicyData, PolicyData

#: Warm-up fraction of the policies' one-cycle schedule (torch's ``OneCycleLR`` default).
ONECYCLE_PCT_START = 0.3
#: Hyper-parameters that must equal the dataset's (``GeneratorConfig``) ones.
DATA_KEYS = ("image_size", "depth", "duration", "n_steps", "robot")
#: Auxiliary head outputs with ``aux_weight > 0``: the top-approach logit, the normalised target point (3).
AUX_DIM = 4
#: Checkpoint key of the training dataset's fingerprint.
FINGERPRINT_KEY = "lfd_dataset_fingerprint"


class VisuomotorPolicy(L.LightningModule):
    """Image + joints -> action. Common constructor arguments (the subclasses add theirs):

    Args:
        name: label of the model config (``"cnn_dmp"``, ``"velocity"``...), kept as
            :attr:`config_name`; not a hyper-parameter (Lightning merges the model's and the
            datamodule's hyper-parameters, and the dataset has a ``name`` too).
        channels: conv channels of the trunk, one entry per layer.
        temperature: initial spatial soft-argmax temperature.
        hidden: widths of the fully connected ReLU layers after the keypoints.
        bias_dim: size of the learned bias input concatenated to the keypoints and joints
            (0 disables it).
        lr, weight_decay: AdamW settings.
        scheduler: ``"cosine"`` (per step, to 0), ``"onecycle"`` (per step, peak ``lr``)
            or ``"none"``.
        image_size: side (px) of the square camera images of the training data.
        depth: the input is RGB-D (4 channels, :func:`lfd.sim.depth.rgbd_image`) instead of
            RGB; the training data must have been made with ``depth: true``.
        depth_encoding: the depth channel's encoding (:data:`lfd.sim.depth.DEPTH_ENCODINGS`):
            ``"range"`` or ``"relief"``; evaluation renders it the same way.
        duration, n_steps: demonstration duration (s) and number of samples; the control
            period is ``duration / (n_steps - 1)``.
        robot: robot model name (:func:`lfd.robots.load_robot`).
        n_joints: arm degrees of freedom.
        colour_augment: shuffle the RGB channels of each training image
            (:func:`~lfd.visuomotor.policies.vision.permute_colour_channels`).
        brightness_augment: ``[low, high]``: the object's colour in each training image
            times a random factor in that range (log-uniform;
            :func:`~lfd.visuomotor.policies.vision.scale_foreground_brightness`), or None. Needs
            ``depth`` (the depth channel tells the object from the table).
        global_pool: the encoder also gives each channel's spatial maximum
            (:class:`~lfd.visuomotor.policies.vision.KeypointEncoder`).
        aux_weight: weight of the auxiliary losses on training-only labels (0: none). The
            head gets :data:`AUX_DIM` more outputs, trained to give the demonstration's
            approach mode (logit of "top", binary cross-entropy) and its grasp target point
            (normalised, mean squared error). They are never used at run time: they make the
            shared features encode *what* the object is and *where* its target lies.
        mode_heads: one output head per approach mode (side, top) instead of one for both
            (needs ``aux_weight > 0``: the auxiliary mode logit picks the head at run time;
            in training the demonstration's own mode does).
        plot_every_n_val: a validation sample plot goes to TensorBoard at every this many
            validation runs (0: never).
        kind: when given (from a checkpoint), must equal the class's :attr:`kind` (checked
            before ``unknown``, so loading another kind's checkpoint names the kinds).
        unknown: any other keyword raises ``TypeError``.

    Subclasses set :attr:`kind` and :attr:`item_mode`, call :meth:`_build` at the end of
    ``__init__`` and define ``losses(batch) -> {"loss": ..., ...}`` (scalar tensors),
    ``sample_figure(batch) -> matplotlib figure`` and :meth:`controller`.
    """

    #: Fixed identifier of the policy family, stored in the checkpoint's hyper-parameters.
    kind: str = ""
    #: Dataset item layout this policy trains on (``ReachDataModule(mode=...)``).
    item_mode: str = ""

    def __init__(
        self,
        *,
        name: str | None = None,
        channels: tuple[int, ...] | list[int] = (32, 32, 32, 32),
        temperature: float = 1.0,
        hidden: tuple[int, ...] | list[int] = (200, 200, 200),
        bias_dim: int = 10,
        lr: float = 1e-3,
        weight_decay: float = 1e-4,
        scheduler: str = "cosine",
        image_size: int = 128,
        depth: bool = False,
        depth_encoding: str = "range",
        duration: float = 4.0,
        n_steps: int = 100,
        robot: str = "pr2_right_arm",
        n_joints: int = 7,
        plot_every_n_val: int = 5,
        colour_augment: bool = False,
        brightness_augment: tuple[float, float] | list[float] | None = None,
        global_pool: bool = False,
        aux_weight: float = 0.0,
        mode_heads: bool = False,
        kind: str | None = None,
        **unknown,
    ) -> None:
        super().__init__()
        if kind is not None and kind != self.kind:
            raise ValueError(
                f"{type(self).__name__} holds '{self.kind}' policies, this checkpoint/config is a '{kind}' policy"
            )
        if unknown:
            raise TypeError(f"{type(self).__name__}: unexpected arguments {sorted(unknown)}")
        if scheduler not in SCHEDULERS:
            raise ValueError(
                f"{type(self).__name__}.scheduler: expected one of {SCHEDULERS}, got {scheduler!r}"
            )
        if not aux_weight >= 0:
            raise ValueError(f"{type(self).__name__}.aux_weight: expected a number >= 0, got {aux_weight}")
        if mode_heads and not aux_weight > 0:
            raise ValueError(
                f"{type(self).__name__}.mode_heads: needs aux_weight > 0 (the mode logit picks the head), "
                f"got aux_weight={aux_weight}"
            )
        if n_steps < 2 or not duration > 0:
            raise ValueError(
                f"{type(self).__name__}: need n_steps >= 2 and duration > 0, got {n_steps}, {duration}"
            )
        if depth_encoding not in DEPTH_ENCODINGS:
            raise ValueError(
                f"{type(self).__name__}.depth_encoding: expected one of {DEPTH_ENCODINGS}, got {depth_encoding!r}"
            )
        if depth_encoding != "range" and not depth:
            raise ValueError(f"{type(self).__name__}.depth_encoding: {depth_encoding!r} needs depth=true")
        brightness_augment = brightness_range(brightness_augment, depth, type(self).__name__)
        self.save_hyperparameters(ignore=["name"])
        self.hparams["kind"] = self.kind
        self.config_name = name or self.kind
        if not isinstance(depth, bool):
            raise ValueError(f"{type(self).__name__}.depth: expected a bool, got {depth!r}")
        self.encoder = KeypointEncoder(
            channels, temperature, global_pool=global_pool, in_channels=4 if depth else 3
        )
        self.bias_input = nn.Parameter(torch.zeros(bias_dim))
        self._robot = None
        self._val_runs = 0
        self._colour_tta = False

    @property
    def input_channels(self) -> int:
        """Image channels the policy takes: 3 (RGB) or 4 (RGB-D, ``depth``)."""
        return self.encoder.in_channels

    @property
    def depth_encoding(self) -> str:
        """The RGB-D depth channel's encoding (``"range"`` for checkpoints older than the option)."""
        return self.hparams.get("depth_encoding", "range")

    def controller(self, dt: float) -> Controller:
        """The policy's one inference interface: a new closed-loop controller with control
        period ``dt`` (s), which the evaluator starts once per episode and steps every period
        (:func:`lfd.visuomotor.eval.rollout.run_episode`)."""
        raise NotImplementedError(f"{type(self).__name__} defines no controller")

    def _build(self, output_dim: int, stat_shapes: dict[str, tuple[int, ...]], extra_inputs: int = 0) -> None:
        """Subclasses call this at the end of ``__init__``: the fully connected head with
        ``output_dim`` outputs (and ``extra_inputs`` more inputs besides keypoints, joints
        and bias, see :meth:`features`), and one persistent (mean, std) buffer pair per
        statistic."""
        hp = self.hparams
        self.output_dim = output_dim
        self.n_aux = AUX_DIM if hp.aux_weight > 0 else 0
        self.n_heads = 2 if hp.mode_heads else 1
        self.head = mlp(
            self.encoder.out_dim + hp.n_joints + hp.bias_dim + extra_inputs,
            hp.hidden,
            self.n_heads * output_dim + self.n_aux,
        )
        if self.n_aux:
            stat_shapes = {**stat_shapes, "target_point": (3,)}
        self.stat_names = tuple(stat_shapes)
        for stat, shape in stat_shapes.items():
            self.register_buffer(f"{stat}_mean", torch.zeros(shape))
            self.register_buffer(f"{stat}_std", torch.ones(shape))

    # ------------------------------------------------------------------ shared pieces
    @property
    def control_dt(self) -> float:
        """Seconds between two samples of a demonstration (= the control period)."""
        return self.hparams.duration / (self.hparams.n_steps - 1)

    @property
    def robot(self):
        """The robot model (batched differentiable FK), loaded on first use."""
        if self._robot is None:
            from lfd.robots import load_robot

            self._robot = load_robot(self.hparams.robot)
        return self._robot

    def normalise(self, stat: str, x: torch.Tensor) -> torch.Tensor:
        return (x - getattr(self, f"{stat}_mean")) / getattr(self, f"{stat}_std")

    def denormalise(self, stat: str, x: torch.Tensor) -> torch.Tensor:
        return x * getattr(self, f"{stat}_std") + getattr(self, f"{stat}_mean")

    def head_outputs(
        self,
        image: torch.Tensor,
        joints: torch.Tensor,
        extra: torch.Tensor | None = None,
        top: torch.Tensor | None = None,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Head outputs for images ``(B, 3, H, W)`` in [0, 1], joints ``(B, n)`` rad and, when
        the head was built with ``extra_inputs``, those inputs ``(B, e)``: the policy's
        ``(B, output_dim)`` and the auxiliary ``(B, n_aux)`` (``n_aux = 0`` without ``aux_weight``).

        With ``mode_heads`` the policy's output is that of the head of mode ``top`` (``(B,)``,
        1 = top; training passes the demonstrations' modes) or, when ``top`` is None, of the
        mode the auxiliary logit predicts; with one head ``top`` is ignored."""
        out = self._head_raw(image, joints, extra)
        k = self.n_heads * self.output_dim
        main, aux = out[:, :k], out[:, k:]
        if self.n_heads == 1:
            return main, aux
        pick = (aux[:, 0] > 0) if top is None else (top > 0.5)
        heads = main.view(-1, self.n_heads, self.output_dim)
        return heads[torch.arange(len(heads), device=heads.device), pick.long()], aux

    def _head_raw(
        self, image: torch.Tensor, joints: torch.Tensor, extra: torch.Tensor | None
    ) -> torch.Tensor:
        """Raw head output ``(B, n_heads * output_dim + n_aux)``; with :attr:`colour_tta`
        (outside training) the mean over the 6 orders of the RGB channels."""
        tta = self.colour_tta and not self.training
        b = image.shape[0]
        if tta:
            image = all_colour_orders(image)
            joints = joints.repeat(len(COLOUR_ORDERS), 1)
            extra = None if extra is None else extra.repeat(len(COLOUR_ORDERS), 1)
        keypoints = self.encoder(image)
        bias = self.bias_input.expand(image.shape[0], -1)
        parts = [keypoints, self.normalise("joints", joints), bias]
        if extra is not None:
            parts.append(extra)
        out = self.head(torch.cat(parts, dim=1))
        return out.view(len(COLOUR_ORDERS), b, -1).mean(dim=0) if tta else out

    @property
    def colour_tta(self) -> bool:
        """Test-time colour averaging: outside training, the head output is the mean over
        the 6 orders of the RGB channels (each head's output and the mode logit averaged
        before the logit picks the head), so the decision does not hang on the colour the
        object happens to have. Only for a policy trained with ``colour_augment`` (it saw
        every order); off by default, the evaluator sets it (``eval.colour_tta``)."""
        return self._colour_tta

    @colour_tta.setter
    def colour_tta(self, on: bool) -> None:
        if on and not self.hparams.get("colour_augment", False):
            raise ValueError(
                f"{type(self).__name__}.colour_tta: needs a policy trained with colour_augment=true "
                "(it never saw permuted colours otherwise)"
            )
        self._colour_tta = bool(on)

    def features(
        self, image: torch.Tensor, joints: torch.Tensor, extra: torch.Tensor | None = None
    ) -> torch.Tensor:
        """The policy's head output ``(B, output_dim)`` (see :meth:`head_outputs`)."""
        return self.head_outputs(image, joints, extra)[0]

    def add_aux_losses(
        self, out: dict[str, torch.Tensor], aux: torch.Tensor, batch: dict[str, torch.Tensor]
    ) -> dict[str, torch.Tensor]:
        """``out`` (a policy's losses) with the auxiliary losses of the ``(B, AUX_DIM)`` outputs
        against the batch's ``top`` (1 for a top approach, ``(B,)``) and ``target_point``
        (``(B, 3)`` m): ``aux_loss`` (unweighted sum, added to ``out["loss"]`` times
        ``aux_weight``) and ``aux_mode_error``; ``out`` unchanged without ``aux_weight``."""
        if not self.n_aux:
            return out
        for key in ("top", "target_point"):
            if key not in batch:
                raise ValueError(
                    f"{type(self).__name__}(aux_weight > 0): batches need the '{key}' key, got {sorted(batch)}"
                )
        mode = F.binary_cross_entropy_with_logits(aux[:, 0], batch["top"].to(aux))
        point = F.mse_loss(aux[:, 1:4], self.normalise("target_point", batch["target_point"]))
        wrong = ((aux[:, 0] > 0) != (batch["top"] > 0.5)).float().mean()
        return {
            **out,
            "loss": out["loss"] + self.hparams.aux_weight * (mode + point),
            "aux_loss": mode + point,
            "aux_mode_error": wrong,
        }

    def _observation(self, image, joints) -> tuple[torch.Tensor, torch.Tensor, bool]:
        """Closed-loop inputs as batched tensors on this module's device; ``batched`` says
        whether the caller gave a batch. Closed-loop calls switch the module to eval mode
        (batch-norm running statistics)."""
        self.eval()
        img = image_to_tensor(image, self.encoder.in_channels)
        q = torch.as_tensor(np.asarray(joints), dtype=torch.float32)
        batched = q.ndim == 2
        q = q.reshape(-1, self.hparams.n_joints)
        if img.shape[0] != q.shape[0]:
            raise ValueError(f"{type(self).__name__}: {img.shape[0]} images but {q.shape[0]} joint vectors")
        size = self.hparams.image_size
        if img.shape[-2:] != (size, size):
            raise ValueError(
                f"{type(self).__name__}: trained on {size}x{size} images, got {tuple(img.shape[-2:])}"
            )
        return img.to(self.device), q.to(self.device), batched

    def check_data(self, config, depth: bool | None = None) -> None:
        """Raise ``ValueError`` unless a dataset's generator ``config`` (rendering, timing,
        robot: :data:`DATA_KEYS`) matches what this policy was built for. ``depth``: whether
        the images served are RGB-D, when that differs from what the dataset recorded
        (``None`` = ``config.depth``; an RGB policy may read an RGB-D dataset's colour frames)."""
        for key in DATA_KEYS:
            built = self.hparams.get(key, False)  # only "depth" can be missing (older checkpoints)
            given = depth if key == "depth" and depth is not None else getattr(config, key)
            if given != built:
                raise ValueError(
                    f"{type(self).__name__} was built with {key}={built!r}, the dataset has {key}={given!r}"
                )

    #: Dataset fingerprint of the training run (:mod:`lfd.visuomotor.data.fingerprint`), saved in the
    #: checkpoint under :data:`FINGERPRINT_KEY`; None when unknown (e.g. a LeRobot dataset).
    dataset_fingerprint: dict | None = None

    def on_save_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        checkpoint[FINGERPRINT_KEY] = self.dataset_fingerprint

    def on_load_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        self.dataset_fingerprint = checkpoint.get(FINGERPRINT_KEY)

    # ------------------------------------------------------------------ Lightning hooks
    def setup(self, stage: str) -> None:
        """Lightning hook, at ``fit``: check the datamodule (:class:`PolicyData`) against the
        hyper-parameters and copy its statistics into the buffers; a generated dataset
        (:class:`GeneratedPolicyData`) also gives the served depth and the fingerprint.

        Raises:
            RuntimeError: the trainer has no datamodule offering :class:`PolicyData`.
            ValueError: its item mode, data settings or depth encoding differ from the policy's.
        """
        if stage != "fit":
            return
        dm = self.trainer.datamodule
        if not isinstance(dm, PolicyData):
            raise RuntimeError(
                f"{type(self).__name__} needs a datamodule with normalisation statistics (ReachDataModule)"
            )
        if dm.mode != self.item_mode:
            raise ValueError(
                f"{type(self).__name__} trains on data.mode={self.item_mode!r} items, the datamodule serves {dm.mode!r}"
            )
        generated = isinstance(dm, GeneratedPolicyData)
        if dm.config is not None:
            self.check_data(dm.config, depth=dm.input_depth if generated else None)
        served = dm.depth_encoding if generated else "range"
        if self.hparams.depth and served != self.depth_encoding:
            raise ValueError(
                f"{type(self).__name__} was built with depth_encoding={self.depth_encoding!r}, "
                f"the datamodule serves depth_encoding={served!r}"
            )
        self.dataset_fingerprint = dm.fingerprint() if generated else None
        stats = dm.stats
        for stat in self.stat_names:
            for moment in ("mean", "std"):
                buffer = getattr(self, f"{stat}_{moment}")
                buffer.copy_(torch.as_tensor(stats[stat][moment], dtype=buffer.dtype).reshape(buffer.shape))

    def perturbation(self, joints: torch.Tensor) -> torch.Tensor:
        """Noise ``(B, n)`` rad for the training joints: ``N(0, state_noise^2)`` (velocity CNN, ACT,
        Diffusion Policy), zeros in eval mode (validation, closed loop) or without ``state_noise``."""
        std = float(self.hparams.get("state_noise", 0.0))
        if not self.training or std == 0:
            return torch.zeros_like(joints)
        return torch.randn_like(joints) * std

    def training_step(self, batch: dict[str, torch.Tensor], batch_idx: int) -> torch.Tensor:
        if self.hparams.colour_augment:
            batch = {**batch, "image": permute_colour_channels(batch["image"])}
        if self.hparams.get("brightness_augment"):
            nearer = self.depth_encoding == "relief"
            batch = {
                **batch,
                "image": scale_foreground_brightness(
                    batch["image"], *self.hparams.brightness_augment, nearer_is_larger=nearer
                ),
            }
        losses = self.losses(batch)
        n = batch["image"].shape[0]
        self.log_dict(
            {f"train/{k}": v for k, v in losses.items()},
            prog_bar=False,
            on_step=True,
            on_epoch=True,
            batch_size=n,
        )
        self.log(
            "train/lr", self.optimizers().param_groups[0]["lr"], on_step=True, on_epoch=False, batch_size=n
        )
        return losses["loss"]

    def validation_step(self, batch: dict[str, torch.Tensor], batch_idx: int) -> None:
        losses = self.losses(batch)
        self.log_dict(
            {f"val/{k}": v for k, v in losses.items()},
            prog_bar=True,
            sync_dist=True,
            batch_size=batch["image"].shape[0],
        )
        if batch_idx == 0 and not self.trainer.sanity_checking:
            every = self.hparams.plot_every_n_val
            if every and self._val_runs % every == 0:
                log_sample_figure(self, batch)
            self._val_runs += 1

    def configure_optimizers(self) -> dict[str, Any]:
        hp = self.hparams
        groups = [{"params": list(self.parameters()), "lr": hp.lr, "weight_decay": hp.weight_decay}]
        return make_optimizer(self, groups, hp.scheduler, pct_start=ONECYCLE_PCT_START)
