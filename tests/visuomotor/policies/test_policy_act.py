"""ACT without data: shapes, the CVAE objective, a one-batch overfit, the closed-loop entry point."""

import functools
import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from _chunk_batches import chunk_batch

from lfd.visuomotor.policies import ACTPolicy
from lfd.visuomotor.policies.backbones import ImageBackbone, grid_embedding, sinusoidal_embedding
from lfd.visuomotor.policies.control import ChunkController

TINY = dict(
    image_size=32,
    n_steps=12,
    duration=1.1,
    backbone="trunk",
    channels=[4, 4, 8],
    chunk_size=5,
    d_model=32,
    n_heads=4,
    dim_feedforward=64,
    n_encoder_layers=1,
    n_vae_layers=1,
    latent_dim=8,
)


batch = functools.partial(chunk_batch, k=5)


@pytest.mark.parametrize("backbone", ["trunk", "resnet18"])
def test_act_shapes(backbone):
    torch.manual_seed(0)
    policy = ACTPolicy(**{**TINY, "backbone": backbone})
    b = batch()
    assert policy.predict_chunk(b["image"], b["joints"]).shape == (4, 5, 7)
    losses = policy.losses(b)
    assert set(losses) == {"loss", "l1", "kl", "chunk_abs_err_rad"}
    torch.testing.assert_close(losses["loss"], losses["l1"] + 10.0 * losses["kl"])
    assert losses["kl"] > 0
    policy.eval()
    with torch.no_grad():  # at inference z = 0: deterministic
        torch.testing.assert_close(
            policy.predict_chunk(b["image"], b["joints"]), policy.predict_chunk(b["image"], b["joints"])
        )


def test_act_without_vae_has_no_latent_encoder():
    policy = ACTPolicy(**{**TINY, "use_vae": False})
    assert not hasattr(policy, "vae_encoder")
    assert policy.losses(batch())["kl"] == 0


def test_act_overfits_one_batch():
    torch.manual_seed(0)
    policy = ACTPolicy(**{**TINY, "dropout": 0.0})
    b = batch()

    def chunk_error():
        policy.eval()
        with torch.no_grad():
            err = (policy.predict_chunk(b["image"], b["joints"]) - b["chunk"]).abs().mean()
        policy.train()
        return err

    before = chunk_error()
    opt = torch.optim.Adam(policy.parameters(), lr=3e-3)
    first = None
    for _ in range(60):
        losses = policy.losses(b)
        opt.zero_grad()
        losses["loss"].backward()
        opt.step()
        first = losses["loss"].item() if first is None else first
    assert losses["loss"].item() < first / 50
    assert chunk_error() < before / 5  # the predicted chunk (z = 0) too


def test_act_closed_loop_interface():
    """A query every step with ensembling (the paper's default), chunks in rad from uint8 frames."""
    policy = ACTPolicy(**TINY)
    frame = np.zeros((32, 32, 3), dtype=np.uint8)
    chunk = policy.act_chunk(frame, np.zeros(7))
    assert chunk.shape == (5, 7) and chunk.dtype == np.float64 and np.all(np.isfinite(chunk))
    assert policy.act_chunk(np.stack([frame] * 2), np.zeros((2, 7))).shape == (2, 5, 7)
    ctl = policy.controller(0.1)
    assert isinstance(ctl, ChunkController) and ctl.replan_every == 1 and ctl.ensemble_m == 0.01
    assert policy.controller(0.1).needs_image
    plain = ACTPolicy(**{**TINY, "ensemble_m": None}).controller(0.1)
    assert plain.ensemble_m is None and plain.replan_every is None  # a query every chunk
    with pytest.raises(ValueError, match="trained on 32x32"):
        policy.act_chunk(np.zeros((24, 24, 3), np.uint8), np.zeros(7))
    with pytest.raises(ValueError, match="colour_tta"):
        policy.colour_tta = True
    fig = policy.sample_figure(batch(k=5))  # the validation plot: predicted chunk vs target
    assert fig.axes


def test_set_execution_changes_how_the_controller_queries():
    """``set_execution`` (the evaluator's ``chunk_execution`` ablation): chunks executed to their end
    query once per chunk; a query every 2 steps without ensembling queries ceil(steps / 2) times."""
    policy = ACTPolicy(**TINY)
    frame, q = np.zeros((32, 32, 3), dtype=np.uint8), np.zeros(7)

    def queries(steps: int) -> int:
        ctl, latencies = policy.controller(0.1), []
        ctl.start(steps)
        for step in range(steps):
            ctl.command(SimpleNamespace(image=frame, joints=q), step, latencies)
        return len(latencies)

    assert queries(12) == 12  # the paper's: a query every step, ensembled
    policy.set_execution(replan_every=None, ensemble_m=None)
    assert queries(12) == 3 and policy.controller(0.1).ensemble_m is None  # chunk_size 5: steps 0, 5, 10
    policy.set_execution(replan_every=2, ensemble_m=0.5)
    ctl = policy.controller(0.1)
    assert (ctl.replan_every, ctl.ensemble_m) == (2, 0.5) and queries(7) == 4
    policy.set_execution(replan_every=4)  # ensemble_m left out: kept
    assert policy.execution == {"replan_every": 4, "ensemble_m": 0.5}
    for bad, match in [
        (dict(replan_every=6), r"replan_every: expected an int in 1..chunk_size=5"),
        (dict(replan_every=True), "replan_every"),
        (dict(ensemble_m=-1.0), "ensemble_m: expected a number >= 0"),
        (dict(ensemble_m=float("nan")), "ensemble_m"),
        (dict(ensemble_m=True), "ensemble_m"),
    ]:
        with pytest.raises(ValueError, match=match):
            policy.set_execution(**bad)


def test_act_bad_settings():
    with pytest.raises(ValueError, match="chunk_size"):
        ACTPolicy(**{**TINY, "chunk_size": 0})
    with pytest.raises(ValueError, match="d_model"):
        ACTPolicy(**{**TINY, "d_model": 30})
    with pytest.raises(ValueError, match="ImageBackbone.name"):
        ACTPolicy(**{**TINY, "backbone": "vit"})
    with pytest.raises(ValueError, match="aux_weight"):
        ACTPolicy(**{**TINY, "aux_weight": 1.0})
    with pytest.raises(ValueError, match="'index' and 'step'"):
        ACTPolicy(**TINY).losses({k: v for k, v in batch().items() if k != "chunk"})
    with pytest.raises(ValueError, match="state_noise: expected a number >= 0"):
        ACTPolicy(**{**TINY, "state_noise": -0.1})


def test_state_noise_perturbs_the_training_joints_only():
    """With ``state_noise`` the training loss conditions the decoder (and the CVAE encoder) on
    joints + N(0, sigma^2) against the unchanged demonstrated chunk; validation and the closed
    loop see the measured joints."""
    torch.manual_seed(0)
    policy = ACTPolicy(**{**TINY, "state_noise": 0.2})
    b = batch(b=256)
    seen, decode = [], policy.decode
    policy.decode = lambda image, joints_n, z: seen.append(joints_n) or decode(image, joints_n, z)
    policy.train()
    policy.losses(b)
    offset = policy.denormalise("joints", seen[-1]) - b["joints"]
    assert abs(float(offset.std()) - 0.2) < 0.02 and abs(float(offset.mean())) < 0.02
    policy.eval()
    policy.losses(b)
    torch.testing.assert_close(policy.denormalise("joints", seen[-1]), b["joints"])
    assert ACTPolicy(**TINY).hparams.state_noise == 0.0  # the paper's: off by default


def test_chunk_targets_read_the_demonstrations_and_hold_the_last_sample():
    policy = ACTPolicy(**TINY)  # n_steps = 12, k = 5

    items = SimpleNamespace(
        tensors={
            "joints": torch.arange(24.0)[:, None].expand(24, 7) * torch.tensor([1.0, 1, 1, 1, 1, 1, -1]),
            "index": torch.tensor([3] * 12 + [5] * 12),
            "step": torch.arange(12).repeat(2),
        }
    )
    policy.set_trajectories([items])
    targets = policy.chunk_targets({"index": torch.tensor([3, 5]), "step": torch.tensor([2, 9])})
    np.testing.assert_array_equal(targets[0, :, 0], [3, 4, 5, 6, 7])
    np.testing.assert_array_equal(targets[1, :, 0], [22, 23, 23, 23, 23])  # episode 5 ends at step 11
    np.testing.assert_array_equal(targets[1, :, 6], [-22, -23, -23, -23, -23])


def test_resnet18_backbone_is_untrained_and_takes_rgbd():
    net = ImageBackbone("resnet18", in_channels=4, norm="group")
    assert net(torch.rand(2, 4, 64, 64)).shape == (2, 512, 2, 2)
    assert any(isinstance(m, torch.nn.GroupNorm) for m in net.modules())
    assert not any(isinstance(m, torch.nn.BatchNorm2d) for m in net.modules())


def test_sine_embeddings_by_hand():
    e = sinusoidal_embedding(torch.tensor([0.0, 2.0]), 4)  # w = 1, 1e-4
    torch.testing.assert_close(
        e[1], torch.tensor([math.sin(2.0), math.sin(2e-4), math.cos(2.0), math.cos(2e-4)])
    )
    g = grid_embedding(2, 3, 8)
    assert g.shape == (6, 8)
    torch.testing.assert_close(g[4, :4], sinusoidal_embedding(torch.tensor(1.0), 4))  # row 1
    torch.testing.assert_close(g[4, 4:], sinusoidal_embedding(torch.tensor(1.0), 4))  # column 1
    torch.testing.assert_close(g[2, 4:], sinusoidal_embedding(torch.tensor(2.0), 4))  # column 2
