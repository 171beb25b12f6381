"""Start velocity, step-wise integration (DMP.step, DMPRunner) and coupling terms."""

import numpy as np
import pytest
from dmp_helpers import smooth_demo
from scipy.integrate import solve_ivp

from lfd.dmp import DMP, DMPRunner, DMPState, JointLimits, ObstacleAvoidance, rollout_batch, transform


@pytest.fixture
def fitted():
    rng = np.random.default_rng(21)
    t, y = smooth_demo(rng, 80, 3, duration=1.6)
    return t, y, DMP(n_basis=15).fit(t, y)


@pytest.mark.parametrize("formulation", ["pastor", "ijspeert"])
def test_runner_agrees_with_the_closed_form_rollout(formulation):
    rng = np.random.default_rng(22)
    t, y = smooth_demo(rng, 60, 3, duration=1.2)
    dmp = DMP(12, formulation=formulation).fit(t, y)
    runner = DMPRunner(dmp, substeps=transform.substeps((t[1] - t[0]) / dmp.tau_))
    states = [runner.state] + [runner.step(dt) for dt in np.diff(t)]
    positions = np.array([s.y for s in states])
    velocities = np.array([s.yd for s in states])
    reference, reference_velocity, _ = dmp.rollout(t=t, return_derivatives=True)
    np.testing.assert_allclose(positions, reference, rtol=0, atol=1e-6 * np.ptp(y))
    np.testing.assert_allclose(
        velocities, reference_velocity, rtol=0, atol=1e-6 * np.abs(reference_velocity).max()
    )
    assert states[-1].t == pytest.approx(t[-1] - t[0])
    # DMP.step is the same pure function; one sub-step per step matches a grid that needs none
    fine = np.linspace(0, dmp.tau_, transform.MIN_STEPS_PER_TAU + 1)
    state = DMPState(dmp.y0_, np.zeros(3))
    for dt in np.diff(fine)[:50]:
        state = dmp.step(state, dt)
    np.testing.assert_allclose(state.y, dmp.rollout(t=fine)[50], atol=1e-10)


def test_runner_follows_a_goal_that_moves_mid_motion(fitted):
    t, y, dmp = fitted
    new_goal = dmp.goal_ + np.array([0.4, -0.3, 0.2])
    dt = dmp.tau_ / 100
    runner = DMPRunner(dmp, substeps=transform.substeps(dt / dmp.tau_))
    path = [runner.step(dt, goal=new_goal if k >= 50 else None).y for k in range(300)]
    path = np.array(path)
    reference = dmp.rollout(t=np.arange(0, 301) * dt)[1:]
    np.testing.assert_allclose(path[:49], reference[:49], atol=1e-6)  # unchanged before the switch
    np.testing.assert_allclose(path[-1], new_goal, atol=1e-3 * np.ptp(y))  # ends at the new goal
    assert np.abs(np.diff(path, 2, axis=0)).max() < 5 * np.abs(np.diff(reference, 2, axis=0)).max()  # no jolt


def test_start_velocity_matches_an_ode_solver_and_is_fitted():
    # zero weights, ijspeert: y'' = w^2 (g - y) - 2 w y' with y(0) = y0, y'(0) = yd0
    tau, y0, goal, yd0 = 1.1, np.array([0.2, -1.0]), np.array([1.0, 0.5]), np.array([3.0, -2.0])
    t = np.linspace(0, 2 * tau, 150)
    ours = rollout_batch(y0, goal, np.zeros((2, 6)), t, tau=tau, yd0=yd0, formulation="ijspeert")
    w = 25.0 / (2 * tau)
    sol = solve_ivp(
        lambda _, x: np.concatenate([x[2:], w**2 * (goal - x[:2]) - 2 * w * x[2:]]),
        (0, t[-1]),
        np.concatenate([y0, yd0]),
        t_eval=t,
        rtol=1e-11,
        atol=1e-12,
    )
    np.testing.assert_allclose(ours, sol.y[:2].T, atol=1e-8)
    # a demonstration that starts moving: fit with its start velocity reproduces it better
    s = np.linspace(0, 1, 120)
    demo = np.stack([0.8 * s + 0.3 * np.sin(np.pi * s), np.sin(2 * s)], -1)
    at_rest = DMP(15).fit(s, demo)
    moving = DMP(15).fit(s, demo, yd0="demo")
    np.testing.assert_allclose(moving.yd0_, [0.8 + 0.3 * np.pi, 2.0], rtol=1e-3)
    err = [np.sqrt(np.mean((d.rollout() - demo) ** 2)) for d in (at_rest, moving)]
    assert err[1] < err[0] / 3, err
    np.testing.assert_allclose(np.gradient(moving.rollout(), s, axis=0)[0], moving.yd0_, rtol=0.05)
    with pytest.raises(ValueError, match="yd0"):
        DMP(5).fit(s, demo, yd0="start")


def _detour():
    t = np.linspace(0, 1, 200)
    y = np.stack([t, 0.2 * np.sin(np.pi * t)], -1)  # a 2-D path (metres)
    return t, y, DMP(20).fit(t, y), np.array([[0.5, 0.17]])  # obstacle 3 cm off the path


@pytest.mark.parametrize("kind", ["park", "hoffmann"])
def test_obstacle_avoidance_keeps_away_and_still_reaches_the_goal(kind):
    t, y, dmp, obstacle = _detour()
    free = dmp.rollout()
    avoided = dmp.rollout(coupling=[ObstacleAvoidance(obstacle, kind=kind)])
    before = np.linalg.norm(free - obstacle, axis=-1).min()
    after = np.linalg.norm(avoided - obstacle, axis=-1).min()
    assert before < 0.035 and after > 2 * before, (before, after)
    assert np.linalg.norm(avoided[-1] - y[-1]) < 2e-3  # close to the goal at t = tau already
    long_t = np.linspace(0, 3, 600)  # and converged to it a little later
    assert (
        np.linalg.norm(dmp.rollout(t=long_t, coupling=[ObstacleAvoidance(obstacle, kind=kind)])[-1] - y[-1])
        < 1e-5
    )


def test_coupling_in_batched_rollout_and_runner_agree_and_obstacles_can_move():
    t, y, dmp, obstacle = _detour()
    weights = dmp.weights_ + np.random.default_rng(0).normal(size=(4, 2, 20)) * 0.01
    term = ObstacleAvoidance(obstacle)
    batch = rollout_batch(dmp.y0_, dmp.goal_, weights, t, coupling=[term])
    assert batch.shape == (4, 200, 2)
    np.testing.assert_allclose(batch[2], dmp.rollout(weights=weights[2], coupling=[term]), atol=1e-12)
    runner = DMPRunner(dmp, weights=weights, coupling=[term], substeps=transform.substeps(t[1] / dmp.tau_))
    stepped = np.stack([runner.state.y] + [runner.step(dt).y for dt in np.diff(t)], axis=1)
    np.testing.assert_allclose(stepped, batch, atol=1e-12)
    # an obstacle that appears mid-motion on the path: the runner moves around it
    runner = DMPRunner(dmp, substeps=5)
    term.points = [[10.0, 10.0]]
    runner.coupling.append(term)
    path = []
    for k in range(199):
        if k == 60:
            term.points = [[0.7, 0.13]]
        path.append(runner.step(t[1]).y)
    free_distance = np.linalg.norm(dmp.rollout() - [0.7, 0.13], axis=-1).min()
    assert np.linalg.norm(np.array(path) - [0.7, 0.13], axis=-1).min() > 2 * free_distance


def test_joint_limits_are_respected_and_the_motion_is_unchanged_far_from_them(fitted):
    t, y, dmp = fitted
    free = dmp.rollout()
    lower, upper = free.min(0) - 0.5, free.max(0) + 0.5
    np.testing.assert_allclose(
        dmp.rollout(coupling=[JointLimits(lower, upper, margin=0.1)]), free, atol=1e-12
    )
    lower = free.min(0) - 0.05
    upper = free[0] + 0.5 * (free.max(0) - free[0])  # halfway between the start and the highest point
    limited = dmp.rollout(coupling=[JointLimits(lower, upper)])
    assert np.all(free.max(0) > upper + 0.01)  # the free motion violates them
    assert np.all(limited <= upper) and np.all(limited >= lower)
    assert (
        np.all(np.isfinite(limited))
        and np.abs(np.diff(limited, axis=0)).max() <= np.abs(np.diff(free, axis=0)).max()
    )
    # the repulsion alone already keeps the motion out of most of the violation
    soft = JointLimits(lower, upper)
    soft.project = None
    assert np.all(dmp.rollout(coupling=[soft]).max(0) - upper < 0.5 * (free.max(0) - upper))


def test_coupling_rejects_bad_input():
    with pytest.raises(ValueError, match="kind"):
        ObstacleAvoidance([[0.0, 0.0]], kind="magnetic")
    with pytest.raises(ValueError, match="2-D or 3-D"):
        ObstacleAvoidance(np.zeros((1, 4)), kind="hoffmann")
    with pytest.raises(ValueError, match="points contains NaN"):
        ObstacleAvoidance([[np.nan, 0.0]])
    with pytest.raises(ValueError, match="lower < upper"):
        JointLimits([0.0, 1.0], [1.0, 0.5])
    t, y, dmp, _ = _detour()
    with pytest.raises(ValueError, match="coordinates"):
        dmp.rollout(coupling=[ObstacleAvoidance(np.zeros((1, 3)))])
    with pytest.raises(ValueError, match="dt"):
        DMPRunner(dmp).step(0.0)
