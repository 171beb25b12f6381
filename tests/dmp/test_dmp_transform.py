"""The exactly discretised transformation system (lfd.dmp.transform) against independent references."""

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp

from lfd.dmp import DMP, clear_caches, rollout_batch, transform
from lfd.dmp.canonical import discrete_features
from lfd.dmp.transform import (
    BLOCK,
    _forced_response_blocked,
    _forced_response_uniform,
    build_operator,
    transition,
)

ALPHA = 25.0


@pytest.mark.parametrize("beta", [ALPHA / 4, 2.0, 20.0, ALPHA / 4 + 1e-7])
@pytest.mark.parametrize("theta", [0.0, 1e-4, 0.3, 2.5])
def test_transition_equals_matrix_exponential(beta, theta):
    generator = torch.tensor([[0.0, 1.0], [-ALPHA * beta, -ALPHA]], dtype=torch.float64)
    expected = torch.linalg.matrix_exp(generator * theta)
    actual = transition(torch.tensor(theta, dtype=torch.float64), ALPHA, beta)
    torch.testing.assert_close(actual, expected, rtol=1e-10, atol=1e-12)


def test_zero_weights_follow_the_critically_damped_closed_form():
    # tau dz = a (a/4 (g - y) - z), tau dy = z, y(0) = y0, z(0) = 0:
    # e = y - g obeys e'' + 2 w e' + w^2 e = 0 with w = a / (2 tau), e(0) = y0 - g, e'(0) = 0,
    # so y(t) = g + (y0 - g) (1 + w t) exp(-w t) and dy/dt = -(y0 - g) w^2 t exp(-w t).
    tau, y0, goal = 1.7, np.array([0.3, -2.0]), np.array([1.5, 4.0])
    t = np.sort(np.random.default_rng(0).uniform(0, 2 * tau, 300))  # non-uniform, past tau
    t = np.concatenate([[0.0], t])
    y, yd, ydd = DMP(n_basis=5, formulation="ijspeert").rollout(
        t=t, y0=y0, goal=goal, tau=tau, weights=np.zeros((2, 5)), return_derivatives=True
    )
    w = ALPHA / (2 * tau)
    decay = np.exp(-w * t)[:, None]
    np.testing.assert_allclose(y, goal + (y0 - goal) * (1 + w * t[:, None]) * decay, rtol=0, atol=1e-12)
    np.testing.assert_allclose(yd, -(y0 - goal) * w**2 * t[:, None] * decay, rtol=0, atol=1e-11)
    np.testing.assert_allclose(ydd, -(y0 - goal) * w**2 * (1 - w * t[:, None]) * decay, rtol=0, atol=1e-10)


def _reference_rollout(t, y0, goal, weights, tau, n_basis, formulation, alpha_s=ALPHA / 3, overlap=0.8):
    """Adaptive RK45 on the continuous equations, re-derived in numpy (the thesis formulation)
    (``"ijspeert"``) or Pastor et al. 2009, ``K (g - y) - D z - K (g - y0) s + K f(s)``."""
    centres = np.exp(-alpha_s * np.linspace(0, 1, n_basis))
    widths = -np.log(overlap) / np.diff(centres) ** 2
    widths = np.append(widths, widths[-1])

    def rhs(time, state):
        y, z = np.split(state, 2)
        s = np.exp(-alpha_s * time / tau)
        psi = np.exp(-widths * (s - centres) ** 2)
        f = (weights @ psi) / psi.sum() * s
        stiffness = ALPHA * ALPHA / 4
        force = f * (goal - y0) if formulation == "ijspeert" else stiffness * (f - (goal - y0) * s)
        return np.concatenate([z / tau, (ALPHA * (ALPHA / 4 * (goal - y) - z) + force) / tau])

    sol = solve_ivp(
        rhs, (t[0], t[-1]), np.concatenate([y0, np.zeros_like(y0)]), t_eval=t, rtol=1e-11, atol=1e-12
    )
    return sol.y[: len(y0)].T


@pytest.mark.parametrize("formulation", ["ijspeert", "pastor"])
@pytest.mark.parametrize("uniform", [True, False])
def test_rollout_converges_to_the_continuous_solution(uniform, formulation, monkeypatch):
    rng = np.random.default_rng(3)
    tau, n_basis = 1.3, 8
    y0, goal, weights = rng.normal(size=2), rng.normal(size=2) + 2, rng.normal(size=(2, n_basis)) * 40
    if formulation == "pastor":
        weights = weights / 10  # units of y: the forcing is K f(s), K = alpha_z beta_z
    errors, refined = [], []
    for n_steps in (30, 100, 400):
        u = np.linspace(0, 1, n_steps)
        t = tau * (u if uniform else u - 0.15 * np.sin(2 * np.pi * u) / np.pi)  # smooth monotone warp
        ours = DMP(n_basis, formulation=formulation).rollout(t=t, y0=y0, goal=goal, tau=tau, weights=weights)
        reference = _reference_rollout(t, y0, goal, weights, tau, n_basis, formulation)
        refined.append(np.abs(ours - reference).max())
        with monkeypatch.context() as patch:  # the raw first-order hold on the grid itself
            patch.setattr(transform, "MIN_STEPS_PER_TAU", 1)
            clear_caches()
            raw = DMP(n_basis, formulation=formulation).rollout(
                t=t, y0=y0, goal=goal, tau=tau, weights=weights
            )
        clear_caches()
        errors.append(np.abs(raw - reference).max())
    # first-order hold on the forcing term: second-order convergence in the step size
    # (400 > BLOCK samples, so the non-uniform case also crosses block boundaries)
    size = max(np.abs(goal - y0).max(), np.abs(reference - y0).max())
    assert errors[2] < 2e-4 * size
    assert errors[2] < errors[1] / 6
    # built on a refined grid (>= transform.MIN_STEPS_PER_TAU steps per tau), every sampling is as
    # close to the continuous solution as a 1000-sample grid, even 30 samples
    assert max(refined) < 3e-5 * size, refined
    assert refined[0] < errors[0] / 50


def test_fft_and_blocked_responses_agree_across_block_boundaries():
    n_steps = 2 * BLOCK + 37
    tau = torch.tensor([0.8, 1.0, 1.7], dtype=torch.float64)
    theta = torch.linspace(0, 1.2, n_steps, dtype=torch.float64) / tau[:, None]
    features = discrete_features(theta, 12, ALPHA / 3, 0.8)
    fast = _forced_response_uniform(theta, features, ALPHA, ALPHA / 4)
    blocked = _forced_response_blocked(theta, features, ALPHA, ALPHA / 4)
    torch.testing.assert_close(fast, blocked, rtol=1e-9, atol=1e-14)


def test_operator_is_linear_in_weights():
    rng = np.random.default_rng(5)
    t = np.linspace(0, 1, 60)
    y0, goal = rng.normal(size=4), rng.normal(size=4)
    w1, w2 = rng.normal(size=(2, 4, 7)) * 10

    def forced_part(weights):
        return rollout_batch(y0, goal, weights, t) - rollout_batch(y0, goal, np.zeros_like(weights), t)

    np.testing.assert_allclose(forced_part(w1 + 2 * w2), forced_part(w1) + 2 * forced_part(w2), atol=1e-10)


def test_build_operator_first_sample_is_the_start_state():
    theta = torch.linspace(0, 1, 5, dtype=torch.float64)
    operator = build_operator(
        theta,
        discrete_features(theta, 3, ALPHA / 3, 0.8),
        torch.tensor(1.0, dtype=torch.float64),
        ALPHA,
        ALPHA / 4,
    )
    torch.testing.assert_close(operator.initial[0], torch.eye(2, dtype=torch.float64))
    assert torch.count_nonzero(operator.forced[0]) == 0
