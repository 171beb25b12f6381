"""The Diffusion Policy's DDPM schedule and DDIM sampler against hand computations."""

import math

import pytest
import torch

from lfd.visuomotor.policies.noise_schedule import NoiseSchedule, betas_for


def test_squared_cosine_betas_by_hand():
    """T = 2: abar(s) = cos((s + 0.008) / 1.008 * pi / 2)^2 at s = 0, 1/2, 1; beta_1 capped at 0.999."""

    def abar(s):
        return math.cos((s + 0.008) / 1.008 * math.pi / 2) ** 2

    betas = betas_for("squaredcos_cap_v2", 2)
    assert betas[0].item() == pytest.approx(1 - abar(0.5) / abar(0.0), rel=1e-12)
    assert betas[1].item() == pytest.approx(0.999)  # 1 - abar(1) / abar(1/2) = 1 - ~1e-5 > cap
    schedule = NoiseSchedule(2)
    expected = torch.tensor([1 - betas[0].item(), (1 - betas[0].item()) * (1 - 0.999)])
    torch.testing.assert_close(schedule.alphas_cumprod, expected.float())


def test_add_noise_is_the_ddpm_forward_process():
    s = NoiseSchedule(10)
    x0, eps = torch.randn(3, 4, 2), torch.randn(3, 4, 2)
    t = torch.tensor([0, 4, 9])
    a = s.alphas_cumprod[t]
    for i in range(3):
        expected = a[i].sqrt() * x0[i] + (1 - a[i]).sqrt() * eps[i]
        torch.testing.assert_close(s.add_noise(x0, eps, t)[i], expected)


def test_ddim_timesteps_use_leading_spacing():
    s = NoiseSchedule(100)
    assert s.timesteps(10) == [90, 80, 70, 60, 50, 40, 30, 20, 10, 0]
    assert s.timesteps(1) == [0]
    with pytest.raises(ValueError, match="n_steps"):
        s.timesteps(101)


def test_one_ddim_step_by_hand():
    """x_prev = sqrt(a_prev) x0_hat + sqrt(1 - a_prev) eps, x0_hat = (x - sqrt(1 - a_t) eps) / sqrt(a_t)."""
    s = NoiseSchedule(4, schedule="linear")
    betas = torch.linspace(1e-4, 0.02, 4, dtype=torch.float64)
    a = torch.cumprod(1 - betas, 0)
    x, eps = torch.tensor([[0.7, -1.2]]), torch.tensor([[0.3, 0.5]])
    x0 = (x.double() - (1 - a[3]).sqrt() * eps.double()) / a[3].sqrt()
    expected = a[1].sqrt() * x0 + (1 - a[1]).sqrt() * eps.double()
    torch.testing.assert_close(s.ddim_step(eps, 3, x, 1), expected.float())
    # the last step goes to x0 itself (alpha_prev = 1)
    torch.testing.assert_close(s.ddim_step(eps, 3, x, -1), x0.float())


@pytest.mark.parametrize("n_steps", [1, 3, 10, 100])
def test_ddim_with_the_perfect_noise_predictor_recovers_x0(n_steps):
    """With eps(x_t, t) = (x_t - sqrt(a_t) x0) / sqrt(1 - a_t), DDIM lands on x0 from any noise."""
    s = NoiseSchedule(100)
    g = torch.Generator().manual_seed(0)
    x0 = torch.randn(2, 16, 7, generator=g, dtype=torch.float64)
    a = s.alphas_cumprod.double()

    def perfect(x, t):
        at = a[t].reshape(-1, 1, 1)
        return (x - at.sqrt() * x0) / (1 - at).sqrt()

    s.alphas_cumprod = a  # float64 for the comparison
    out = s.sample(perfect, torch.randn(2, 16, 7, generator=g, dtype=torch.float64), n_steps)
    torch.testing.assert_close(out, x0, atol=1e-9, rtol=0)


@pytest.mark.parametrize("n_steps", [1, 3, 10, 100])
def test_ddim_with_the_perfect_sample_predictor_recovers_x0(n_steps):
    """prediction="sample": the network gives x0 itself; the DDIM step derives the noise from it."""
    s = NoiseSchedule(100, prediction="sample")
    g = torch.Generator().manual_seed(0)
    x0 = torch.randn(2, 16, 7, generator=g, dtype=torch.float64)
    s.alphas_cumprod = s.alphas_cumprod.double()
    out = s.sample(lambda x, t: x0, torch.randn(2, 16, 7, generator=g, dtype=torch.float64), n_steps)
    torch.testing.assert_close(out, x0, atol=1e-9, rtol=0)
    # one step by hand: x_prev = sqrt(a_prev) x0 + sqrt(1 - a_prev) (x - sqrt(a) x0) / sqrt(1 - a)
    a = s.alphas_cumprod
    x = torch.randn(2, 16, 7, generator=g, dtype=torch.float64)
    expected = a[40].sqrt() * x0 + (1 - a[40]).sqrt() * (x - a[70].sqrt() * x0) / (1 - a[70]).sqrt()
    torch.testing.assert_close(s.ddim_step(x0, 70, x, 40), expected)
    noise = torch.randn_like(x0)
    assert s.target(x0, noise) is x0 and NoiseSchedule(10).target(x0, noise) is noise
    with pytest.raises(ValueError, match="prediction: expected one of"):
        NoiseSchedule(10, prediction="v_prediction")


def test_clip_sample_bounds_the_predicted_x0():
    s = NoiseSchedule(10, clip_sample=1.0)
    out = s.ddim_step(torch.zeros(1, 3), 5, torch.full((1, 3), 100.0), -1)
    torch.testing.assert_close(out, torch.ones(1, 3))
    with pytest.raises(ValueError, match="clip_sample"):
        NoiseSchedule(10, clip_sample=0.0)
    with pytest.raises(ValueError, match="expected one of"):
        NoiseSchedule(10, schedule="cosine")
