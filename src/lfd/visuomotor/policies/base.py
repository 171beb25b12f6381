"""The visuomotor policies' training harness (a LightningModule): settings shared by every
policy, the data checks, normalisation, optimisation, logging, and the policy registry.

A policy sees only what a robot's own sensors give it: the fixed camera's RGB image and
the arm's joint angles. Subclasses define the network, the loss, the dataset item mode
they train on and their one inference interface, :meth:`VisuomotorPolicy.controller`
(a :class:`~lfd.visuomotor.protocols.Controller` the closed-loop evaluator steps). The
harness holds no network of its own: the keypoint head of the CNN -> DMP and velocity
policies is :class:`~lfd.visuomotor.policies.keypoint.KeypointPolicy`, the chunking
policies' networks are theirs.

Every subclass that sets :attr:`VisuomotorPolicy.kind` is registered under it when its class
is defined (:data:`POLICIES`): a new policy is its module and its ``configs/model/<kind>.yaml``.

Normalisation statistics (train split of the dataset, see :mod:`lfd.visuomotor.data.stats`) are
copied from the datamodule (:class:`~lfd.visuomotor.protocols.PolicyData`) at ``setup("fit")``
into persistent buffers, so a checkpoint
carries them and ``Policy.load_from_checkpoint(path)`` runs on its own.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import lightning as L
import numpy as np
import torch

from lfd.checks import check_int
from lfd.sim.depth import DEPTH_ENCODINGS
from lfd.training import SCHEDULERS, make_optimizer
from lfd.visuomotor.policies.plots import log_sample_figure
from lfd.visuomotor.policies.vision import (
    brightness_range,
    image_to_tensor,
    permute_colour_channels,
    scale_foreground_brightness,
)
from lfd.visuomotor.protocols import ITEM_MODES, Controller, GeneratedPolicyData, PolicyData

#: Warm-up fraction of the policies' one-cycle schedule (torch's ``OneCycleLR`` default).
ONECYCLE_PCT_START = 0.3
#: Hyper-parameters that must equal the dataset's (``GeneratorConfig``) ones.
DATA_KEYS = ("image_size", "depth", "duration", "n_steps", "robot")
#: Checkpoint key of the training dataset's fingerprint.
FINGERPRINT_KEY = "lfd_dataset_fingerprint"
#: Checkpoint key of the training run's settings (:attr:`VisuomotorPolicy.training_run`).
TRAINING_RUN_KEY = "lfd_training_run"


def check_sizes(owner: str, **sizes: Any) -> None:
    """Refuse a size hyper-parameter that is not an integer >= 1, or a list of sizes (layer widths:
    ``hidden=[200, 200]``) that is empty or holds one that is not: ``ValueError`` naming
    ``<owner>.<name>``. A policy checks its sizes before building anything (a config's or a
    checkpoint's values: ``n_joints=-3`` or ``hidden=[2e5, 2e5]`` is refused here, not by torch)."""
    for name, value in sizes.items():
        if isinstance(value, (list, tuple)) or (
            hasattr(value, "__len__") and not isinstance(value, (str, bytes))
        ):
            values = list(value)
            if not values:
                raise ValueError(f"{owner}.{name} must be a non-empty list of integers >= 1, got []")
            for i, v in enumerate(values):
                check_int(v, f"{owner}.{name}[{i}]", minimum=1)
        else:
            check_int(value, f"{owner}.{name}", minimum=1)


#: The policy registry: kind (``VisuomotorPolicy.kind``, stored in every checkpoint) -> class.
#: Filled by :meth:`VisuomotorPolicy.__init_subclass__`; read it, do not write it.
POLICIES: dict[str, type[VisuomotorPolicy]] = {}


class VisuomotorPolicy(L.LightningModule):
    """Image + joints -> action: the training harness every policy shares. Its constructor
    arguments (each policy adds its own):

    Args:
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
        robot: robot model name (:func:`lfd.robots.load_robot`), or None for a policy in the
            tool's space: the state's (``joints``') first three entries are the tool position
            (m), e.g. Meta-World's hand position and gripper command (:mod:`lfd.metaworld`).
        n_joints: arm degrees of freedom.
        colour_augment: shuffle the RGB channels of each training image
            (:func:`~lfd.visuomotor.policies.vision.permute_colour_channels`).
        brightness_augment: ``[low, high]``: the object's colour in each training image
            times a random factor in that range (log-uniform;
            :func:`~lfd.visuomotor.policies.vision.scale_foreground_brightness`), or None. Needs
            ``depth`` (the depth channel tells the object from the table).
        subtract_background: the encoders see ``0.5 + 2 (image - background)`` clipped to
            [0, 1] instead of the image, where ``background`` ``(C, H, W)`` is the per-pixel
            median of the training episodes' first images (a fixed camera's empty scene: what
            differs from it is what the episode placed), filled at ``setup("fit")`` from the
            datamodule's ``background`` and stored in the checkpoint. Not with the colour or
            brightness augmentation (they change the image, not the background).
        plot_every_n_val: a validation sample plot goes to TensorBoard at every this many
            validation runs (0: never).
        kind: when given (from a checkpoint), must equal the class's :attr:`kind` (checked
            before ``unknown``, so loading another kind's checkpoint names the kinds).
        unknown: any other keyword raises ``TypeError``.

    The dataset settings (:attr:`DATA_ARGUMENTS`) are not written in a model config: ``train.py``
    takes them from the data config (:meth:`data_arguments`), and the datamodule serves the
    items of :attr:`item_mode`.

    Subclasses set :attr:`kind` (which registers them in :data:`POLICIES`) and :attr:`item_mode`,
    register their normalisation statistics (:meth:`register_statistics`) and define
    ``losses(batch) -> {"loss": ..., ...}`` (scalar tensors), ``sample_figure(batch) ->
    matplotlib figure`` and :meth:`controller`.
    """

    #: Fixed identifier of the policy family, stored in the checkpoint's hyper-parameters.
    kind: str = ""
    #: Dataset item layout this policy trains on (``ReachDataModule(mode=...)``).
    item_mode: str = ""
    #: Name in tables and figure legends (default: the kind).
    label: str = ""
    #: Matplotlib colour in every figure (default: grey).
    colour: str = "tab:gray"
    #: Constructor arguments taken from the dataset's settings (:meth:`data_arguments`).
    DATA_ARGUMENTS: tuple[str, ...] = (
        "image_size",
        "depth",
        "depth_encoding",
        "duration",
        "n_steps",
        "robot",
    )

    def __init_subclass__(cls, **kwargs) -> None:
        """Register a subclass that sets its own :attr:`kind` in :data:`POLICIES`.

        Raises:
            ValueError: another class already holds that kind (a kind names one policy).
        """
        super().__init_subclass__(**kwargs)
        kind = cls.__dict__.get("kind")
        if not kind:
            return
        if not isinstance(kind, str) or not kind.isidentifier():
            raise ValueError(f"{cls.__qualname__}.kind: expected an identifier, got {kind!r}")
        if cls.item_mode not in ITEM_MODES:
            raise ValueError(
                f"{cls.__qualname__}.item_mode: expected one of {ITEM_MODES}, got {cls.item_mode!r}"
            )
        held = POLICIES.get(kind)
        if held is not None and (held.__module__, held.__qualname__) != (cls.__module__, cls.__qualname__):
            raise ValueError(
                f"policy kind {kind!r} is already registered by {held.__module__}.{held.__qualname__}"
            )
        POLICIES[kind] = cls
        if not cls.__dict__.get("label"):
            cls.label = kind

    @classmethod
    def data_arguments(cls, data: Mapping[str, Any]) -> dict[str, Any]:
        """The constructor arguments :attr:`DATA_ARGUMENTS` from a data config's plain values
        (``data.image_size``, ...): ``depth`` is what the policy sees (``input_depth``, else
        ``depth``), ``depth_encoding`` defaults to ``"range"``, ``duration`` to ``(n_steps - 1) * control_dt``
        when the data config gives a control period instead; ``n_joints`` too when the data
        config gives it (not null: the size of the state the policy sees).

        Raises:
            ValueError: the data config lacks one of them (one line naming it).
        """
        values = dict(data)
        depth = values.get("input_depth")
        values["depth"] = values.get("depth", False) if depth is None else depth
        values.setdefault("depth_encoding", "range")
        if values.get("duration") is None and values.get("control_dt") and values.get("n_steps"):
            values["duration"] = (values["n_steps"] - 1) * values["control_dt"]  # a simulator's fixed period
        missing = [k for k in cls.DATA_ARGUMENTS if k not in values]
        if missing:
            raise ValueError(
                f"{cls.__name__}: the data config has no {missing}; the policy takes them from its dataset"
            )
        out = {k: values[k] for k in cls.DATA_ARGUMENTS}
        if values.get("n_joints") is not None:  # a data config that names its state size
            out["n_joints"] = values["n_joints"]
        return out

    def __init__(
        self,
        *,
        lr: float = 1e-3,
        weight_decay: float = 1e-4,
        scheduler: str = "cosine",
        image_size: int = 128,
        depth: bool = False,
        depth_encoding: str = "range",
        duration: float = 4.0,
        n_steps: int = 100,
        robot: str | None = "pr2_right_arm",
        n_joints: int = 7,
        plot_every_n_val: int = 5,
        colour_augment: bool = False,
        brightness_augment: tuple[float, float] | list[float] | None = None,
        subtract_background: bool = False,
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
        check_sizes(type(self).__name__, n_joints=n_joints, image_size=image_size, n_steps=n_steps)
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
        if not isinstance(subtract_background, bool):
            raise ValueError(
                f"{type(self).__name__}.subtract_background: expected true or false, got {subtract_background!r}"
            )
        if subtract_background and (colour_augment or brightness_augment):
            raise ValueError(
                f"{type(self).__name__}.subtract_background: not with colour_augment or brightness_augment "
                "(they change the image and not its background)"
            )
        self.save_hyperparameters()
        self.hparams["kind"] = self.kind
        if not isinstance(depth, bool):
            raise ValueError(f"{type(self).__name__}.depth: expected a bool, got {depth!r}")
        self.stat_names: tuple[str, ...] = ()
        self._robot = None
        self._val_runs = 0
        if subtract_background:
            self.register_buffer("background", torch.zeros(self.input_channels, image_size, image_size))

    def scene_image(self, image: torch.Tensor) -> torch.Tensor:
        """What the encoders see of images ``(B, C, H, W)`` in [0, 1]: the images, or with
        ``subtract_background`` their difference from the background (same shape, in [0, 1])."""
        if not self.hparams.get("subtract_background", False):
            return image
        return (0.5 + 2.0 * (image - self.background)).clamp(0.0, 1.0)

    @property
    def input_channels(self) -> int:
        """Image channels the policy takes: 3 (RGB) or 4 (RGB-D, ``depth``)."""
        return 4 if self.hparams.depth else 3

    @property
    def colour_tta(self) -> bool:
        """Test-time colour averaging (a policy that supports it overrides this; the evaluator
        sets it from ``eval.colour_tta``)."""
        return False

    @colour_tta.setter
    def colour_tta(self, on: bool) -> None:
        if on:
            raise ValueError(f"{type(self).__name__}.colour_tta: test-time colour averaging is not supported")

    #: Settings of the training run that made this policy (``train.py``: the experiment and the
    #: data config's plain values), saved in the checkpoint under :data:`TRAINING_RUN_KEY` so that
    #: an evaluation can use them; None when unknown (e.g. a checkpoint of an older release).
    training_run: dict | None = None

    def register_statistics(self, stat_shapes: Mapping[str, tuple[int, ...]]) -> None:
        """One persistent (mean, std) buffer pair per statistic (``<stat>_mean`` zeros,
        ``<stat>_std`` ones of that shape), filled from the datamodule at ``setup("fit")``."""
        self.stat_names = tuple(stat_shapes)
        for stat, shape in stat_shapes.items():
            self.register_buffer(f"{stat}_mean", torch.zeros(shape))
            self.register_buffer(f"{stat}_std", torch.ones(shape))

    @property
    def depth_encoding(self) -> str:
        """The RGB-D depth channel's encoding (``"range"`` for checkpoints older than the option)."""
        return self.hparams.get("depth_encoding", "range")

    def controller(self, dt: float) -> Controller:
        """The policy's one inference interface: a new closed-loop controller with control
        period ``dt`` (s), which the evaluator starts once per episode and steps every period
        (:func:`lfd.visuomotor.eval.rollout.run_episode`)."""
        raise NotImplementedError(f"{type(self).__name__} defines no controller")

    # ------------------------------------------------------------------ shared pieces
    @property
    def control_dt(self) -> float:
        """Seconds between two samples of a demonstration (= the control period)."""
        return self.hparams.duration / (self.hparams.n_steps - 1)

    @property
    def robot(self):
        """The robot model (batched differentiable FK), loaded on first use.

        Raises:
            ValueError: the policy has no robot (``robot=None``: its state is the tool's).
        """
        if self._robot is None:
            if self.hparams.robot is None:
                raise ValueError(
                    f"{type(self).__name__} acts in the tool's space (robot=None): no robot model"
                )
            from lfd.robots import load_robot

            self._robot = load_robot(self.hparams.robot)
        return self._robot

    def tool_positions(self, states: torch.Tensor) -> torch.Tensor:
        """Tool positions ``(..., 3)`` m of states ``(..., n)``: forward kinematics of the robot's
        joint angles, or the first three entries of a tool-space state (``robot=None``)."""
        if self.hparams.robot is None:
            return states[..., :3]
        flat = states.reshape(-1, states.shape[-1])
        return self.robot.fk(flat)[:, :3, 3].reshape(*states.shape[:-1], 3)

    def normalise(self, stat: str, x: torch.Tensor) -> torch.Tensor:
        return (x - getattr(self, f"{stat}_mean")) / getattr(self, f"{stat}_std")

    def denormalise(self, stat: str, x: torch.Tensor) -> torch.Tensor:
        return x * getattr(self, f"{stat}_std") + getattr(self, f"{stat}_mean")

    def _observation(self, image, joints) -> tuple[torch.Tensor, torch.Tensor, bool]:
        """Closed-loop inputs as batched tensors on this module's device; ``batched`` says
        whether the caller gave a batch. Closed-loop calls switch the module to eval mode
        (batch-norm running statistics)."""
        self.eval()
        img = image_to_tensor(image, self.input_channels)
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
        if self.training_run is not None:
            checkpoint[TRAINING_RUN_KEY] = self.training_run

    def on_load_checkpoint(self, checkpoint: dict[str, Any]) -> None:
        self.dataset_fingerprint = checkpoint.get(FINGERPRINT_KEY)
        run = checkpoint.get(TRAINING_RUN_KEY)
        self.training_run = run if isinstance(run, dict) else None

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
                f"{type(self).__name__} trains on {self.item_mode!r} items (its item_mode), "
                f"the datamodule serves {dm.mode!r}"
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
        if self.hparams.get("subtract_background", False):
            self._copy_background(dm)
        stats = dm.stats
        for stat in self.stat_names:
            for moment in ("mean", "std"):
                buffer = getattr(self, f"{stat}_{moment}")
                buffer.copy_(torch.as_tensor(stats[stat][moment], dtype=buffer.dtype).reshape(buffer.shape))

    def _copy_background(self, dm) -> None:
        background = getattr(dm, "background", None)
        if background is None:
            raise ValueError(
                f"{type(self).__name__}.subtract_background: the datamodule {type(dm).__name__} has no "
                "background image (Meta-World's has)"
            )
        background = torch.as_tensor(background, dtype=self.background.dtype)
        if background.shape != self.background.shape:
            raise ValueError(
                f"{type(self).__name__}.subtract_background: the datamodule's background has shape "
                f"{tuple(background.shape)}, the policy takes images of {tuple(self.background.shape)}"
            )
        self.background.copy_(background)

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
