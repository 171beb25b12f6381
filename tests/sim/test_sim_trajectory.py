"""Quintic via-point trajectories."""

import numpy as np
import pytest

from lfd.sim.trajectory import quintic_coefficients, via_quintic, via_velocities


def test_quintic_meets_boundary_conditions():
    q0, q1 = np.array([0.0, 1.0]), np.array([2.0, -1.0])
    v0, v1, a0, a1 = np.array([0.5, 0.0]), np.array([-0.2, 0.3]), np.array([0.1, 0.0]), np.array([0.0, -0.4])
    c = quintic_coefficients(q0, q1, v0, v1, a0, a1, 2.0)
    powers = np.arange(6)
    pos = lambda t: (c * (t**powers)[:, None]).sum(0)  # noqa: E731
    vel = lambda t: (c[1:] * (powers[1:] * t ** (powers[1:] - 1))[:, None]).sum(0)  # noqa: E731
    acc = lambda t: (c[2:] * (powers[2:] * (powers[2:] - 1) * t ** (powers[2:] - 2))[:, None]).sum(0)  # noqa: E731
    np.testing.assert_allclose([pos(0), vel(0), acc(0)], [q0, v0, a0], atol=1e-12)
    np.testing.assert_allclose([pos(2.0), vel(2.0), acc(2.0)], [q1, v1, a1], atol=1e-12)
    with pytest.raises(ValueError, match="duration"):
        quintic_coefficients(q0, q1, v0, v1, a0, a1, 0.0)


def test_via_quintic_rest_to_rest_through_knots_and_smooth():
    times = np.array([0.0, 1.5, 3.0, 4.0])
    points = np.array([[0.0, 0.0], [1.0, -1.0], [1.5, 0.5], [1.7, 0.4]])
    t = np.linspace(0, 4, 4001)
    q, qd, qdd = via_quintic(t, times, points)
    for k, tk in enumerate(times):
        i = int(round(tk * 1000))
        np.testing.assert_allclose(q[i], points[k], atol=1e-9)
    np.testing.assert_allclose(qd[[0, -1]], 0.0, atol=1e-12)
    np.testing.assert_allclose(qdd[[0, -1]], 0.0, atol=1e-9)
    # derivatives are consistent (C2: no jumps in velocity or acceleration at the knots)
    np.testing.assert_allclose(np.gradient(q, t, axis=0)[1:-1], qd[1:-1], atol=1e-5)
    np.testing.assert_allclose(np.gradient(qd, t, axis=0)[1:-1], qdd[1:-1], atol=2e-2)
    assert np.abs(np.diff(qdd, axis=0)).max() < 0.05  # no jumps in acceleration (jerk * dt only)


def test_via_velocities_stop_where_the_path_turns():
    vel = via_velocities(np.array([0.0, 1.0, 2.0]), np.array([[0.0, 0.0], [1.0, 1.0], [3.0, 0.0]]))
    np.testing.assert_allclose(vel, [[0, 0], [1.5, 0.0], [0, 0]])


def test_via_quintic_rejects_bad_knots():
    with pytest.raises(ValueError, match="strictly increasing"):
        via_quintic(np.linspace(0, 1, 5), np.array([0.0, 0.0]), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="K >= 2"):
        via_quintic(np.linspace(0, 1, 5), np.array([0.0]), np.zeros((1, 3)))
