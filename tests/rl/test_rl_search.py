"""Per-step PoWER, PI^BB, CMA-ES and the pyrdmp variant on the shared harness; via-point and obstacle rewards."""

import numpy as np
import pytest
from rl_helpers import quintic_demo

from lfd.dmp import DMP
from lfd.rl import DMPRollout, ObstacleReward, SearchProblem, ViaPointReward, cmaes, pibb, power
from lfd.rl.power import basis_features, per_step_update, pyrdmp_exploration


def via_task(dmp, offset=(0.1, -0.1), joints=(0, 1)):
    """Via point ``offset`` rad off the DMP's rollout at t = tau / 2 on ``joints``, goal fixed."""
    t = np.linspace(0.0, dmp.tau_, dmp.n_steps_)
    reference = dmp.rollout()
    point = np.array([np.interp(0.5 * dmp.tau_, t, reference[:, d]) for d in range(reference.shape[1])])
    point[list(joints)] += offset
    return ViaPointReward(t, 0.5 * dmp.tau_, point, goal=dmp.goal_)


@pytest.fixture(scope="module")
def planar_dmp():
    """2-DoF DMP of a 2 s, 100-sample quintic."""
    return DMP(n_basis=15).fit(*quintic_demo([0.0, 0.5], [1.0, -0.5], n_steps=100, duration=2.0))


# ------------------------------------------------------------------------------ rewards


def test_via_point_reward_error_interpolates_and_returns_to_go_end_with_the_return(planar_dmp):
    t = np.linspace(0.0, 2.0, 100)
    line = np.stack([t, -t], axis=1)[None]  # y(t) = (t, -t)
    reward = ViaPointReward(t, 1.0, [1.0, -1.0], goal=[2.0, -2.0])
    assert reward.error(line)[0] == pytest.approx(0.0, abs=1e-12)
    shifted = line + np.array([0.03, 0.04])
    assert reward.error(shifted)[0] == pytest.approx(0.05)
    q = reward.returns_to_go(shifted)
    assert q[0, 0] == pytest.approx(reward(shifted)[0])
    assert reward(shifted)[0] == pytest.approx(np.exp(-2 * (0.05 / 0.05) ** 2))
    assert np.all(np.diff(q[0]) >= 0.0)  # fewer costs remain later
    with pytest.raises(ValueError, match="t_via"):
        ViaPointReward(t, 3.0, [1.0, -1.0], goal=[2.0, -2.0])


def test_obstacle_reward_penetration_and_clearance():
    t = np.linspace(0.0, 1.0, 11)
    path = np.stack([t, np.zeros_like(t)], axis=1)[None]
    reward = ObstacleReward([0.5, 0.05], 0.1, goal=[1.0, 0.0])
    assert reward.clearance(path)[0] == pytest.approx(-0.05)
    assert reward.error(path)[0] == pytest.approx(0.05)
    clear = ObstacleReward([0.5, 0.2], 0.1, goal=[1.0, 0.0])
    assert clear.error(path)[0] == 0.0 and clear(path)[0] == 1.0
    with pytest.raises(ValueError, match="centre"):
        ObstacleReward([0.5], 0.1, goal=[1.0, 0.0])


def test_joint_goal_reward_per_step_sums_to_the_return(line_dmp):
    from lfd.rl import JointGoalReward

    reward = JointGoalReward([1.2], w1=0.9)
    trajectories = line_dmp.rollout()[None]
    np.testing.assert_allclose(reward.per_step(trajectories).sum(axis=1), reward(trajectories))


# ------------------------------------------------------------------------------ harness and exploration


def test_every_basis_gets_the_same_effect_and_no_dof_is_frozen():
    """basis_scale: a unit change of weight i moves the trajectory by exactly its scale."""
    dmp = DMP(n_basis=10, formulation="ijspeert").fit(*quintic_demo([0.0, 0.3], [1.0, 0.3], n_steps=100))
    rollout = DMPRollout(dmp)
    goal = dmp.goal_ + np.array([0.0, 0.4])  # the stationary DoF's goal moves
    base = rollout(dmp.weights_[None], goal[None])[0]
    scale = rollout.basis_scale(goal)
    for i in range(10):
        weights = dmp.weights_.copy()
        weights[:, i] += 1.0
        effect = np.abs(rollout(weights[None], goal[None])[0] - base).max(axis=0)
        np.testing.assert_allclose(effect, scale[:, i], rtol=1e-9)
    assert scale[0, -1] < 0.05 * scale[0, 0]  # late bases move the trajectory far less per unit
    # the harness floors g - y0, so the stationary DoF (g == y0) still explores
    problem = SearchProblem(dmp, lambda y: np.ones(len(y)))
    assert np.all(problem.scale(problem.theta0) > 0)
    assert rollout.basis_scale(dmp.goal_)[1].max() == 0.0


def test_stationary_dof_explores_once_its_goal_moves():
    """Bug fixed: a DoF with g == y0 (ijspeert) never explored its weights, even after the goal moved."""
    dmp = DMP(n_basis=10, formulation="ijspeert").fit(*quintic_demo([0.0, 0.3], [1.0, 0.3], n_steps=100))
    reward = via_task(dmp, offset=(0.0, 0.1), joints=(0, 1))
    reward.goal = dmp.goal_ + np.array([0.0, 0.3])  # the second DoF must now move to a new goal
    result = power(dmp, reward, sigma_goal=0.05, max_iter=40, seed=0)
    assert np.any(result.weights[1] != 0.0)
    assert result.history.error[-1] < result.history.error[0]


def test_pastor_and_ijspeert_rollouts_match_the_dmp():
    for formulation in ("pastor", "ijspeert"):
        dmp = DMP(n_basis=12, formulation=formulation).fit(*quintic_demo([0.0, 0.3], [1.0, -0.2], n_steps=80))
        rollout = DMPRollout(dmp)
        rng = np.random.default_rng(0)
        weights = dmp.weights_ + rng.normal(size=(3, 2, 12))
        goals = dmp.goal_ + rng.normal(scale=0.2, size=(3, 2))
        for k in range(3):
            np.testing.assert_allclose(rollout(weights, goals)[k], dmp.rollout(weights=weights[k], goal=goals[k]),
                                       atol=1e-9)  # fmt: skip
        assert rollout.goal_scaled == (formulation == "ijspeert")


# ------------------------------------------------------------------------------ per-step update


def test_per_step_update_with_constant_returns_is_the_reward_weighted_average():
    rng = np.random.default_rng(0)
    features = rng.uniform(size=(50, 6))
    eps = rng.normal(size=(4, 3, 6))
    returns = rng.uniform(0.1, 1.0, size=4)
    q = np.repeat(returns[:, None], 50, axis=1)
    variances = rng.uniform(0.5, 2.0, size=(3, 6))
    step = per_step_update(features, q, eps, variances)
    np.testing.assert_allclose(step, np.einsum("m,mdk->dk", returns, eps) / returns.sum(), rtol=1e-6)


def test_per_step_update_credits_each_basis_with_the_returns_after_it_acts():
    """Two bases acting in disjoint halves; rollout A is good in the second half only."""
    features = np.zeros((20, 2))
    features[:10, 0] = 1.0
    features[10:, 1] = 1.0
    eps = np.array([[[1.0, 1.0]], [[-1.0, -1.0]]])  # (M = 2, D = 1, K = 2)
    q = np.zeros((2, 20))
    q[0, 10:] = 1.0  # A: returns only after t = 10
    q[1, :10] = 1.0  # B: returns only before
    step = per_step_update(features, q, eps, np.ones((1, 2)))
    np.testing.assert_allclose(step, [[-1.0, 1.0]], atol=1e-6)  # basis 0 follows B, basis 1 follows A


def test_basis_features_sum_to_the_phase(line_dmp):
    t = np.linspace(0.0, line_dmp.tau_, 50)
    features = basis_features(line_dmp, t)
    np.testing.assert_allclose(
        features.sum(axis=1), np.exp(-line_dmp.alpha_s * t / line_dmp.tau_), rtol=1e-12
    )


# ------------------------------------------------------------------------------ searches converge


@pytest.mark.parametrize("variant", ["per-step", "episodic"])
def test_power_passes_a_via_point(planar_dmp, variant):
    reward = via_task(planar_dmp)
    start = reward.error(planar_dmp.rollout()[None])[0]
    result = power(planar_dmp, reward, variant=variant, tol=0.01, max_iter=150, seed=0)
    assert start > 0.14
    assert result.converged and result.error <= 0.01
    assert reward.error(result.trajectory[None])[0] == pytest.approx(result.error)
    np.testing.assert_allclose(result.trajectory, planar_dmp.rollout(weights=result.weights), atol=1e-9)


def test_power_avoids_an_obstacle(planar_dmp):
    reference = planar_dmp.rollout()
    reward = ObstacleReward(reference[50] + [0.02, 0.0], 0.1, goal=planar_dmp.goal_)
    assert reward.clearance(reference[None])[0] < -0.05
    result = power(planar_dmp, reward, tol=0.01, max_iter=150, seed=0)
    assert result.converged and reward.clearance(result.trajectory[None])[0] >= -0.01


@pytest.mark.parametrize("search", [pibb, cmaes])
def test_pibb_and_cmaes_pass_a_via_point(planar_dmp, search):
    reward = via_task(planar_dmp)
    options = dict(sigma0=0.005) if search is cmaes else dict(sigma=0.02)
    result = search(planar_dmp, reward, tol=0.01, max_iter=300, seed=0, **options)
    assert result.converged and result.error <= 0.01
    assert result.rollouts == result.history.rollouts[-1]


def test_goal_exploration_learns_a_new_goal_with_every_search(line_dmp):
    from lfd.rl import JointGoalReward

    reward = JointGoalReward([1.2])
    common = dict(sigma_goal=0.05, tol=0.01, max_iter=200, seed=0)
    for run in (
        lambda: power(line_dmp, reward, **common),
        lambda: pibb(line_dmp, reward, **common),
        lambda: cmaes(line_dmp, reward, sigma0=0.05, **common),
    ):
        result = run()
        assert result.converged and abs(result.trajectory[-1, 0] - 1.2) <= 0.01
        assert result.goal[0] > 1.02  # the goal moved (late weights share the end-point correction)


def test_cmaes_matches_pycma_on_the_same_problem(planar_dmp):
    """Reference check: pycma on the same scaled coordinates needs a similar number of evaluations."""
    cma = pytest.importorskip("cma")
    reward = via_task(planar_dmp)
    problem = SearchProblem(planar_dmp, reward, tol=0.01)
    scale = problem.scale(problem.theta0)
    ours, theirs = [], []
    for seed in range(4):
        ours.append(cmaes(planar_dmp, reward, sigma0=0.005, tol=0.01, max_iter=400, seed=seed).rollouts)
        es = cma.CMAEvolutionStrategy(np.zeros(problem.size), 0.005, {"seed": seed + 1, "verbose": -9})
        used = 1
        while True:
            x = np.array(es.ask())
            _, returns, _ = problem.evaluate(problem.theta0 + x / scale)
            es.tell(list(x), list(-returns))
            mean_error = problem.policy_error(problem.evaluate((problem.theta0 + es.mean / scale)[None])[0])
            used += len(x) + 1
            if mean_error <= 0.01 or used > 8000:
                break
        theirs.append(used)
    assert max(ours) < 8000 and max(theirs) < 8000
    ratio = np.median(ours) / np.median(theirs)
    assert 0.6 < ratio < 1.6, (ours, theirs)


# ------------------------------------------------------------------------------ pyrdmp variant


def test_pyrdmp_exploration_has_mean_spread_and_unit_sd():
    rng = np.random.default_rng(0)
    psi = np.exp(-(np.linspace(-2, 2, 30)[:, None] ** 2) * np.arange(1, 4))  # (T = 30, K = 3)
    weights = np.array([[10.0, -5.0, 0.0], [2.0, 0.0, 40.0]])
    eps = pyrdmp_exploration(rng, 20000, weights, psi)
    spread = np.std(psi[None] * weights[:, None, :], axis=1)
    np.testing.assert_allclose(eps.mean(axis=0), spread, atol=0.05)
    np.testing.assert_allclose(eps.std(axis=0), 1.0, atol=0.03)
    assert np.all(spread >= 0.0)


def test_pyrdmp_published_stopping_test_stops_at_once_on_a_via_task(planar_dmp):
    """The published test only checks the distance to the (fixed) goal, which the DMP always reaches."""
    reward = via_task(planar_dmp)
    published = power(planar_dmp, reward, variant="pyrdmp", tol=0.01, max_iter=50, seed=0)
    assert published.iterations == 1 and not published.converged
    harness = power(planar_dmp, reward, variant="pyrdmp", stop="tol", tol=0.01, max_iter=5, seed=0)
    assert harness.iterations == 5
    with pytest.raises(ValueError, match="stop"):
        power(planar_dmp, reward, variant="pyrdmp", stop="never")
    with pytest.raises(ValueError, match="variant"):
        power(planar_dmp, reward, variant="kober")


def test_bad_arguments_of_the_searches_are_rejected_with_their_name(line_dmp):
    from lfd.rl import JointGoalReward

    reward = JointGoalReward([1.0])
    cases = [
        (power, dict(variance_bounds=(2.0, 3.0)), "variance_bounds"),
        (power, dict(variance_bounds=0.5), "variance_bounds"),
        (pibb, dict(eliteness=0.0), "eliteness"),
        (pibb, dict(n_rollouts=0), "n_rollouts"),
        (cmaes, dict(sigma0=0.0), "sigma0"),
        (cmaes, dict(popsize=1), "popsize"),
        (cmaes, dict(tol=0.01, error=None, reward=lambda y: np.ones(len(y))), "tol"),
    ]
    for search, kwargs, name in cases:
        kwargs = dict(kwargs)
        with pytest.raises(ValueError, match=name):
            search(line_dmp, kwargs.pop("reward", reward), **kwargs)
