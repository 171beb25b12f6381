"""Discrete DMP: fitting, reproduction, generalisation (goal, duration), zero motion, errors."""

import json
import warnings

import numpy as np
import pytest
from dmp_helpers import LASA_SHAPES, lasa_demo, rmse, scale, smooth_demo

from lfd.dmp import DMP, FIT_METHODS


@pytest.mark.parametrize("method", FIT_METHODS)
def test_reproduces_smooth_synthetic_demonstrations(method):
    rng = np.random.default_rng(0)
    dmp = DMP(n_basis=30, overlap=0.8 if method == "trajectory" else 0.3)
    for n_steps, duration in ((100, 4.0), (500, 1.0)):
        t, y = smooth_demo(rng, n_steps, n_dims=7, duration=duration)
        out = dmp.fit(t, y, method=method).rollout()
        assert out.shape == y.shape
        tolerance = 2e-3 if method == "trajectory" else 3e-2
        assert rmse(out, y) < tolerance * scale(y)
        assert np.linalg.norm(out[-1] - y[-1]) < 2 * tolerance * scale(y)
        np.testing.assert_allclose(out[0], y[0], rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", LASA_SHAPES[:6])
def test_reproduces_lasa_handwriting(name):
    t, y = lasa_demo(name)
    out = DMP(n_basis=20).fit(t, y).rollout(t=t)
    assert rmse(out, y) < 5e-3 * scale(y)
    assert np.linalg.norm(out[-1] - y[-1]) < 1e-3 * scale(y)


def test_fit_learns_start_goal_and_duration_and_keeps_inputs():
    rng = np.random.default_rng(1)
    t, y = smooth_demo(rng, 80, 2, duration=3.0)
    t = t + 5.0  # the motion starts at t[0], whatever its value
    t_copy, y_copy = t.copy(), y.copy()
    dmp = DMP(n_basis=12).fit(t, y)
    np.testing.assert_array_equal(t, t_copy)
    np.testing.assert_array_equal(y, y_copy)
    np.testing.assert_array_equal(dmp.y0_, y[0])
    np.testing.assert_array_equal(dmp.goal_, y[-1])
    assert dmp.tau_ == pytest.approx(3.0) and dmp.n_steps_ == 80 and dmp.weights_.shape == (2, 12)
    dmp.y0_[:] = 0  # learned state is not a view of the caller's array
    np.testing.assert_array_equal(y, y_copy)
    shifted = dmp.rollout(t=t, y0=y[0])
    np.testing.assert_allclose(shifted, dmp.rollout(t=t - 5.0, y0=y[0]), atol=1e-12)


def test_non_uniform_sampling_is_handled():
    rng = np.random.default_rng(2)
    u = np.linspace(0, 1, 300)
    t = 2.0 * (u - 0.12 * np.sin(2 * np.pi * u) / np.pi)  # dense and sparse stretches
    _, y = smooth_demo(rng, t=t, n_dims=3)
    for method, overlap, tolerance in (("trajectory", 0.8, 2e-3), ("lwr", 0.3, 3e-2)):
        out = DMP(30, overlap=overlap).fit(t, y, method=method).rollout(t=t)
        assert rmse(out, y) < tolerance * scale(y), method


def test_temporal_scaling_stretches_the_same_path():
    rng = np.random.default_rng(3)
    t, y = smooth_demo(rng, 150, 3, duration=1.5)
    dmp = DMP().fit(t, y)
    slow = dmp.rollout(t=t, tau=2 * dmp.tau_)  # y_slow(t) == y(t / 2)
    np.testing.assert_allclose(slow, dmp.rollout(t=t / 2), rtol=0, atol=1e-12)
    default_slow = dmp.rollout(tau=2 * dmp.tau_)  # default grid: n_steps_ samples over the new tau
    np.testing.assert_allclose(default_slow, dmp.rollout(), rtol=0, atol=1e-12)
    _, velocity, acceleration = dmp.rollout(t=2 * t, tau=2 * dmp.tau_, return_derivatives=True)
    _, velocity_ref, acceleration_ref = dmp.rollout(t=t, return_derivatives=True)
    np.testing.assert_allclose(velocity, velocity_ref / 2, atol=1e-10)
    np.testing.assert_allclose(acceleration, acceleration_ref / 4, atol=1e-9)


def test_new_goal_scales_the_motion_with_the_displacement_ijspeert():
    rng = np.random.default_rng(4)
    t, y = smooth_demo(rng, 120, 3)
    dmp = DMP(formulation="ijspeert").fit(t, y)
    base = dmp.rollout(t=t)
    new_goal = dmp.goal_ + np.array([0.7, -1.3, 2.0])
    moved = dmp.rollout(t=t, goal=new_goal)
    # the forcing term scales with (g - y0), so (y - g) scales by (g' - y0) / (g - y0) per DoF
    ratio = (new_goal - dmp.y0_) / (dmp.goal_ - dmp.y0_)
    np.testing.assert_allclose(moved - new_goal, (base - dmp.goal_) * ratio, atol=1e-10)
    assert np.abs(
        dmp.rollout(t=np.linspace(0, 3 * dmp.tau_, 300), goal=new_goal)[-1] - new_goal
    ).max() < 1e-4 * scale(y)


def test_new_goal_adds_a_smooth_offset_pastor():
    # Pastor et al. 2009: y' - y is the goal offset times a smooth 0 -> 1 transient, the same
    # for every weight vector (the forcing term does not depend on the goal); the path keeps
    # its demonstrated shape and ends at the new goal.
    rng = np.random.default_rng(4)
    t, y = smooth_demo(rng, 120, 3)
    dmp = DMP().fit(t, y)
    assert dmp.formulation == "pastor"
    offset = np.array([0.7, -1.3, 2.0])
    long_t = np.linspace(0, 3 * dmp.tau_, 300)
    for weights in (dmp.weights_, dmp.weights_ + rng.normal(size=dmp.weights_.shape)):
        shift = dmp.rollout(t=long_t, goal=dmp.goal_ + offset, weights=weights) - dmp.rollout(
            t=long_t, weights=weights
        )
        transient = shift / offset
        np.testing.assert_allclose(
            transient, transient[:, :1].repeat(3, axis=1), atol=1e-10
        )  # same for every DoF
        assert np.all(np.diff(transient[:, 0]) >= -1e-12)  # monotone 0 -> 1
        assert abs(transient[0, 0]) < 1e-12 and transient[-1, 0] == pytest.approx(1.0, abs=1e-4)
        velocity = np.gradient(transient[:, 0], long_t)
        assert abs(velocity[1]) < 0.05 * velocity.max()  # no jump at the start


def test_batched_fit_equals_per_sample_fit():
    rng = np.random.default_rng(5)
    t = np.linspace(0, 2, 90)
    demos = np.stack([smooth_demo(rng, t=t, n_dims=4)[1] for _ in range(5)])
    for method in FIT_METHODS:
        batched = DMP(15).fit(t, demos, method=method)
        assert batched.weights_.shape == (5, 4, 15) and batched.y0_.shape == (5, 4)
        for b in range(5):
            single = DMP(15).fit(t, demos[b], method=method)
            np.testing.assert_allclose(batched.weights_[b], single.weights_, rtol=1e-10, atol=1e-8)
        np.testing.assert_allclose(
            batched.rollout()[2], DMP(15).fit(t, demos[2], method=method).rollout(), atol=1e-10
        )


def test_batched_rollout_of_many_weight_sets_matches_single_rollouts():
    rng = np.random.default_rng(6)
    t, y = smooth_demo(rng, 60, 7)
    dmp = DMP().fit(t, y)
    weights = dmp.weights_ + rng.normal(size=(50, 7, 20)) * 10
    batch = dmp.rollout(weights=weights)
    assert batch.shape == (50, 60, 7)
    for b in (0, 17, 49):
        np.testing.assert_allclose(batch[b], dmp.rollout(weights=weights[b]), atol=1e-12)
    starts = y[0] + rng.normal(size=(50, 7))
    np.testing.assert_allclose(dmp.rollout(y0=starts)[3], dmp.rollout(y0=starts[3]), atol=1e-12)


def test_stationary_demonstration_gives_finite_weights_and_stays_put():
    t = np.linspace(0, 1, 50)
    y = np.tile([0.5, -2.0], (50, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a stationary demo is representable: no warning
        dmp = DMP().fit(t, y)
    assert np.all(dmp.weights_ == 0)
    np.testing.assert_allclose(dmp.rollout(), y, atol=1e-12)


def test_dof_returning_to_its_start_warns_and_rests_ijspeert():
    t = np.linspace(0, 1, 100)
    y = np.stack([np.sin(np.pi * t), t], axis=-1)  # DoF 0 moves and comes back, DoF 1 moves
    with pytest.warns(RuntimeWarning, match="ends at its start"):
        dmp = DMP(formulation="ijspeert").fit(t, y)
    assert np.all(np.isfinite(dmp.weights_)) and np.all(dmp.weights_[0] == 0)
    out = dmp.rollout()
    np.testing.assert_allclose(out[:, 0], y[0, 0], atol=1e-12)
    assert rmse(out[:, 1:], y[:, 1:]) < 1e-3
    straight = dmp.rollout(goal=[2.0, 1.0])[:, 0]  # zero weights: the spring alone, monotone to the goal
    assert np.all(np.diff(straight) >= 0) and straight[-1] == pytest.approx(2.0, abs=1e-3)


def test_dof_returning_to_its_start_is_reproduced_pastor():
    t = np.linspace(0, 1, 100)
    y = np.stack([np.sin(np.pi * t), t, 0.3 * np.sin(2 * np.pi * t)], axis=-1)  # DoFs 0 and 2 return
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dmp = DMP().fit(t, y)
    out = dmp.rollout()
    for d in range(3):  # every DoF as well as the moving one (relative to its own range)
        assert rmse(out[:, d : d + 1], y[:, d : d + 1]) < 2e-3 * np.ptp(y[:, d])
    lifted = dmp.rollout(goal=[0.0, 2.0, 0.0])  # other DoF moved: the returning ones keep their shape
    np.testing.assert_allclose(lifted[:, [0, 2]], out[:, [0, 2]], atol=1e-12)


def test_files_saved_before_the_formulation_argument_load_as_ijspeert(tmp_path):
    rng = np.random.default_rng(9)
    t, y = smooth_demo(rng, 60, 3)
    old = DMP(8, formulation="ijspeert").fit(t, y)
    path = tmp_path / "old.dmp.json"
    old.save(path)
    payload = json.loads(path.read_text())
    del payload["params"]["formulation"]  # what version-1 files written before the argument hold
    path.write_text(json.dumps(payload))
    loaded = DMP.load(path)
    assert loaded.formulation == "ijspeert"
    np.testing.assert_array_equal(loaded.rollout(), old.rollout())
    new = DMP(8).fit(t, y)
    new.save(path)
    assert (
        DMP.load(path).formulation == "pastor"
        and json.loads(path.read_text())["params"]["formulation"] == "pastor"
    )


def test_derivatives_agree_with_finite_differences():
    rng = np.random.default_rng(7)
    t, y = smooth_demo(rng, 2000, 2, duration=1.0)
    position, velocity, acceleration = DMP().fit(t, y).rollout(return_derivatives=True)
    np.testing.assert_allclose(
        np.gradient(position, t, axis=0, edge_order=2), velocity, atol=2e-3 * np.abs(velocity).max()
    )
    np.testing.assert_allclose(
        np.gradient(velocity, t, axis=0, edge_order=2), acceleration, atol=2e-3 * np.abs(acceleration).max()
    )
    np.testing.assert_array_equal(velocity[0], 0.0)


def test_save_load_round_trip(tmp_path):
    rng = np.random.default_rng(8)
    t = np.linspace(0, 1, 40)
    for dmp in (
        DMP(9, alpha_z=30.0, beta_z=7.0, alpha_s=5.0, overlap=0.6).fit(t, smooth_demo(rng, t=t, n_dims=3)[1]),
        DMP(6).fit(t, np.stack([smooth_demo(rng, t=t, n_dims=2)[1] for _ in range(3)])),
        DMP(4),
    ):
        path = tmp_path / "skill.dmp.json"
        dmp.save(path)
        loaded = DMP.load(path)
        assert repr(loaded) == repr(dmp) and loaded.is_fitted == dmp.is_fitted
        assert not list(tmp_path.glob(".*.tmp"))  # temp file renamed away
        if dmp.is_fitted:
            for name in ("weights_", "y0_", "goal_"):
                np.testing.assert_array_equal(getattr(loaded, name), getattr(dmp, name))
            assert (loaded.tau_, loaded.n_steps_) == (dmp.tau_, dmp.n_steps_)
            np.testing.assert_array_equal(loaded.rollout(), dmp.rollout())


def test_load_rejects_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        DMP.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        DMP.load(bad)
    DMP(3).fit(np.linspace(0, 1, 10), np.linspace(0, 1, 10)[:, None] ** 2).save(bad)
    text = bad.read_text()
    with pytest.raises(ValueError, match="does not hold"):
        bad.write_text(text.replace("lfd.dmp.DMP", "lfd.dmp.RhythmicDMP"))
        DMP.load(bad)
    with pytest.raises(ValueError, match="bad fitted state"):
        bad.write_text(text.replace('"n_basis": 3', '"n_basis": 4'))
        DMP.load(bad)


def test_unfitted_dmp_needs_every_argument():
    dmp = DMP(5)
    with pytest.raises(ValueError, match="not fitted"):
        dmp.rollout()
    out = dmp.rollout(t=np.linspace(0, 1, 30), y0=[0.0], goal=[1.0], tau=1.0, weights=np.zeros((1, 5)))
    assert out.shape == (30, 1)


@pytest.mark.parametrize(
    ("t", "y", "message"),
    [
        (np.array([0.0, 0.5, 0.5, 1.0]), np.zeros((4, 2)), "strictly increasing"),
        (np.array([0.0, 1.0, 0.5, 2.0]), np.zeros((4, 2)), "strictly increasing"),
        (np.array([0.0, 1.0]), np.zeros((2, 2)), "at least 3 samples"),
        (np.array([0.0, 0.5, np.nan]), np.zeros((3, 2)), "t contains NaN"),
        (np.linspace(0, 1, 5), np.array([[0.0], [1.0], [np.inf], [2.0], [3.0]]), "y contains NaN or inf"),
        (np.linspace(0, 1, 5), np.zeros((6, 2)), r"T = len\(t\) = 5"),
        (np.linspace(0, 1, 5), np.zeros(5), "y must be 2-D or 3-D"),
        (np.zeros((5, 1)), np.zeros((5, 2)), "t must be 1-D"),
    ],
)
def test_fit_rejects_bad_demonstrations(t, y, message):
    with pytest.raises(ValueError, match=message):
        DMP().fit(t, y)


def test_rollout_and_constructor_reject_bad_arguments():
    dmp = DMP(4).fit(np.linspace(0, 1, 20), np.random.default_rng(0).normal(size=(20, 3)).cumsum(0))
    cases = [
        (dict(y0=np.zeros(2)), r"y0 must have shape \(3,\)"),
        (dict(goal=np.zeros((2, 4))), r"goal must have shape \(3,\)"),
        (dict(weights=np.zeros((3, 5))), "K = 4"),
        (dict(weights=np.zeros((2, 4))), r"weights must have shape|y0 must have shape"),
        (dict(weights=np.zeros((4, 3, 4)), y0=np.zeros((3, 3))), "batch sizes disagree"),
        (dict(tau=0.0), "tau must be"),
        (dict(tau=np.nan), "tau"),
        (dict(t=[0.0, 0.2, 0.1]), "strictly increasing"),
        (dict(goal=[np.nan, 0, 0]), "goal contains NaN"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            dmp.rollout(**kwargs)
    for kwargs, message in [
        (dict(n_basis=0), "n_basis"),
        (dict(n_basis=2.5), "n_basis"),
        (dict(alpha_z=-1.0), "alpha_z"),
        (dict(beta_z=0.0), "beta_z"),
        (dict(alpha_s=np.inf), "alpha_s"),
        (dict(overlap=1.0), "overlap"),
        (dict(formulation="hoffmann"), "formulation"),
    ]:
        with pytest.raises(ValueError, match=message):
            DMP(**kwargs)
    with pytest.raises(ValueError, match="method"):
        dmp.fit(np.linspace(0, 1, 5), np.zeros((5, 1)), method="ridge")


def test_file_names_and_contents_must_say_json(tmp_path):
    dmp = DMP(3).fit(np.linspace(0, 1, 10), np.linspace(0, 1, 10)[:, None] ** 2)
    with pytest.raises(ValueError, match=r"give it a \.json name"):
        dmp.save(tmp_path / "dmp.npz")
    assert not (tmp_path / "dmp.npz").exists()
    binary = tmp_path / "binary.json"
    binary.write_bytes(b"\x80\x04\x95 pickle-like bytes \xff\xfe")
    with pytest.raises(ValueError, match="not a DMP file"):
        DMP.load(binary)
