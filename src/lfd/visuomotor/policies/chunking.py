"""Base of the action-chunking policies (ACT, Diffusion Policy): image + joints at step ``t``
-> a chunk of future joint positions ``q[t+1], ..., q[t+k]`` (rad).

They train on the velocity policy's items (one per time step, ``item_mode = "velocity"``:
image, joints, episode ``index`` and ``step``). The chunk target of an item is read from
the demonstrations' joint trajectories, which :meth:`ChunkPolicy.setup` collects from the
datamodule's split datasets into a lookup table (episode index -> ``(T, n)``); past the
demonstration's end the target holds its last sample (the demonstrations end at rest, as
the CNN -> DMP policy's ``rest_steps`` use). A batch may also carry its own ``chunk``
``(B, k, n)`` (tests, foreign data).

Chunk sample ``i`` is the position target of the command at step ``t + i`` (reached one
control period later), as :class:`~lfd.visuomotor.policies.control.PlanController` tracks a
plan; :class:`~lfd.visuomotor.policies.control.ChunkController` runs the chunks in closed
loop. Actions are normalised with the joints' statistics (train split).
"""

from __future__ import annotations

import numpy as np
import torch

from lfd.visuomotor.policies.base import VisuomotorPolicy
from lfd.visuomotor.policies.control import ChunkController, chunk_execution
from lfd.visuomotor.policies.plots import joint_figure
from lfd.visuomotor.policies.vision import KeypointEncoder

#: Batch keys the chunk lookup needs (the velocity items carry them).
LOOKUP_KEYS = ("index", "step")
#: Keypoint-head settings that checkpoints of earlier releases carry, at these no-op values.
RETIRED = {"hidden": [], "bias_dim": 0, "global_pool": False, "aux_weight": 0.0, "mode_heads": False}
#: State-dict entries of those checkpoints that no chunking policy has any more (the unused
#: keypoint head's bias input, and the backbone's second name).
RETIRED_STATE = ("bias_input", "encoder.")


class ChunkPolicy(VisuomotorPolicy):
    """Common part of :class:`~lfd.visuomotor.policies.act.ACTPolicy` and
    :class:`~lfd.visuomotor.policies.diffusion.DiffusionPolicy`.

    Args:
        chunk_size: ``k``, joint-position samples predicted per query.
        state_noise: std (rad) of Gaussian noise added to the joints the policy is conditioned
            on in training (0: none), the target chunk staying the demonstration's: the policy
            learns to steer back to the demonstrated path from states near it (noise injection,
            DART, Laskey et al. 2017, as the velocity CNN's ``state_noise``; absolute position
            targets make the correction implicit). Not in the ACT or Diffusion Policy papers.
        channels: the conv channels of the project's trunk (``backbone="trunk"``).
        temperature: initial spatial soft-argmax temperature (Diffusion Policy's keypoints).
        **common: :class:`~lfd.visuomotor.policies.base.VisuomotorPolicy` arguments. Checkpoints
            of earlier releases also hold the keypoint head's settings at their no-op values
            (:data:`RETIRED`); they are accepted and dropped, any other value is refused.

    Subclasses define :meth:`predict_chunk` and ``losses``; :attr:`replan_every` and
    :attr:`ensemble_m` say how :meth:`controller` runs the chunks.
    """

    item_mode = "velocity"
    #: Hyper-parameters of earlier releases' checkpoints that the constructor accepts by ``**common``
    #: (:data:`RETIRED`; :func:`lfd.training.init_arguments` counts them as taken).
    RETIRED_HYPERPARAMETERS = tuple(RETIRED)

    def __init__(
        self,
        *,
        chunk_size: int,
        state_noise: float = 0.0,
        channels: tuple[int, ...] | list[int] = (32, 32, 32, 32),
        temperature: float = 1.0,
        **common,
    ) -> None:
        for key, no_op in RETIRED.items():
            if common.pop(key, no_op):
                raise ValueError(f"{type(self).__name__}.{key}: not supported by chunking policies")
        super().__init__(**common)
        # The random draws of the keypoint trunk these policies were first built with (never
        # used by them): the initial weights, and so every documented result, stay reproducible.
        KeypointEncoder(channels, temperature, in_channels=self.input_channels)
        if not (isinstance(chunk_size, int) and chunk_size >= 1):
            raise ValueError(f"{type(self).__name__}.chunk_size: expected an int >= 1, got {chunk_size!r}")
        if not (isinstance(state_noise, (int, float)) and 0 <= state_noise < float("inf")):
            raise ValueError(
                f"{type(self).__name__}.state_noise: expected a number >= 0 (rad), got {state_noise!r}"
            )
        n = self.hparams.n_joints
        self.register_statistics({"joints": (n,)})
        # episode index -> demonstrated joints (T, n); filled at fit time, not saved
        self.register_buffer("_trajectories", torch.zeros(0, self.hparams.n_steps, n), persistent=False)

    #: Chunks are queried every this many control steps (None: the chunk size).
    replan_every: int | None = None
    #: Temporal ensembling weight decay ``m`` (``w_i = exp(-m i)``, oldest chunk first), or None.
    ensemble_m: float | None = None

    def set_execution(self, replan_every: int | None = ..., ensemble_m: float | None = ...) -> None:
        """Run the chunks differently from the trained configuration (an evaluation ablation:
        ``replan_every`` control steps between queries, None: each chunk executed to its end;
        ``ensemble_m`` temporal ensembling, None: the newest chunk alone); an argument left out
        keeps its current value.

        Raises:
            ValueError: ``replan_every`` not an int in 1..chunk_size or None; ``ensemble_m`` not a
                number >= 0 or None.
        """
        self.replan_every, self.ensemble_m = chunk_execution(
            self.replan_every if replan_every is ... else replan_every,
            self.ensemble_m if ensemble_m is ... else ensemble_m,
            type(self).__name__,
            max_replan=self.hparams.chunk_size,
        )

    @property
    def execution(self) -> dict[str, int | float | None]:
        """How :meth:`controller` runs the chunks: ``{"replan_every": ..., "ensemble_m": ...}``."""
        return {"replan_every": self.replan_every, "ensemble_m": self.ensemble_m}

    def on_load_checkpoint(self, checkpoint: dict) -> None:
        """Drop the :data:`RETIRED_STATE` entries of an earlier release's checkpoint."""
        super().on_load_checkpoint(checkpoint)
        state = checkpoint.get("state_dict", {})
        for key in [k for k in state if k.startswith(RETIRED_STATE)]:
            del state[key]

    # ------------------------------------------------------------------ targets
    def setup(self, stage: str) -> None:
        """Lightning hook: the dataset's statistics (base class), then the lookup table of the
        demonstrations' joints from every split dataset's ``joints``, ``index``, ``step``."""
        super().setup(stage)
        if stage != "fit":
            return
        datasets = [d for d in self.trainer.datamodule.datasets.values() if d is not None]
        self.set_trajectories(datasets)

    def set_trajectories(self, datasets) -> None:
        """Fill the chunk lookup table from datasets with ``tensors`` ``joints (N, n)``,
        ``index (N,)`` and ``step (N,)`` (velocity items).

        Raises:
            ValueError: a dataset lacks those tensors or its steps exceed ``n_steps``.
        """
        n, steps = self.hparams.n_joints, self.hparams.n_steps
        parts = []
        for d in datasets:
            t = getattr(d, "tensors", {})
            missing = [k for k in ("joints", *LOOKUP_KEYS) if k not in t]
            if missing:
                raise ValueError(
                    f"{type(self).__name__}: the items need {missing} (the velocity items, one per time step)"
                )
            parts.append((t["index"].long(), t["step"].long(), t["joints"].float()))
        size = 1 + max(int(i.max()) for i, _, _ in parts)
        table = torch.zeros(size, steps, n)
        for index, step, joints in parts:
            if int(step.max()) >= steps:
                raise ValueError(f"{type(self).__name__}: item step {int(step.max())} >= n_steps={steps}")
            table[index, step] = joints
        self._trajectories = table.to(self.device)

    def chunk_targets(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        """The batch's chunk targets ``(B, k, n)`` rad: ``batch["chunk"]`` when given, else
        ``q[t+1..t+k]`` of each item's demonstration (held at its last sample)."""
        if "chunk" in batch:
            return batch["chunk"]
        if self._trajectories.shape[0] == 0 or any(k not in batch for k in LOOKUP_KEYS):
            raise ValueError(
                f"{type(self).__name__}: batches need 'chunk' (B, k, n) or 'index' and 'step' with the "
                "demonstrations set (setup('fit') or set_trajectories)"
            )
        k, last = self.hparams.chunk_size, self.hparams.n_steps - 1
        steps = (batch["step"].long()[:, None] + torch.arange(1, k + 1, device=self.device)).clamp(max=last)
        return self._trajectories[batch["index"].long()[:, None], steps]

    def input_joints(self, batch: dict[str, torch.Tensor]) -> torch.Tensor:
        """The joints ``(B, n)`` rad a training or validation batch conditions the policy on:
        ``batch["joints"]`` plus :meth:`perturbation` (``state_noise``, training only)."""
        return batch["joints"] + self.perturbation(batch["joints"])

    # ------------------------------------------------------------------ inference
    def predict_chunk(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        """Images ``(B, C, H, W)`` in [0, 1], joints ``(B, n)`` rad -> chunk ``(B, k, n)`` rad (each chunking
        policy, ACT and Diffusion Policy, defines it)."""
        raise NotImplementedError(f"{type(self).__name__} defines no predict_chunk")

    def forward(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        return self.predict_chunk(image, joints)

    @torch.inference_mode()
    def act_chunk(self, image, joints) -> np.ndarray:
        """The per-query call of :meth:`controller`: camera image(s) uint8 ``(H, W, C)`` /
        ``(B, H, W, C)`` and joints ``(n,)`` / ``(B, n)`` rad -> chunk ``(k, n)`` / ``(B, k, n)``
        rad (float64), sample ``i`` the position target of the command ``i`` steps from now."""
        img, q, batched = self._observation(image, joints)
        chunk = self.predict_chunk(img, q).double().cpu().numpy()
        return chunk if batched else chunk[0]

    def controller(self, dt: float) -> ChunkController:
        """A :class:`~lfd.visuomotor.policies.control.ChunkController` querying :meth:`act_chunk`
        every :attr:`replan_every` steps (temporal ensembling with :attr:`ensemble_m`)."""
        return ChunkController(self, dt, replan_every=self.replan_every, ensemble_m=self.ensemble_m)

    def sample_figure(self, batch: dict[str, torch.Tensor]):
        """The first item's predicted chunk against its target."""
        with torch.no_grad():
            predicted = self.predict_chunk(batch["image"][:1], batch["joints"][:1])[0].cpu().numpy()
        target = self.chunk_targets(batch)[0].cpu().numpy()
        t = np.arange(1, len(target) + 1) * self.control_dt
        return joint_figure(t, predicted, target, f"{self.kind} chunk, item 0")
