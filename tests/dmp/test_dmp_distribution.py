"""DMP weight distribution: closed-form propagation vs sigma points, Monte Carlo and the demonstrations."""

from __future__ import annotations

import numpy as np
import pytest
from dmp_helpers import lasa_demo

from lfd.dmp import DMP, DMPDistribution


def demos(rng, n_demos=10, n_steps=150, n_dims=2, duration=1.5):
    """``(t (T,), Y (N, T, D))``: minimum-jerk strokes with random start, amplitude and bump."""
    t = np.linspace(0.0, duration, n_steps)
    s = t / duration
    min_jerk = (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None]
    start = 0.1 * rng.normal(size=(n_demos, 1, n_dims))
    stroke = 1.0 + 0.2 * rng.normal(size=(n_demos, 1, n_dims))
    bump = 0.3 * rng.normal(size=(n_demos, 1, n_dims)) * np.sin(np.pi * s)[:, None]
    return t, start + stroke * min_jerk + bump


def sigma_point_moments(dist, t):
    """Mean and covariance of rollouts of the ``2 r`` symmetric sigma points (exact for a linear map)."""
    values, vectors = np.linalg.eigh(dist.cov_)
    factor = vectors * np.sqrt(np.clip(values, 0.0, None))
    points = np.concatenate([dist.mean_ + factor.T, dist.mean_ - factor.T])
    rolled = dist.rollout_params(points, t)
    mean = rolled.mean(axis=0)
    centred = rolled - mean
    return mean, np.einsum("ntd,nue->tdue", centred, centred) / 2


def test_closed_form_equals_sigma_point_propagation():
    t, Y = demos(np.random.default_rng(0))
    dist = DMPDistribution(n_basis=10).fit(t, Y)
    mean, cov = dist.propagate(t)
    ref_mean, ref_cov = sigma_point_moments(dist, t)
    assert mean.shape == (150, 2) and cov.shape == (150, 2, 150, 2)
    np.testing.assert_allclose(mean, ref_mean, atol=1e-10)
    # rounding: the weights' covariance is ~1e8 times the positions' (cancellation in the map)
    np.testing.assert_allclose(cov, ref_cov, atol=1e-7 * np.abs(cov).max())


def test_closed_form_equals_the_spread_of_the_demonstrations_reproductions():
    """cov_reg = 0: the propagated covariance is the sample covariance of the per-demo DMP rollouts."""
    t, Y = demos(np.random.default_rng(1))
    dist = DMPDistribution(n_basis=15).fit(t, Y)
    reproductions = np.stack([DMP(n_basis=15).fit(t, y).rollout(t) for y in Y])
    mean, cov = dist.propagate(t)
    np.testing.assert_allclose(mean, reproductions.mean(axis=0), atol=1e-9)
    centred = reproductions - reproductions.mean(axis=0)
    expected = np.einsum("ntd,nue->tdue", centred, centred) / (len(Y) - 1)
    np.testing.assert_allclose(cov, expected, atol=1e-8 * np.abs(cov).max())
    np.testing.assert_allclose(dist.var_trajectory(t), Y.var(axis=0, ddof=1), atol=0.02 * Y.var(axis=0).max())


def test_monte_carlo_rollouts_agree_with_the_closed_form():
    t, Y = demos(np.random.default_rng(2), n_dims=3)
    dist = DMPDistribution(n_basis=10, cov_reg=0.01).fit(t, Y)
    mean, _ = dist.propagate(t)
    var = dist.var_trajectory(t)
    samples = dist.sample_trajectories(20000, t, rng=3)
    assert np.all(np.abs(samples.mean(axis=0) - mean) <= 5 * np.sqrt(var / 20000) + 1e-12)
    np.testing.assert_allclose(samples.var(axis=0), var, rtol=0.06, atol=1e-10)


@pytest.mark.parametrize("formulation", ["pastor", "ijspeert"])
def test_fixed_start_and_goal_uses_the_weight_distribution(formulation):
    t, Y = demos(np.random.default_rng(4))
    dist = DMPDistribution(n_basis=10, formulation=formulation).fit(t, Y)
    y0, goal = np.array([0.2, -0.1]), np.array([1.5, 0.8])
    mean, cov = dist.propagate(t, y0=y0, goal=goal)
    np.testing.assert_allclose(mean[0], y0, atol=1e-12)
    assert np.abs(mean[-1] - goal).max() < 0.02
    rng = np.random.default_rng(5)
    weights = rng.multivariate_normal(
        dist.weights_mean_.reshape(-1), dist.weights_cov_, size=4000, method="eigh", check_valid="ignore"
    )
    rolled = DMP(n_basis=10, formulation=formulation).rollout(
        t=t, y0=y0, goal=goal, tau=dist.tau_, weights=weights.reshape(4000, 2, 10)
    )
    var = cov[np.arange(150), :, np.arange(150), :].diagonal(axis1=1, axis2=2)
    assert np.all(np.abs(rolled.mean(axis=0) - mean) <= 5 * np.sqrt(var / 4000) + 1e-12)
    np.testing.assert_allclose(rolled.var(axis=0), var, rtol=0.15, atol=1e-10)


def test_demonstrations_of_different_durations_and_temporal_scaling():
    """LASA demonstrations (different durations): one DMP per demonstration, weights in normalised time."""
    ts, ys = [], []
    for index in range(7):
        t, y = lasa_demo("Angle", index)
        ts.append(t[::10])
        ys.append(y[::10])
    dist = DMPDistribution(n_basis=20).fit(ts, ys)
    assert dist.tau_ == pytest.approx(np.mean([t[-1] for t in ts]))
    for i, (t, y) in enumerate(zip(ts, ys)):
        single = DMP(n_basis=20).fit(t, y)
        np.testing.assert_allclose(dist.params_[i].reshape(2, 22)[:, 2:], single.weights_, atol=1e-9)
    mean, _ = dist.propagate()
    slow, _ = dist.propagate(t=np.linspace(0.0, 2 * dist.tau_, dist.n_steps_), tau=2 * dist.tau_)
    np.testing.assert_allclose(slow, mean, atol=1e-6 * np.ptp(mean))  # same path, twice as slow
    np.testing.assert_allclose(mean[0], np.mean([y[0] for y in ys], axis=0), atol=1e-9)


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: DMPDistribution(cov_reg=-1.0), "cov_reg"),
        (lambda: DMPDistribution(n_basis=0), "n_basis"),
        (lambda: DMPDistribution().fit(np.linspace(0, 1, 10), np.zeros((3, 8, 2))), "Y"),
        (lambda: DMPDistribution().fit(np.linspace(0, 1, 10), np.full((3, 10, 2), np.inf)), "NaN or inf"),
        (lambda: DMPDistribution().propagate(), "not fitted"),
        (lambda: fitted().propagate(tau=0.0), "tau"),
        (lambda: fitted().propagate(y0=[0.0, 0.0, 0.0], goal=[1.0, 1.0]), "y0 and goal"),
        (lambda: fitted().rollout_params(np.zeros((2, 5))), "params"),
        (
            lambda: (
                DMPDistribution(formulation="ijspeert").fit(*demos(np.random.default_rng(0))).linear_map()
            ),
            "pastor",
        ),
    ],
)
def test_bad_input_is_one_clear_value_error(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def fitted() -> DMPDistribution:
    return DMPDistribution(n_basis=5).fit(*demos(np.random.default_rng(9), n_steps=40))
