"""ACT, Action Chunking with Transformers (Zhao et al. 2023, "Learning Fine-Grained Bimanual
Manipulation with Low-Cost Hardware"), written here (lfd cannot depend on LeRobot).

Network (the paper's Fig. 4, DETR-style):

* image backbone (:class:`~lfd.visuomotor.policies.backbones.ImageBackbone`: ResNet-18 trained
  from scratch, or the project's trunk) -> feature map -> 1x1 conv to ``d_model`` -> one token
  per cell with a 2-D sine embedding;
* transformer encoder over ``[z, joints, image tokens]`` (``z``: the CVAE latent projected, the
  joints projected; both with learned position embeddings);
* transformer decoder with ``chunk_size`` learned queries cross-attending to the encoder
  output -> linear -> normalised joint positions ``(k, n)``.

CVAE (``use_vae``, the paper's default): in training a transformer encoder over ``[CLS,
joints, the target chunk]`` (1-D sine embeddings) gives the posterior ``q(z | chunk, joints)``
(mean and log-variance of a ``latent_dim`` Gaussian); ``z`` is sampled from it and the loss
is ``L1(chunk) + kl_weight KL(q || N(0, I))``. At inference ``z = 0`` (the prior's mean).
Without ``use_vae`` ``z = 0`` always and the loss is the L1 alone.

Closed loop: a query every control step and temporal ensembling with ``w_i = exp(-m i)``
(``ensemble_m``; oldest chunk first), or with ``ensemble_m=None`` a query every chunk.

Differences from the paper's implementation (said, not hidden): position embeddings are added
once at the input of each transformer instead of in every attention layer; one observation
frame from one camera; the backbone is trained from scratch (no ImageNet weights).
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from lfd.visuomotor.policies.backbones import ImageBackbone, grid_embedding, sinusoidal_embedding
from lfd.visuomotor.policies.base import check_sizes
from lfd.visuomotor.policies.chunking import ChunkPolicy


def _encoder(d_model: int, heads: int, ff: int, layers: int, dropout: float) -> nn.TransformerEncoder:
    layer = nn.TransformerEncoderLayer(d_model, heads, ff, dropout, activation="relu", batch_first=True)
    return nn.TransformerEncoder(layer, layers, enable_nested_tensor=False)


class ACTPolicy(ChunkPolicy):
    """Image + joints at step t -> chunk of joint positions ``q[t+1..t+k]`` (rad).

    Args:
        chunk_size: ``k`` (the paper: 100 at 50 Hz, 2 s).
        backbone: ``"resnet18"`` or ``"trunk"`` (:data:`~lfd.visuomotor.policies.backbones.BACKBONES`).
        d_model, n_heads, dim_feedforward, dropout: transformer width, heads, feed-forward
            width, dropout.
        n_encoder_layers, n_decoder_layers: transformer depth (the paper's code runs 1
            decoder layer: its 7 are built but only the first one's output is used).
        use_vae: train as a CVAE (the paper's default) or deterministically.
        latent_dim, n_vae_layers, kl_weight: CVAE latent size, its encoder's depth and the
            KL term's weight (the paper: 32, 4, 10).
        ensemble_m: temporal-ensembling decay ``m`` (the paper: 0.01), None: no ensembling
            (a query every ``chunk_size`` steps).
        query_every: control steps between queries with ensembling (the paper: 1).
        max_grid: the feature map is average-pooled to at most ``max_grid x max_grid`` tokens
            (ResNet-18 at 128 px gives 4 x 4, untouched; the stride-2 trunk gives 64 x 64).
        **common: :class:`~lfd.visuomotor.policies.chunking.ChunkPolicy` arguments.
    """

    kind = "act"
    label = "ACT"
    colour = "tab:green"

    def __init__(
        self,
        *,
        chunk_size: int = 50,
        backbone: str = "resnet18",
        d_model: int = 256,
        n_heads: int = 8,
        dim_feedforward: int = 1024,
        dropout: float = 0.1,
        n_encoder_layers: int = 4,
        n_decoder_layers: int = 1,
        use_vae: bool = True,
        latent_dim: int = 32,
        n_vae_layers: int = 4,
        kl_weight: float = 10.0,
        ensemble_m: float | None = 0.01,
        query_every: int = 1,
        max_grid: int = 8,
        **common,
    ) -> None:
        check_sizes(
            "ACTPolicy",
            d_model=d_model,
            n_heads=n_heads,
            dim_feedforward=dim_feedforward,
            n_encoder_layers=n_encoder_layers,
            n_decoder_layers=n_decoder_layers,
            latent_dim=latent_dim,
            n_vae_layers=n_vae_layers,
            max_grid=max_grid,
        )
        super().__init__(chunk_size=chunk_size, **common)
        if d_model % 4 or d_model % n_heads:
            raise ValueError(
                f"ACTPolicy.d_model: expected a multiple of 4 and of n_heads={n_heads}, got {d_model}"
            )
        if not kl_weight >= 0:
            raise ValueError(f"ACTPolicy.kl_weight: expected a number >= 0, got {kl_weight}")
        if not (isinstance(query_every, int) and query_every >= 1):
            raise ValueError(f"ACTPolicy.query_every: expected an int >= 1, got {query_every!r}")
        n = self.hparams.n_joints
        self.backbone = ImageBackbone(backbone, self.input_channels, self.hparams.channels, norm="batch")
        self.input_proj = nn.Conv2d(self.backbone.out_channels, d_model, kernel_size=1)
        self.joints_proj = nn.Linear(n, d_model)
        self.latent_proj = nn.Linear(latent_dim, d_model)
        self.token_pos = nn.Parameter(torch.zeros(2, d_model))  # latent, joints
        nn.init.normal_(self.token_pos, std=0.02)
        self.transformer_encoder = _encoder(d_model, n_heads, dim_feedforward, n_encoder_layers, dropout)
        layer = nn.TransformerDecoderLayer(d_model, n_heads, dim_feedforward, dropout, batch_first=True)
        self.transformer_decoder = nn.TransformerDecoder(layer, n_decoder_layers)
        self.queries = nn.Embedding(chunk_size, d_model)
        self.action_head = nn.Linear(d_model, n)
        if use_vae:
            self.vae_cls = nn.Parameter(torch.zeros(1, 1, d_model))
            self.vae_joints_proj = nn.Linear(n, d_model)
            self.vae_action_proj = nn.Linear(n, d_model)
            self.vae_encoder = _encoder(d_model, n_heads, dim_feedforward, n_vae_layers, dropout)
            self.vae_out = nn.Linear(d_model, 2 * latent_dim)
            self.register_buffer(
                "vae_pos", sinusoidal_embedding(torch.arange(chunk_size + 2), d_model), persistent=False
            )
        self.replan_every = query_every if ensemble_m is not None else None
        self.ensemble_m = ensemble_m

    # ------------------------------------------------------------------ network
    def posterior(self, joints_n: torch.Tensor, chunk_n: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """CVAE encoder: normalised joints ``(B, n)`` and chunk ``(B, k, n)`` -> mean and
        log-variance ``(B, latent_dim)`` of ``q(z | chunk, joints)``."""
        b = joints_n.shape[0]
        tokens = torch.cat(
            [
                self.vae_cls.expand(b, -1, -1),
                self.vae_joints_proj(joints_n)[:, None],
                self.vae_action_proj(chunk_n),
            ],
            dim=1,
        )
        out = self.vae_encoder(tokens + self.vae_pos[: tokens.shape[1]])[:, 0]
        mu, logvar = self.vae_out(out).chunk(2, dim=-1)
        return mu, logvar

    def decode(self, image: torch.Tensor, joints_n: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        """Images ``(B, C, H, W)``, normalised joints ``(B, n)``, latent ``(B, latent_dim)`` ->
        normalised chunk ``(B, k, n)``."""
        features = self.backbone(self.scene_image(image))
        g = self.hparams.max_grid
        if features.shape[-2] > g or features.shape[-1] > g:
            features = F.adaptive_avg_pool2d(
                features, (min(g, features.shape[-2]), min(g, features.shape[-1]))
            )
        maps = self.input_proj(features)  # (B, d, h, w)
        b, d, h, w = maps.shape
        image_tokens = maps.flatten(2).transpose(1, 2) + grid_embedding(h, w, d).to(maps)
        first = torch.stack([self.latent_proj(z), self.joints_proj(joints_n)], dim=1) + self.token_pos
        memory = self.transformer_encoder(torch.cat([first, image_tokens], dim=1))
        queries = self.queries.weight.expand(b, -1, -1)
        return self.action_head(self.transformer_decoder(queries, memory))

    def predict_chunk(self, image: torch.Tensor, joints: torch.Tensor) -> torch.Tensor:
        joints_n = self.normalise("joints", joints)
        z = torch.zeros(joints.shape[0], self.hparams.latent_dim, device=joints.device)
        return self.denormalise("joints", self.decode(image, joints_n, z))

    def losses(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        joints_n = self.normalise("joints", self.input_joints(batch))
        target_n = self.normalise("joints", self.chunk_targets(batch))
        b = joints_n.shape[0]
        if self.hparams.use_vae:
            mu, logvar = self.posterior(joints_n, target_n)
            z = mu + (0.5 * logvar).exp() * torch.randn_like(mu)
            kl = (-0.5 * (1 + logvar - mu**2 - logvar.exp())).sum(-1).mean()
        else:
            z = torch.zeros(b, self.hparams.latent_dim, device=joints_n.device)
            kl = torch.zeros((), device=joints_n.device)
        pred_n = self.decode(batch["image"], joints_n, z)
        l1 = F.l1_loss(pred_n, target_n)
        err = (self.denormalise("joints", pred_n) - self.chunk_targets(batch)).abs().mean()
        return {"loss": l1 + self.hparams.kl_weight * kl, "l1": l1, "kl": kl, "chunk_abs_err_rad": err}
