"""PoWER on DMP weights and goals: convergence to known optima, limits, determinism, validation."""

import numpy as np
import pytest

from lfd.dmp import DMP
from lfd.rl import DMPRollout, JointGoalReward, PowerResult, power


def tracking_problem(dmp, displacement: float, seed: int = 100, base=None):
    """A target trajectory reachable by known weights ``w*`` (goal unchanged) and its reward.

    ``w* = base + delta`` (``base`` defaults to the fitted weights), each weight of ``delta``
    moving the trajectory by at most ``~displacement`` rad (the same weight change for every basis).

    Returns ``(target (T, D), reward, rms_error)``: the reward is
    ``exp(-rms^2 / 0.05^2)`` with ``rms`` the RMS distance (rad) to the target, so the
    optimum (return 1, error 0) is attained exactly at ``w*``.
    """
    rollout = DMPRollout(dmp)
    rng = np.random.default_rng(seed)
    scale = rollout.weight_scale(dmp.goal_)
    delta = rng.normal(size=dmp.weights_.shape) * (displacement / scale)[:, None]
    w_star = (dmp.weights_ if base is None else base) + delta
    target = rollout(w_star[None], dmp.goal_[None])[0]

    def rms_error(trajectories):
        return np.sqrt(np.square(trajectories - target).sum(axis=-1).mean(axis=-1))

    def reward(trajectories):
        return np.exp(-np.square(rms_error(trajectories) / 0.05))

    return target, reward, rms_error


def test_converges_to_known_optimum_one_dof(line_dmp):
    target, reward, rms_error = tracking_problem(line_dmp, displacement=0.2)
    start_error = rms_error(line_dmp.rollout()[None])[0]
    # the target moves every weight by the same amount, which the per-DoF exploration matches
    result = power(line_dmp, reward, error=rms_error, tol=0.005, max_iter=200, seed=1, per_basis=False)
    assert start_error > 0.03
    assert result.converged and result.error <= 0.005
    np.testing.assert_allclose(result.trajectory, line_dmp.rollout(weights=result.weights), atol=1e-9)
    assert rms_error(result.trajectory[None])[0] == pytest.approx(result.error)
    assert result.policy_return >= np.exp(-((0.005 / 0.05) ** 2))
    assert np.sqrt(np.square(result.trajectory - target).mean()) <= 0.005


def test_converges_to_known_optimum_seven_dof(sawyer_dmp):
    target, reward, rms_error = tracking_problem(sawyer_dmp, displacement=0.05)
    start_error = rms_error(sawyer_dmp.rollout()[None])[0]
    result = power(sawyer_dmp, reward, error=rms_error, tol=0.01, max_iter=300, seed=0, per_basis=False)
    assert start_error > 0.05
    assert result.converged and result.error <= 0.01
    assert np.sqrt(np.square(result.trajectory - target).sum(axis=-1).mean()) <= 0.01
    assert result.history.error[-1] < result.history.error[0] / 5


def test_learns_a_new_joint_goal_within_tolerance_and_limits(sawyer_dmp, sawyer):
    new_goal = sawyer_dmp.goal_ + np.array([0.1, -0.1, 0.08, 0.1, -0.05, 0.1, -0.1])
    lower, upper = sawyer.lower.numpy(), sawyer.upper.numpy()
    result = power(
        sawyer_dmp,
        JointGoalReward(new_goal),
        sigma_goal=0.1,
        tol=0.01,
        lower=lower,
        upper=upper,
        max_iter=150,
        seed=0,
    )
    assert result.converged and result.within_limits
    assert np.linalg.norm(result.trajectory[-1] - new_goal) <= 0.01
    assert np.all(result.trajectory >= lower) and np.all(result.trajectory <= upper)
    # late bases act at the end of the motion, so weights and goal share the end-point correction
    np.testing.assert_allclose(result.trajectory, sawyer_dmp.rollout(weights=result.weights, goal=result.goal),
                               atol=1e-9)  # fmt: skip


def test_overshooting_demonstration_is_brought_within_joint_limits():
    t = np.linspace(0.0, 1.0, 100)
    profile = 10 * t**3 - 15 * t**4 + 6 * t**5
    demo = (profile + 0.5 * np.sin(np.pi * profile) * profile)[:, None]  # overshoots 1 rad by ~4 %
    dmp = DMP(n_basis=20).fit(t, demo)
    lower, upper = np.array([-1.0]), np.array([1.01])
    assert dmp.rollout().max() > 1.03
    result = power(dmp, JointGoalReward([1.0]), tol=0.01, lower=lower, upper=upper, max_iter=200, seed=0)
    assert result.converged and result.within_limits
    assert result.trajectory.max() <= 1.01 and abs(result.trajectory[-1, 0] - 1.0) <= 0.01
    assert result.history.policy_return[-1] > 10 * result.history.policy_return[0]


def test_zero_weights_explore(line_dmp):
    zero = np.zeros_like(line_dmp.weights_)
    _, reward, rms_error = tracking_problem(line_dmp, displacement=0.2, base=zero)
    start_error = rms_error(line_dmp.rollout(weights=zero)[None])[0]
    result = power(line_dmp, reward, weights=zero, error=rms_error, max_iter=100, seed=0)
    assert start_error > 0.03
    assert result.error < start_error / 4 and np.all(result.weights != 0.0)


def test_memory_keeps_the_best_rollouts_across_iterations(line_dmp):
    """With M = 1 the policy is the best rollout seen so far: its return never decreases."""
    _, reward, rms_error = tracking_problem(line_dmp, displacement=0.2)
    result = power(line_dmp, reward, error=rms_error, n_best=1, max_iter=30, sigma=0.05, seed=3)
    history = result.history
    assert np.all(np.diff(history.policy_return) >= 0.0)
    np.testing.assert_allclose(history.policy_return, np.maximum.accumulate(history.best_return), rtol=1e-12)


def test_caller_arrays_and_dmp_are_not_modified(sawyer_dmp):
    weights = sawyer_dmp.weights_ + 1.0
    goal = sawyer_dmp.goal_ + 0.05
    saved = {name: np.copy(getattr(sawyer_dmp, name)) for name in ("weights_", "goal_", "y0_")}
    inputs = weights.copy(), goal.copy()
    reward = JointGoalReward(sawyer_dmp.goal_)
    goal_before = reward.goal.copy()
    result = power(sawyer_dmp, reward, weights=weights, goal=goal, sigma_goal=0.05, max_iter=3, seed=0)
    np.testing.assert_array_equal(weights, inputs[0])
    np.testing.assert_array_equal(goal, inputs[1])
    np.testing.assert_array_equal(reward.goal, goal_before)
    for name, value in saved.items():
        np.testing.assert_array_equal(getattr(sawyer_dmp, name), value)
    result.weights[:] = 0.0
    result.goal[:] = 0.0
    np.testing.assert_array_equal(weights, inputs[0])
    np.testing.assert_array_equal(sawyer_dmp.weights_, saved["weights_"])


def test_same_seed_same_result_different_seed_different_path(line_dmp):
    _, reward, rms_error = tracking_problem(line_dmp, displacement=0.2)

    def run(seed):
        return power(line_dmp, reward, error=rms_error, max_iter=10, seed=seed)

    first, second, other = run(7), run(7), run(8)
    np.testing.assert_array_equal(first.weights, second.weights)
    np.testing.assert_array_equal(first.history.policy_return, second.history.policy_return)
    assert not np.array_equal(first.history.best_return, other.history.best_return)
    assert not np.array_equal(first.weights, other.weights)


def test_history_and_rollout_accounting(line_dmp):
    reward = JointGoalReward([1.3])
    result = power(line_dmp, reward, n_rollouts=4, max_iter=6, sigma_goal=0.05, seed=0)
    assert isinstance(result, PowerResult)
    assert not result.converged and result.iterations == 6
    assert result.rollouts == 1 + 6 * (4 + 1)
    np.testing.assert_array_equal(result.history.rollouts, 1 + 5 * np.arange(7))
    for column in (result.history.policy_return, result.history.best_return, result.history.error):
        assert column.shape == (7,)
    assert result.history.exploration[0] == 0.0 and np.all(result.history.exploration[1:] > 0.0)
    assert result.error == pytest.approx(reward.error(result.trajectory[None])[0])
    # a policy already within tolerance costs one rollout and no iteration
    done = power(line_dmp, JointGoalReward([1.0]), tol=0.01)
    assert done.converged and done.iterations == 0 and done.rollouts == 1


def test_sigma_decay_shrinks_exploration(line_dmp):
    result = power(line_dmp, JointGoalReward([1.2]), sigma_goal=0.05, sigma_decay=0.5, scale_by_error=False,
                   adapt_variance=False, max_iter=4)  # fmt: skip
    np.testing.assert_allclose(result.history.exploration[1:], [1.0, 0.5, 0.25, 0.125])


def test_bad_arguments_are_rejected_with_their_name(line_dmp):
    reward = JointGoalReward([1.0])
    cases = {
        "n_rollouts": dict(n_rollouts=0),
        "n_best": dict(n_best=0),
        "max_iter": dict(max_iter=-1),
        "sigma_goal": dict(sigma_goal=-0.1),
        "sigma_decay": dict(sigma_decay=0.0),
        "goal": dict(goal=[float("nan")]),
        "weights": dict(weights=np.zeros((1, 19))),
        "tol": dict(tol=0.0),
        "lower": dict(lower=[0.0]),
    }
    for name, kwargs in cases.items():
        with pytest.raises(ValueError, match=name):
            power(line_dmp, reward, **kwargs)
    with pytest.raises(ValueError, match="tol"):
        power(line_dmp, lambda y: np.ones(len(y)), tol=0.01)
    with pytest.raises(ValueError, match="reward"):
        power(line_dmp, "not callable")
    with pytest.raises(ValueError, match="reward"):
        power(line_dmp, lambda y: -np.ones(len(y)), max_iter=1)
    with pytest.raises(ValueError, match="reward"):
        power(line_dmp, lambda y: np.ones(3), max_iter=1)
    with pytest.raises(ValueError, match="dmp"):
        power(DMP(), reward)
