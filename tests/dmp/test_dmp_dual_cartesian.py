"""DualCartesianDMP and its relative-pose coupling against movement_primitives' DualCartesianDMP.

At equal settings (basis ``alpha_s = log 100``, weights ``K w``, ``smooth_scaling=True`` which
is our ``"pastor"`` form, the same CouplingTermDualCartesianPose gains with ``c1 = 0``) its
semi-implicit Euler solution converges to ours at first order in ``int_dt``, and the Richardson
extrapolation of two of its runs meets ours far below either run's error.
"""

from __future__ import annotations

import numpy as np
import pytest
from movement_primitives.dmp import CouplingTermDualCartesianPose
from movement_primitives.dmp import DualCartesianDMP as ReferenceDual

from lfd.dmp import DualCartesianDMP, RelativePoseCoupling
from lfd.dmp.quaternion import conjugate, exp, log, multiply

K = 25.0 * 6.25
T = np.linspace(0.0, 1.0, 101)


def _demo() -> np.ndarray:
    left = np.stack([0.3 * T, 0.5 + 0.1 * np.sin(np.pi * T), 0.2 + 0 * T], -1)
    right = left + [0.0, -0.3, 0.0] + np.stack([0 * T, 0 * T, 0.05 * np.sin(np.pi * T)], -1)
    return np.concatenate([left, exp(np.outer(T, [0, 0, 0.8])), right, exp(np.outer(T, [0.3, 0, 0.5]))], -1)


@pytest.fixture(scope="module")
def fitted():
    return DualCartesianDMP(n_basis=10, alpha_s=np.log(100.0)).fit(T, _demo())


@pytest.fixture(scope="module")
def free(fitted):
    """The uncoupled rollout on the demonstration's grid (101 samples over 1 s)."""
    return fitted.rollout()


def _reference(dmp, int_dt, c1=0.0, offset=(0.0, -0.2, 0.0)):
    ref = ReferenceDual(execution_time=1.0, dt=0.01, n_weights_per_dim=10, int_dt=int_dt, smooth_scaling=True)
    ref.set_weights((K * dmp.weights_).ravel())
    ref.configure(start_y=dmp.start_, goal_y=dmp.goal_)
    desired = np.eye(4)
    desired[:3, 3] = offset
    term = CouplingTermDualCartesianPose(desired_distance=desired, lf=(1.0, 1.0), k=1.0, c1=c1, c2=30.0)
    _, poses = ref.open_loop(coupling_term=term)
    return poses


def _same_hemisphere(poses, like):
    poses = poses.copy()
    for s in (slice(3, 7), slice(10, 14)):
        flip = np.sum(poses[:, s] * like[: len(poses), s], -1) < 0
        poses[flip, s] *= -1
    return poses


def test_coupled_rollout_is_the_limit_of_the_reference(fitted, free):
    coupling = RelativePoseCoupling(desired=[0.0, -0.2, 0.0, 1.0, 0.0, 0.0, 0.0], k=1.0, c1=0.0, c2=30.0)
    ours = fitted.rollout(t=np.linspace(0.0, 1.0, 101), coupling=coupling)
    coarse = _same_hemisphere(_reference(fitted, 1e-3), ours)
    fine = _same_hemisphere(_reference(fitted, 5e-4), ours)
    coarse_error, fine_error = np.abs(coarse - ours).max(), np.abs(fine - ours).max()
    assert 2e-4 < coarse_error < 1e-3 and 1.8 < coarse_error / fine_error < 2.2  # first order, towards ours
    assert np.abs(2 * fine - coarse - ours).max() < 2e-5  # Richardson
    # the coupling did something: the arms end 0.2 m apart instead of 0.3 m
    gap = lambda poses: np.linalg.norm(poses[:, 7:10] - poses[:, :3], axis=-1)  # noqa: E731
    assert gap(free)[-1] == pytest.approx(0.3, abs=1e-3) and gap(ours)[-1] < 0.28


def test_follower_takes_the_desired_relative_pose_and_the_leader_ignores_it(fitted, free):
    desired_rotation = exp(np.array([0.0, 0.2, 0.0]))
    desired = np.array([0.0, -0.25, 0.05, *desired_rotation])
    coupling = RelativePoseCoupling(desired=desired, leader_follower=(0.0, 1.0), k=100.0, c2=50.0)
    coupled = fitted.rollout(coupling=coupling)

    def relative_error(poses):  # right tool in the left tool frame vs desired, at the end
        left_q, right_q = poses[-1, 3:7], poses[-1, 10:14]
        rotation = log(multiply(multiply(conjugate(left_q), right_q), conjugate(desired_rotation)))
        offset = multiply(
            multiply(conjugate(left_q), np.concatenate([[0.0], poses[-1, 7:10] - poses[-1, :3]])), left_q
        )
        return np.linalg.norm(offset[1:] - desired[:3]), np.linalg.norm(rotation)

    (p_free, r_free), (p_coupled, r_coupled) = relative_error(free), relative_error(coupled)
    # equilibrium of the follower: its own spring (K = 156) against the coupling (c2 k = 5000)
    assert p_coupled < 0.1 * p_free and r_coupled < 0.1 * r_free  # at tau, still converging
    np.testing.assert_allclose(coupled[:, :7], free[:, :7], atol=1e-5)  # the leader follows its own DMP
    assert np.allclose(np.linalg.norm(coupled[:, 10:14], axis=-1), 1.0)


def test_weak_coupling_equals_independent_arms(fitted, free):
    weak = RelativePoseCoupling(desired=[0.0, -0.3, 0.0, 1.0, 0.0, 0.0, 0.0], k=1e-12, c2=1.0)
    np.testing.assert_allclose(fitted.rollout(coupling=weak), free, atol=1e-5)
    assert np.abs(free - _demo()).max() < 0.02


def test_uncoupled_equals_two_cartesian_dmps(fitted, free):
    np.testing.assert_array_equal(free[:, :7], fitted.left_.rollout())
    np.testing.assert_array_equal(free[:, 7:], fitted.right_.rollout())
    batch = DualCartesianDMP(n_basis=10, alpha_s=np.log(100.0)).fit(T, np.stack([_demo(), _demo()]))
    early = np.linspace(0.0, 0.1, 11)
    assert batch.weights_.shape == (2, 12, 10) and batch.rollout(t=early).shape == (2, 11, 14)
    np.testing.assert_allclose(batch.rollout(t=early)[1], free[:11], atol=1e-12)


def test_coupled_batch_equals_single_rollouts(fitted):
    coupling = RelativePoseCoupling(desired=[0.0, -0.2, 0.0, 1.0, 0.0, 0.0, 0.0], c1=0.5)
    early = np.linspace(0.0, 0.1, 11)
    goals = np.stack([fitted.goal_, fitted.goal_ + np.r_[0.1, 0, 0, 0, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, 0]])
    batch = fitted.rollout(t=early, goal=goals, coupling=coupling)
    assert batch.shape == (2, 11, 14)
    for k in range(2):
        np.testing.assert_allclose(
            batch[k], fitted.rollout(t=early, goal=goals[k], coupling=coupling), atol=1e-13
        )


@pytest.mark.slow
def test_reference_velocity_coupling_depends_on_its_step(fitted):
    """movement_primitives adds c1's velocity term to its state once per Euler step: halving
    int_dt changes its trajectory by far more than its Euler error (documented defect)."""
    coarse, fine = _reference(fitted, 1e-3, c1=1.0), _reference(fitted, 5e-4, c1=1.0)
    euler_change = np.abs(_reference(fitted, 1e-3) - _reference(fitted, 5e-4)).max()
    assert np.abs(coarse - fine).max() > 10 * euler_change


def test_save_load_round_trip(tmp_path, fitted, free):
    path = tmp_path / "bimanual.dmp.json"
    fitted.save(path)
    np.testing.assert_allclose(DualCartesianDMP.load(path).rollout(), free, atol=1e-12)


def test_bad_input_is_one_clear_line(fitted):
    with pytest.raises(ValueError, match="pose must end with 14 values"):
        DualCartesianDMP().fit(T, _demo()[:, :7])
    with pytest.raises(ValueError, match="goal must have 14 values"):
        fitted.rollout(goal=np.zeros(7))
    with pytest.raises(ValueError, match="unit norm"):
        RelativePoseCoupling(desired=[0, 0, 0, 2, 0, 0, 0])
    with pytest.raises(ValueError, match="leader_follower"):
        RelativePoseCoupling(desired=[0, 0, 0, 1, 0, 0, 0], leader_follower=(1, 1, 1))
    with pytest.raises(ValueError, match="not fitted"):
        DualCartesianDMP().rollout()
