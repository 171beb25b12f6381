"""Evaluation metrics: Wilson intervals, jerk, approach angle, the summary layout."""

import math

import numpy as np
import pytest

from lfd.visuomotor.eval.metrics import (
    approach_angle_deg,
    integrated_squared_jerk,
    summarise,
    wilson_interval,
)


def test_wilson_interval_known_values():
    # 8 of 10: the textbook Wilson 95 % interval is (0.490, 0.943)
    low, high = wilson_interval(8, 10)
    assert low == pytest.approx(0.4902, abs=1e-4) and high == pytest.approx(0.9433, abs=1e-4)
    # extremes stay inside [0, 1] and are not degenerate
    assert wilson_interval(0, 20)[0] == 0.0 and 0.1 < wilson_interval(0, 20)[1] < 0.2
    assert wilson_interval(20, 20)[1] == 1.0 and 0.8 < wilson_interval(20, 20)[0] < 0.9
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


def test_integrated_squared_jerk_of_a_cubic_is_analytic():
    dt = 0.01
    t = np.arange(50) * dt
    path = np.stack([2.0 * t**3, np.zeros_like(t), -(t**3)], axis=-1)  # jerk (12, 0, -6) everywhere
    # 47 third differences, each |j|^2 = 180, times dt
    assert integrated_squared_jerk(path, dt) == pytest.approx(180 * 47 * dt, rel=1e-6)
    assert integrated_squared_jerk(np.stack([path, 2 * path]), dt) == pytest.approx(
        [180 * 0.47, 720 * 0.47], rel=1e-6
    )
    line = np.stack([t, t, t], axis=-1)
    assert integrated_squared_jerk(line, dt) == pytest.approx(0.0, abs=1e-6)
    # resting after a motion that ends at rest (a quintic) changes nothing; a mean would halve
    u = np.linspace(0.0, 1.0, 101)
    quintic = (10 * u**3 - 15 * u**4 + 6 * u**5)[:, None] * np.array([0.3, 0.0, 0.1])
    rest = np.concatenate([quintic, np.repeat(quintic[-1:], 100, axis=0)])
    assert integrated_squared_jerk(rest, dt) == pytest.approx(integrated_squared_jerk(quintic, dt), rel=0.05)


def test_approach_angle():
    assert approach_angle_deg([1, 0, 0], [0, 0, -1]) == pytest.approx(90.0)
    assert approach_angle_deg([0, 0, -2], [0, 0, -1]) == pytest.approx(0.0)
    assert approach_angle_deg([1, 0, -1], [0, 0, -1]) == pytest.approx(45.0)


def test_summarise_layout_and_values():
    d = np.array([0.01, 0.03, 0.04, 0.10])
    out = summarise(
        d,
        [True, True, False, True],
        jerk=[2.0, 4.0, 2.0, 40.0],
        demo_jerk=[1.0, 2.0, 1.0, np.nan],
        limit_violations=[0, 3, 0, 1],
        latency_ms=[1.0, 2.0, 3.0],
    )
    assert out["episodes"] == 4
    assert out["final_distance_m"]["mean"] == pytest.approx(0.045)
    assert out["final_distance_m"]["median"] == pytest.approx(0.035)
    assert out["success_5cm"] == 0.75 and out["success_2cm"] == 0.25
    assert out["success_5cm_ci"] == pytest.approx(list(wilson_interval(3, 4)))
    assert out["approach_correct"] == 0.5  # the 10 cm episode is not correct (distance condition)
    assert out["jerk_ratio"] == pytest.approx(8.0 / 4.0)  # the episode without a demonstration is left out
    assert out["jerk_ratio_median"] == pytest.approx(2.0)
    assert out["joint_limit_violations"] == 4
    assert out["latency_ms"]["median"] == 2.0
    assert summarise(d, [True] * 4, [1.0] * 4, [np.nan] * 4, [0] * 4, [1.0])["jerk_ratio"] is None
    assert all(not (isinstance(v, float) and math.isnan(v)) for v in out.values())
