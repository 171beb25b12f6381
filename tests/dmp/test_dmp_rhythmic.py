"""Rhythmic DMP: periodic reproduction, amplitude, tempo, anchor, persistence, errors."""

import math

import numpy as np
import pytest

from lfd.dmp import DMP, RhythmicDMP

PERIOD = 2.0


def signal(t):
    """Sum of sines with period 2 s, two DoF: ``(T, 2)``."""
    w = 2 * np.pi / PERIOD
    return np.stack(
        [np.sin(w * t) + 0.3 * np.sin(3 * w * t), 0.5 * np.cos(w * t) + 0.2 * np.sin(2 * w * t + 1.0) + 1.0],
        -1,
    )


@pytest.mark.parametrize(("method", "overlap", "tolerance"), [("trajectory", 0.8, 1e-4), ("lwr", 0.1, 5e-2)])
def test_reproduces_one_period_and_keeps_oscillating(method, overlap, tolerance):
    t = np.linspace(0, PERIOD, 201)
    dmp = RhythmicDMP(n_basis=30, overlap=overlap).fit(t, signal(t), method=method)
    assert dmp.period_ == pytest.approx(PERIOD) and dmp.tau_ == pytest.approx(PERIOD / (2 * math.pi))
    np.testing.assert_allclose(dmp.goal_, [0.0, 1.0], atol=1e-3)  # anchor = mean over the period
    out = dmp.rollout()
    amplitude = np.ptp(signal(t), axis=0).max()
    assert np.sqrt(np.mean((out - signal(t)) ** 2)) < tolerance * amplitude
    later = np.linspace(0, 4 * PERIOD, 801)  # beyond the demonstration: stays on the cycle
    assert np.abs(dmp.rollout(t=later) - signal(later)).max() < 5 * tolerance * amplitude


def test_amplitude_scales_the_oscillation_about_the_anchor():
    t = np.linspace(0, PERIOD, 151)
    dmp = RhythmicDMP(20).fit(t, signal(t))
    base = dmp.rollout()
    for r in (2.0, 0.5, 0.0):
        np.testing.assert_allclose(dmp.rollout(r=r), dmp.goal_ + r * (base - dmp.goal_), atol=1e-12)
    # from an arbitrary start, transients die out and the steady cycle still scales with r
    t_long = np.linspace(0, 4 * PERIOD, 401)
    start = dict(t=t_long, y0=np.zeros(2), yd0=np.zeros(2))
    last_period = slice(300, None)
    np.testing.assert_allclose(
        (dmp.rollout(r=2.0, **start) - dmp.goal_)[last_period],
        2 * (dmp.rollout(r=1.0, **start) - dmp.goal_)[last_period],
        atol=1e-6,
    )


def test_tempo_and_anchor_generalise():
    t = np.linspace(0, PERIOD, 151)
    dmp = RhythmicDMP(20).fit(t, signal(t))
    slow = dmp.rollout(tau=2 * dmp.tau_)  # default grid stretches with tau: same samples
    np.testing.assert_allclose(slow, dmp.rollout(), atol=1e-12)
    np.testing.assert_allclose(dmp.rollout(t=2 * t, tau=2 * dmp.tau_), dmp.rollout(t=t), atol=1e-12)
    shifted = dmp.rollout(goal=dmp.goal_ + [1.0, -2.0])
    np.testing.assert_allclose(shifted, dmp.rollout() + [1.0, -2.0], atol=1e-12)
    starts = np.stack([dmp.yd0_, 0 * dmp.yd0_, 2 * dmp.yd0_])  # a batch of start velocities only
    batch = dmp.rollout(yd0=starts)
    assert batch.shape == (3, 151, 2)
    np.testing.assert_allclose(batch[0], dmp.rollout(), atol=1e-12)


def test_explicit_period_and_batch():
    t = np.arange(200) * PERIOD / 200  # one period, end point excluded
    batch = np.stack([signal(t), 2 * signal(t)])
    dmp = RhythmicDMP(25).fit(t, batch, period=PERIOD)
    assert dmp.weights_.shape == (2, 2, 25) and dmp.period_ == pytest.approx(PERIOD)
    out = dmp.rollout()
    assert out.shape == (2, 200, 2)
    assert np.sqrt(np.mean((out - batch) ** 2)) < 1e-3
    single = RhythmicDMP(25).fit(t, batch[1], period=PERIOD)
    np.testing.assert_allclose(single.weights_, dmp.weights_[1], rtol=1e-9, atol=1e-9)


def test_save_load_round_trip(tmp_path):
    t = np.linspace(0, PERIOD, 101)
    dmp = RhythmicDMP(12, alpha_z=30.0, overlap=0.5).fit(t, signal(t))
    dmp.save(tmp_path / "wave.json")
    loaded = RhythmicDMP.load(tmp_path / "wave.json")
    assert repr(loaded) == repr(dmp)
    for name in ("weights_", "y0_", "yd0_", "goal_"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(dmp, name))
    np.testing.assert_array_equal(loaded.rollout(r=1.5), dmp.rollout(r=1.5))
    with pytest.raises(ValueError, match="does not hold"):
        DMP.load(tmp_path / "wave.json")


def test_rejects_bad_arguments():
    t = np.linspace(0, PERIOD, 50)
    with pytest.raises(ValueError, match="period"):
        RhythmicDMP().fit(t, signal(t), period=-1.0)
    with pytest.raises(ValueError, match="method"):
        RhythmicDMP().fit(t, signal(t), method="fourier")
    with pytest.raises(ValueError, match="strictly increasing"):
        RhythmicDMP().fit(t[::-1], signal(t))
    dmp = RhythmicDMP(8).fit(t, signal(t))
    for kwargs, message in [
        (dict(r=np.nan), "r must be"),
        (dict(tau=0.0), "tau"),
        (dict(weights=np.zeros((2, 9))), "K = 8"),
        (dict(weights=np.zeros(8)), "weights must have shape"),
        (dict(yd0=np.zeros(3)), r"yd0 must have shape \(2,\)"),
        (dict(goal=np.zeros(3)), r"goal must have shape \(2,\)"),
    ]:
        with pytest.raises(ValueError, match=message):
            dmp.rollout(**kwargs)
    with pytest.raises(ValueError, match="not fitted"):
        RhythmicDMP().rollout()


def test_rollout_accepts_the_keywords_of_the_discrete_rollout_and_tensors():
    import inspect

    import torch

    discrete = list(inspect.signature(DMP.rollout).parameters)
    rhythmic = list(inspect.signature(RhythmicDMP.rollout).parameters)
    shared = [name for name in discrete if name != "coupling"]  # coupling terms are discrete-only
    assert rhythmic[: len(shared)] == shared  # same names, same order
    t = np.linspace(0, PERIOD, 121)
    dmp = RhythmicDMP(15).fit(t, signal(t))
    positional = dmp.rollout(t, dmp.y0_, dmp.goal_, dmp.tau_, dmp.weights_, False, dmp.yd0_)
    np.testing.assert_allclose(positional, dmp.rollout(), atol=1e-12)
    y, yd, ydd = dmp.rollout(return_derivatives=True)
    assert y.shape == yd.shape == ydd.shape == (121, 2)
    weights = torch.tensor(dmp.weights_, requires_grad=True)
    tau = torch.tensor(dmp.tau_, dtype=torch.float64, requires_grad=True)
    out = dmp.rollout(t=t, tau=tau, weights=weights)
    assert isinstance(out, torch.Tensor)
    np.testing.assert_allclose(out.detach().numpy(), dmp.rollout(t=t), atol=1e-10)
    out.sum().backward()
    assert weights.grad.abs().sum() > 0 and tau.grad.abs() > 0
    taus = torch.tensor([dmp.tau_, 2 * dmp.tau_], dtype=torch.float64)
    per_sample = dmp.rollout(t=t, tau=taus)
    np.testing.assert_allclose(per_sample[1].numpy(), dmp.rollout(t=t, tau=2 * dmp.tau_), atol=1e-9)
