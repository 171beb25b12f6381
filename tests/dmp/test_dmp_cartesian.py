"""Cartesian DMP: unit quaternions, an analytic reduction to the 1-D DMP, movement_primitives."""

import numpy as np
import pytest
from dmp_helpers import lasa_demo
from movement_primitives.dmp import CartesianDMP as ReferenceCartesianDMP

from lfd.dmp import DMP, CartesianDMP
from lfd.dmp import quaternion as quat


def angle_profile(s):
    return 1.2 * (10 * s**3 - 15 * s**4 + 6 * s**5) + 0.3 * np.sin(np.pi * s)


def fixed_axis_demo(n=101, duration=1.0):
    t = np.linspace(0, duration, n)
    s = t / duration
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    q0 = quat.exp(np.array([0.3, -0.2, 0.1]))
    q = quat.multiply(quat.exp(np.outer(angle_profile(s), axis)), q0)
    position = np.stack([s, np.sin(2 * s), 0.2 * np.sin(np.pi * s)], -1)
    return t, np.concatenate([position, q], -1), axis, q0


def free_demos():
    """Demonstrations whose rotation axis changes: synthetic, and LASA shapes lifted to 3-D."""
    cases = []
    t = np.linspace(0, 1, 101)
    s = t
    for i, (a, b) in enumerate([(0.5, 0.8), (-0.7, 0.3), (1.0, -0.6)]):
        rotvec = np.stack([angle_profile(s), a * np.sin(2 * np.pi * s), b * s**2], -1)
        q = quat.multiply(quat.exp(rotvec), quat.exp(np.array([0.1 * i, 0.2, -0.3])))
        position = np.stack([s, np.sin(2 * s + i), 0.2 * np.sin(np.pi * s)], -1)
        cases.append((f"synthetic{i}", t, np.concatenate([position, q], -1)))
    for name in ("CShape", "Angle", "Sshape", "GShape", "Snake", "WShape"):
        t, y = lasa_demo(name)
        index = np.linspace(0, len(t) - 1, 200).astype(int)
        t, y = t[index], y[index] / 100.0  # mm -> 0.1 m scale, 200 samples
        # the tool turns with the hand's position (the path's heading is undefined where LASA's
        # demonstrations come to rest, so it would make the orientation noise, not motion)
        rotvec = np.stack([0.3 * y[:, 0], 0.2 * y[:, 1], 0.5 * (y[:, 0] + y[:, 1])], -1)
        position = np.column_stack([y, 0.05 * np.sin(np.pi * t / t[-1])])
        cases.append((f"LASA {name}", t, np.concatenate([position, quat.exp(rotvec)], -1)))
    return cases


def orientation_rmse(a, b):
    return float(np.sqrt(np.mean(np.sum(quat.log(quat.multiply(a, quat.conjugate(b))) ** 2, -1))))


def position_rmse(a, b):
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, -1))))


@pytest.mark.filterwarnings("ignore:a demonstrated DoF moves:RuntimeWarning")  # z returns: ijspeert warns
@pytest.mark.parametrize("formulation", ["pastor", "ijspeert"])
@pytest.mark.parametrize("orientation", ["log", "ude"])
def test_rotation_about_a_fixed_axis_is_the_one_dimensional_dmp_of_the_angle(orientation, formulation):
    # Analytic reduction: for q(t) = exp(a(t) axis) q0 both orientation systems are exactly the
    # 1-D DMP of the angle a(t) from 0 to A = a(end), with weights w_d = axis_d w_a ("pastor",
    # weights in radians) or w_d = w_a ("ijspeert", dimensionless) per rotation-vector axis d.
    t, pose, axis, q0 = fixed_axis_demo()
    dmp = CartesianDMP(n_basis=20, orientation=orientation, formulation=formulation).fit(t, pose)
    out = dmp.rollout()
    assert out.shape == (101, 7)
    np.testing.assert_allclose(np.linalg.norm(out[:, 3:], axis=-1), 1.0, atol=1e-12)
    relative = quat.log(quat.multiply(out[:, 3:], quat.conjugate(q0)))
    np.testing.assert_allclose(np.cross(relative, axis), 0.0, atol=1e-9)  # stays on the axis
    d = int(np.argmax(np.abs(axis)))
    w_angle = dmp.weights_[3 + d] / (axis[d] if formulation == "pastor" else 1.0)
    expected = np.outer(w_angle, axis if formulation == "pastor" else np.ones(3)).T
    np.testing.assert_allclose(dmp.weights_[3:], expected, rtol=1e-6, atol=1e-9 * np.abs(w_angle).max())
    angle = DMP(20, formulation=formulation).rollout(
        t=t, y0=[0.0], goal=[angle_profile(1.0)], tau=1.0, weights=w_angle[None]
    )[:, 0]
    tolerance = 1e-10 if orientation == "log" else 2e-5  # "ude" is integrated (RK2, tau / 1000)
    np.testing.assert_allclose(relative @ axis, angle, atol=tolerance)
    if orientation == "log":  # and its fit is the exact trajectory fit of the angle
        fitted = DMP(20, formulation=formulation).fit(t, angle_profile(t)[:, None]).rollout()[:, 0]
        np.testing.assert_allclose(relative @ axis, fitted, atol=1e-10)
    np.testing.assert_allclose(
        out[:, :3], DMP(20, formulation=formulation).fit(t, pose[:, :3]).rollout(), atol=1e-12
    )


def test_reproduction_no_worse_than_movement_primitives():
    ratios = {}
    for name, t, pose in free_demos() + [("fixed axis", *fixed_axis_demo()[:2])]:
        ours = CartesianDMP(n_basis=20).fit(t, pose).rollout(t=t)
        reference = ReferenceCartesianDMP(execution_time=t[-1] - t[0], dt=t[1] - t[0], n_weights_per_dim=20)
        reference.imitate(t - t[0], pose)
        reference.configure(start_y=pose[0], goal_y=pose[-1])
        theirs = reference.open_loop()[1][: len(t)]
        ratios[name] = (
            position_rmse(ours[:, :3], pose[:, :3]) / position_rmse(theirs[:, :3], pose[:, :3]),
            orientation_rmse(ours[:, 3:], pose[:, 3:]) / orientation_rmse(theirs[:, 3:], pose[:, 3:]),
        )
    assert max(max(r) for r in ratios.values()) <= 1.0, ratios


def test_batched_fit_and_rollout_new_goal_and_tempo():
    cases = free_demos()[:3]
    t = cases[0][1]
    poses = np.stack([pose for _, _, pose in cases])
    batched = CartesianDMP(12).fit(t, poses)
    assert batched.weights_.shape == (3, 6, 12) and batched.goal_.shape == (3, 7)
    out = batched.rollout()
    assert out.shape == (3, 101, 7)
    np.testing.assert_allclose(out[1], CartesianDMP(12).fit(t, poses[1]).rollout(), atol=1e-10)
    single = CartesianDMP(12).fit(t, poses[0])
    goal = poses[0, -1].copy()
    goal[:3] += [0.2, -0.1, 0.3]
    goal[3:] = quat.multiply(quat.exp(np.array([0.0, 0.4, 0.0])), goal[3:])
    long_t = np.linspace(0, 3, 300)
    for orientation in ("log", "ude"):
        dmp = CartesianDMP(12, orientation=orientation).fit(t, poses[0])
        moved = dmp.rollout(t=long_t, goal=goal)
        np.testing.assert_allclose(moved[-1, :3], goal[:3], atol=1e-4)
        assert orientation_rmse(moved[-1:, 3:], goal[None, 3:]) < 1e-4
        np.testing.assert_allclose(np.linalg.norm(moved[:, 3:], axis=-1), 1.0, atol=1e-12)
    slow = single.rollout(t=2 * t, tau=2.0)
    np.testing.assert_allclose(slow, single.rollout(t=t), atol=1e-10)


def test_cartesian_dmp_rejects_bad_input():
    t, pose, _, _ = fixed_axis_demo()
    with pytest.raises(ValueError, match="7 values"):
        CartesianDMP().fit(t, pose[:, :6])
    bad = pose.copy()
    bad[5, 3:] *= 2
    with pytest.raises(ValueError, match="unit norm"):
        CartesianDMP().fit(t, bad)
    with pytest.raises(ValueError, match="orientation"):
        CartesianDMP(orientation="euler")
    with pytest.raises(ValueError, match="not fitted"):
        CartesianDMP().rollout()
    dmp = CartesianDMP(5).fit(t, pose)
    with pytest.raises(ValueError, match="weights must have shape"):
        dmp.rollout(weights=np.zeros((7, 5)))
