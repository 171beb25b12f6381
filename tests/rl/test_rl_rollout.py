"""Batched DMP rollouts used by PoWER agree with the DMP's own rollout."""

import numpy as np
import pytest

from lfd.rl import DMPRollout


def test_batched_rollouts_match_dmp_rollout_per_sample(sawyer_dmp):
    rollout = DMPRollout(sawyer_dmp)
    rng = np.random.default_rng(0)
    weights = sawyer_dmp.weights_ + rng.normal(scale=50.0, size=(4, 7, 20))
    goals = sawyer_dmp.goal_ + rng.normal(scale=0.2, size=(4, 7))
    batch = rollout(weights, goals)
    assert batch.shape == (4, sawyer_dmp.n_steps_, 7)
    for k in range(4):
        expected = sawyer_dmp.rollout(weights=weights[k], goal=goals[k])
        np.testing.assert_allclose(batch[k], expected, atol=1e-9)


def test_custom_grid_and_start(line_dmp):
    t = np.linspace(0.0, 1.5, 40)
    rollout = DMPRollout(line_dmp, t=t, y0=[0.2])
    expected = line_dmp.rollout(t=t, y0=np.array([0.2]), goal=np.array([0.7]))
    np.testing.assert_allclose(rollout(line_dmp.weights_[None], np.array([[0.7]]))[0], expected, atol=1e-9)


def test_weight_scale_bounds_the_effect_of_every_weight(sawyer_dmp):
    rollout = DMPRollout(sawyer_dmp)
    scale = rollout.weight_scale(sawyer_dmp.goal_)
    base = rollout(sawyer_dmp.weights_[None], sawyer_dmp.goal_[None])[0]
    effects = np.zeros((7, 20))
    for i in range(20):
        weights = sawyer_dmp.weights_.copy()
        weights[:, i] += 1.0
        effects[:, i] = np.abs(rollout(weights[None], sawyer_dmp.goal_[None])[0] - base).max(axis=0)
    np.testing.assert_allclose(effects.max(axis=1), scale, rtol=1e-9)
    assert np.all(scale > 0)
    goal = sawyer_dmp.goal_.copy()
    goal[2] = sawyer_dmp.y0_[2]
    # the weights' effect scales with g - y0 only when the forcing term does ("ijspeert")
    assert (rollout.weight_scale(goal)[2] == 0.0) == rollout.goal_scaled


def test_unfitted_dmp_and_bad_shapes_are_rejected(line_dmp):
    from lfd.dmp import DMP

    with pytest.raises(ValueError, match="dmp"):
        DMPRollout(DMP())
    rollout = DMPRollout(line_dmp)
    with pytest.raises(ValueError, match="weights"):
        rollout(np.zeros((2, 1, 19)), np.zeros((2, 1)))
    with pytest.raises(ValueError, match="goal"):
        rollout(np.zeros((2, 1, 20)), np.zeros((3, 1)))
