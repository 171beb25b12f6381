"""The keypoint head of the CNN -> DMP and velocity policies: a conv trunk with spatial
soft-argmax keypoints (:class:`~lfd.visuomotor.policies.vision.KeypointEncoder`), concatenated with
the normalised joints and a learned bias input, then a fully connected ReLU head; optionally
one output head per approach mode, auxiliary training-only labels and test-time colour
averaging. The training harness (:class:`~lfd.visuomotor.policies.base.VisuomotorPolicy`)
knows none of this; the chunking policies (ACT, Diffusion Policy) have their own networks.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from lfd.visuomotor.policies.base import VisuomotorPolicy, check_sizes
from lfd.visuomotor.policies.vision import COLOUR_ORDERS, KeypointEncoder, all_colour_orders, mlp

#: Auxiliary head outputs with ``aux_weight > 0``: the top-approach logit, the normalised target point (3).
AUX_DIM = 4


class KeypointPolicy(VisuomotorPolicy):
    """A policy whose network is the keypoint head (module docstring); its constructor
    arguments, besides the harness's (``**common``):

    Args:
        channels: conv channels of the trunk, one entry per layer.
        temperature: initial spatial soft-argmax temperature.
        hidden: widths of the fully connected ReLU layers after the keypoints.
        bias_dim: size of the learned bias input concatenated to the keypoints and joints
            (0 disables it).
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
        **common: :class:`~lfd.visuomotor.policies.base.VisuomotorPolicy` arguments.

    Subclasses call :meth:`_build` at the end of ``__init__``.
    """

    def __init__(
        self,
        *,
        channels: tuple[int, ...] | list[int] = (32, 32, 32, 32),
        temperature: float = 1.0,
        hidden: tuple[int, ...] | list[int] = (200, 200, 200),
        bias_dim: int = 10,
        global_pool: bool = False,
        aux_weight: float = 0.0,
        mode_heads: bool = False,
        **common,
    ) -> None:
        name = type(self).__name__
        check_sizes(name, channels=channels, hidden=hidden, bias_dim=bias_dim)
        if not aux_weight >= 0:
            raise ValueError(f"{name}.aux_weight: expected a number >= 0, got {aux_weight}")
        if mode_heads and not aux_weight > 0:
            raise ValueError(
                f"{name}.mode_heads: needs aux_weight > 0 (the mode logit picks the head), "
                f"got aux_weight={aux_weight}"
            )
        super().__init__(**common)
        self.encoder = KeypointEncoder(
            channels, temperature, global_pool=global_pool, in_channels=self.input_channels
        )
        self.bias_input = nn.Parameter(torch.zeros(bias_dim))
        self._colour_tta = False

    def _build(
        self,
        output_dim: int,
        stat_shapes: dict[str, tuple[int, ...]],
        extra_inputs: int = 0,
        joints_input: bool = True,
        head_keypoints: int | None = None,
        head_spreads: bool = True,
    ) -> None:
        """Subclasses call this at the end of ``__init__``: the fully connected head with
        ``output_dim`` outputs (and ``extra_inputs`` more inputs besides keypoints, joints
        and bias, see :meth:`features`; without ``joints_input`` the head does not see the
        joints; with ``head_keypoints = m`` it sees only the first ``m`` keypoints' coordinates
        and, with ``head_spreads``, the encoder's spreads, :attr:`KeypointEncoder.spread_channels`,
        if any), and one persistent (mean, std) buffer pair per statistic."""
        hp = self.hparams
        self.output_dim = output_dim
        self.joints_input = joints_input
        self.head_keypoints = head_keypoints
        self.head_spreads = head_spreads
        self.n_aux = AUX_DIM if hp.aux_weight > 0 else 0
        self.n_heads = 2 if hp.mode_heads else 1
        spreads = 2 * self.encoder.spread_channels if head_spreads else 0
        seen = self.encoder.out_dim if head_keypoints is None else 2 * int(head_keypoints) + spreads
        self.head = mlp(
            seen + (hp.n_joints if joints_input else 0) + hp.bias_dim + extra_inputs,
            hp.hidden,
            self.n_heads * output_dim + self.n_aux,
        )
        if self.n_aux:
            stat_shapes = {**stat_shapes, "target_point": (3,)}
        self.register_statistics(stat_shapes)

    def head_outputs(
        self,
        image: torch.Tensor,
        joints: torch.Tensor,
        extra: torch.Tensor | None = None,
        top: torch.Tensor | None = None,
        with_keypoints: bool = False,
    ) -> tuple[torch.Tensor, ...]:
        """Head outputs for images ``(B, 3, H, W)`` in [0, 1], joints ``(B, n)`` rad and, when
        the head was built with ``extra_inputs``, those inputs ``(B, e)``: the policy's
        ``(B, output_dim)`` and the auxiliary ``(B, n_aux)`` (``n_aux = 0`` without ``aux_weight``).

        With ``mode_heads`` the policy's output is that of the head of mode ``top`` (``(B,)``,
        1 = top; training passes the demonstrations' modes) or, when ``top`` is None, of the
        mode the auxiliary logit predicts; with one head ``top`` is ignored.

        ``with_keypoints``: also return the encoder's output ``(B, encoder.out_dim)`` (keypoints
        ``[x_0, y_0, ...]`` in the soft-argmax's ``[-1, 1]`` units first), a third element."""
        out, keypoints = self._head_and_keypoints(image, joints, extra)
        k = self.n_heads * self.output_dim
        main, aux = out[:, :k], out[:, k:]
        if self.n_heads > 1:
            pick = (aux[:, 0] > 0) if top is None else (top > 0.5)
            heads = main.view(-1, self.n_heads, self.output_dim)
            main = heads[torch.arange(len(heads), device=heads.device), pick.long()]
        return (main, aux, keypoints) if with_keypoints else (main, aux)

    def _head_raw(
        self, image: torch.Tensor, joints: torch.Tensor, extra: torch.Tensor | None
    ) -> torch.Tensor:
        """Raw head output ``(B, n_heads * output_dim + n_aux)``; with :attr:`colour_tta`
        (outside training) the mean over the 6 orders of the RGB channels."""
        return self._head_and_keypoints(image, joints, extra)[0]

    def _head_and_keypoints(
        self, image: torch.Tensor, joints: torch.Tensor, extra: torch.Tensor | None
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """:meth:`_head_raw` and the encoder's output (averaged the same way)."""
        tta = self.colour_tta and not self.training
        image = self.scene_image(image)
        b = image.shape[0]
        if tta:
            image = all_colour_orders(image)
            joints = joints.repeat(len(COLOUR_ORDERS), 1)
            extra = None if extra is None else extra.repeat(len(COLOUR_ORDERS), 1)
        keypoints = self.encoder(image)
        if self.head_keypoints is None:
            seen = keypoints
        else:
            seen = keypoints[:, : 2 * self.head_keypoints]
            if self.head_spreads and self.encoder.spread_channels:
                spreads = keypoints[:, keypoints.shape[1] - 2 * self.encoder.spread_channels :]
                seen = torch.cat([seen, spreads], dim=1)
        bias = self.bias_input.expand(image.shape[0], -1)
        parts = [seen, self.normalise("joints", joints), bias] if self.joints_input else [seen, bias]
        if extra is not None:
            parts.append(extra)
        out = self.refine_head(self.head(torch.cat(parts, dim=1)), keypoints)
        if tta:
            mean = lambda x: x.view(len(COLOUR_ORDERS), b, -1).mean(dim=0)  # noqa: E731
            return mean(out), mean(keypoints)
        return out, keypoints

    def refine_head(self, out: torch.Tensor, keypoints: torch.Tensor) -> torch.Tensor:
        """The raw head output ``(B, n_heads * output_dim + n_aux)`` after a subclass's own use of
        the encoder's output ``(B, encoder.out_dim)``; here unchanged."""
        return out

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
