"""Diffusion Policy without data: shapes, a one-batch overfit, the closed-loop entry point."""

import functools

import numpy as np
import pytest
import torch
from _chunk_batches import chunk_batch

from lfd.visuomotor.policies import DiffusionPolicy
from lfd.visuomotor.policies.control import ChunkController
from lfd.visuomotor.policies.diffusion_unet import ConditionalUnet1D

TINY = dict(
    image_size=32,
    n_steps=12,
    duration=1.1,
    backbone="trunk",
    channels=[4, 4, 8],
    horizon=8,
    n_action_steps=4,
    down_dims=[16, 32],
    n_keypoints=8,
    image_feature_dim=16,
    step_embed_dim=16,
    n_inference_steps=5,
)


batch = functools.partial(chunk_batch, k=8)


@pytest.mark.parametrize("backbone", ["trunk", "resnet18"])
def test_diffusion_shapes(backbone):
    torch.manual_seed(0)
    policy = DiffusionPolicy(**{**TINY, "backbone": backbone})
    b = batch()
    assert policy.condition(b["image"], b["joints"]).shape == (4, 16 + 7)
    assert policy.predict_chunk(b["image"], b["joints"]).shape == (4, 8, 7)
    assert policy.losses(b)["loss"].ndim == 0
    if backbone == "resnet18":  # the paper's: group norm instead of batch norm
        assert not any(isinstance(m, torch.nn.BatchNorm2d) for m in policy.backbone.modules())


def test_unet_keeps_the_sequence_shape_and_uses_its_condition():
    torch.manual_seed(0)
    net = ConditionalUnet1D(7, 5, down_dims=[16, 32, 64], step_embed_dim=16)
    x, t = torch.randn(2, 16, 7), torch.tensor([3, 50])
    out = net(x, t, torch.zeros(2, 5))
    assert out.shape == (2, 16, 7)
    assert not torch.allclose(out, net(x, t, torch.ones(2, 5)))  # FiLM: the condition matters
    assert not torch.allclose(out, net(x, torch.tensor([60, 10]), torch.zeros(2, 5)))  # so does the step
    with pytest.raises(ValueError, match="not divisible"):
        net(torch.randn(2, 6, 7), t, torch.zeros(2, 5))


@pytest.mark.parametrize("prediction", ["epsilon", "sample"])
def test_diffusion_overfits_one_batch(prediction):
    """The batch is the items with their diffusion steps and noise draws (the same generator
    state at every step): the noise- (or sample-) prediction loss drops by a large factor."""
    torch.manual_seed(0)
    policy = DiffusionPolicy(**TINY, prediction=prediction)
    b = batch()
    opt = torch.optim.Adam(policy.parameters(), lr=3e-3)
    history = []
    for _ in range(60):
        torch.manual_seed(7)
        loss = policy.losses(b)["loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()
        history.append(loss.item())
    assert history[-1] < history[0] / 10


def test_diffusion_closed_loop_interface():
    """A query every n_action_steps (receding horizon), chunks in rad from uint8 frames."""
    policy = DiffusionPolicy(**TINY)
    frame = np.zeros((32, 32, 3), dtype=np.uint8)
    torch.manual_seed(0)
    chunk = policy.act_chunk(frame, np.zeros(7))
    assert chunk.shape == (8, 7) and chunk.dtype == np.float64 and np.all(np.isfinite(chunk))
    # with the predicted x0 clipped at clip_sample, samples stay within that many std of the joints' mean
    assert np.all(np.abs(chunk) <= 5.0 + 1e-6)  # mean 0, std 1 before setup
    ctl = policy.controller(0.1)
    assert isinstance(ctl, ChunkController) and ctl.replan_every == 4 and ctl.ensemble_m is None


def test_diffusion_bad_settings():
    with pytest.raises(ValueError, match="n_action_steps"):
        DiffusionPolicy(**{**TINY, "n_action_steps": 9})
    with pytest.raises(ValueError, match="horizon"):
        DiffusionPolicy(**{**TINY, "horizon": 7, "n_action_steps": 4})
    with pytest.raises(ValueError, match="n_steps: expected an int in 1..100"):
        DiffusionPolicy(**{**TINY, "n_inference_steps": 0})
    with pytest.raises(ValueError, match="down_dims"):
        DiffusionPolicy(**{**TINY, "down_dims": [12, 32]})


def test_state_noise_perturbs_the_condition_in_training_only():
    torch.manual_seed(0)
    policy = DiffusionPolicy(**{**TINY, "state_noise": 0.2})
    b = batch(b=256)
    seen, condition = [], policy.condition
    policy.condition = lambda image, joints: seen.append(joints) or condition(image, joints)
    policy.train()
    policy.losses(b)
    offset = seen[-1] - b["joints"]
    assert abs(float(offset.std()) - 0.2) < 0.02
    policy.eval()
    policy.losses(b)
    torch.testing.assert_close(seen[-1], b["joints"])
