"""FinalVelocityDMP (Mülling et al. 2013) against movement_primitives' DMPWithFinalVelocity.

movement_primitives integrates with semi-implicit Euler (first order in its ``int_dt``); ours
is the exact solution of the same equation. So at equal settings (same basis, weights
``K w``, boundary conditions) its error to ours must shrink 10x when ``int_dt`` does, and the
Richardson extrapolation of two of its runs must meet ours far below either run's error.
"""

from __future__ import annotations

import numpy as np
import pytest
from dmp_helpers import lasa_demo, rmse, scale
from movement_primitives.dmp import DMPWithFinalVelocity

from lfd.dmp import FinalVelocityDMP
from lfd.dmp.final_velocity import quintic

K = 25.0 * 6.25  # alpha_z beta_z: movement_primitives' weights are K times ours
T = np.linspace(0.0, 1.0, 101)
DEMO = np.stack([T**2, np.sin(2 * T), 0.3 * np.cos(3 * T)], -1)  # ends moving
TRUE_END_VELOCITY = np.array([2.0, 2 * np.cos(2.0), -0.9 * np.sin(3.0)])


@pytest.fixture(scope="module")
def fitted():
    return FinalVelocityDMP(n_basis=10, alpha_s=np.log(100.0)).fit(T, DEMO)


def _reference(dmp: FinalVelocityDMP, int_dt: float, goal_velocity=None):
    mp = DMPWithFinalVelocity(n_dims=3, execution_time=dmp.tau_, dt=0.01, n_weights_per_dim=10, int_dt=int_dt)
    mp.set_weights((K * dmp.weights_).ravel())
    mp.configure(
        start_y=dmp.y0_,
        start_yd=dmp.yd0_,
        start_ydd=dmp.ydd0_,
        goal_y=dmp.goal_,
        goal_yd=dmp.goal_velocity_ if goal_velocity is None else goal_velocity,
        goal_ydd=dmp.goal_acceleration_,
    )
    return mp.open_loop()


def test_equal_settings_converge_to_ours(fitted):
    times, coarse = _reference(fitted, 1e-3)
    _, fine = _reference(fitted, 1e-4)
    _, half = _reference(fitted, 2e-4)
    ours = fitted.rollout(t=times)
    coarse_error, fine_error = np.abs(coarse - ours).max(), np.abs(fine - ours).max()
    assert 1e-3 < coarse_error < 5e-3 and 8 < coarse_error / fine_error < 12  # first order, towards ours
    assert np.abs(2 * fine - half - ours).max() < 1e-6  # Richardson: the continuous solution is ours


def test_new_final_velocity_is_reached_like_the_reference(fitted):
    hit = np.array([3.0, 0.0, -1.0])
    y, yd, _ = fitted.rollout(goal_velocity=hit, return_derivatives=True)
    np.testing.assert_allclose(yd[-1], hit, atol=2e-3)
    np.testing.assert_allclose(y[-1], fitted.goal_, atol=1e-5)
    times, reference = _reference(fitted, 1e-4, goal_velocity=hit)
    np.testing.assert_allclose(fitted.rollout(t=times, goal_velocity=hit), reference, atol=5e-4)


def test_fit_reproduces_and_estimates_the_final_velocity_better_than_the_reference(fitted):
    assert np.abs(fitted.rollout() - DEMO).max() < 2e-5
    mp = DMPWithFinalVelocity(n_dims=3, execution_time=1.0, dt=0.01, n_weights_per_dim=10)
    mp.imitate(T, DEMO)
    _, theirs = mp.open_loop()
    assert np.abs(theirs - DEMO).max() > 100 * np.abs(fitted.rollout() - DEMO).max()
    ours_error = np.abs(fitted.goal_velocity_ - TRUE_END_VELOCITY).max()
    theirs_error = np.abs(mp.goal_yd - TRUE_END_VELOCITY).max()
    assert ours_error < 1e-3 < theirs_error  # their backward difference lags half a sample


@pytest.mark.parametrize("name", ["Angle", "CShape", "GShape", "Sshape", "Snake", "WShape"])
def test_lasa_stroke_cut_mid_motion(name):
    """Real handwriting cut at 60 % (it ends moving): ours reproduces it >= 10x better than
    movement_primitives' imitate at the same 30 bases and ends with the estimated velocity."""
    t, y = lasa_demo(name)
    t, y = t[:600:3], y[:600:3]
    dmp = FinalVelocityDMP(n_basis=30).fit(t, y)
    out, velocity, _ = dmp.rollout(return_derivatives=True)
    mp = DMPWithFinalVelocity(n_dims=2, execution_time=t[-1], dt=t[1] - t[0], n_weights_per_dim=30)
    mp.imitate(t, y)
    _, theirs = mp.open_loop()
    n = min(len(theirs), len(y))
    assert rmse(out, y) < 3e-4 * scale(y) and 10 * rmse(out, y) < rmse(theirs[:n], y[:n])
    speed = np.linalg.norm(dmp.goal_velocity_)
    assert speed > 10 and np.abs(velocity[-1] - dmp.goal_velocity_).max() < 0.05 * speed


def test_quintic_meets_its_boundary_conditions():
    ends = np.array([0.0, 1.0])
    values, first, second = (quintic(ends, k) for k in range(3))
    np.testing.assert_allclose(values, [[1, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(first, [[0, 1, 0, 0, 0, 0], [0, 0, 0, 0, 1, 0]], atol=1e-15)
    np.testing.assert_allclose(second, [[0, 0, 1, 0, 0, 0], [0, 0, 0, 0, 0, 1]], atol=1e-15)


def test_batch_tau_and_goal_generalise():
    demos = np.stack([DEMO, DEMO * 1.5 + 0.1])
    dmp = FinalVelocityDMP(n_basis=15).fit(T, demos)
    assert dmp.weights_.shape == (2, 3, 15) and dmp.rollout().shape == (2, 101, 3)
    np.testing.assert_allclose(dmp.rollout()[1], demos[1], atol=5e-5)
    y, yd, _ = dmp.rollout(t=np.linspace(0, 2, 201), tau=2.0, goal=[1.0, 1.0, 1.0], return_derivatives=True)
    np.testing.assert_allclose(y[:, -1], 1.0, atol=1e-4)
    np.testing.assert_allclose(yd[:, -1], dmp.goal_velocity_, atol=2e-3)


def test_save_load_round_trip(tmp_path, fitted):
    path = tmp_path / "hit.dmp.json"
    fitted.save(path)
    loaded = FinalVelocityDMP.load(path)
    np.testing.assert_array_equal(loaded.rollout(), fitted.rollout())
    assert loaded.gains == fitted.gains


def test_bad_input_is_one_clear_line(fitted):
    with pytest.raises(ValueError, match="t must span at most tau"):
        fitted.rollout(t=np.linspace(0, 1.5, 10))
    with pytest.raises(ValueError, match="goal_velocity contains NaN"):
        fitted.rollout(goal_velocity=[np.nan, 0, 0])
    with pytest.raises(ValueError, match="boundary vector"):
        fitted.rollout(goal_velocity=[1.0, 2.0])
    with pytest.raises(ValueError, match="y must have shape"):
        FinalVelocityDMP().fit(T, DEMO[:-1])
    with pytest.raises(ValueError, match="not fitted"):
        FinalVelocityDMP().rollout()


def test_docstring_example():
    import doctest

    import lfd.dmp.final_velocity

    result = doctest.testmod(lfd.dmp.final_velocity, raise_on_error=False, verbose=False)
    assert result.attempted > 0 and result.failed == 0
