"""Filters, gap filling and swap repair."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from lfd.human.cleaning import fill_gaps, repair_swaps
from lfd.human.filters import (
    butterworth_filter,
    butterworth_sos,
    filter_positions,
    hampel_filter,
    median_filter,
)
from lfd.human.fit import fit_derivatives, fit_polynomial, fit_spline


@pytest.mark.parametrize(("cutoff", "rate", "order"), [(6.0, 30.0, 2), (4.0, 100.0, 4), (10.0, 30.0, 2)])
def test_butterworth_double_pass_is_minus_3db_at_the_cutoff(cutoff, rate, order):
    sos = butterworth_sos(cutoff, rate, order)
    _, h = signal.sosfreqz(sos, worN=[cutoff], fs=rate)
    assert abs(h[0]) ** 2 == pytest.approx(1 / np.sqrt(2), rel=1e-6)  # forward-backward = |H|^2
    # without the correction the zero-phase response would be -6 dB at the cutoff
    _, h_naive = signal.sosfreqz(signal.butter(order, cutoff, fs=rate, output="sos"), worN=[cutoff], fs=rate)
    assert abs(h_naive[0]) ** 2 == pytest.approx(0.5, rel=1e-6)


def test_butterworth_zero_phase_and_nan_segments():
    t = np.arange(300) / 30.0
    x = np.sin(2 * np.pi * 0.5 * t)[:, None]
    y = butterworth_filter(x, 30.0, 6.0)
    assert np.abs(y - x)[20:-20].max() < 1e-3  # 0.5 Hz passes, no delay
    x[100:130] = np.nan
    y = butterworth_filter(x, 30.0, 6.0)
    assert np.isnan(y[100:130]).all() and np.isfinite(y[:100]).all() and np.isfinite(y[130:]).all()
    with pytest.raises(ValueError, match="cutoff must be in"):
        butterworth_filter(x, 30.0, 20.0)


def test_median_and_hampel_remove_spikes():
    rng = np.random.default_rng(0)
    x = np.sin(np.linspace(0, 6, 200))[:, None] + rng.normal(0, 0.01, (200, 1))
    spiky = x.copy()
    spiky[[50, 120, 121]] += 1.0
    assert np.abs(median_filter(spiky, 5) - x).max() < 0.1
    cleaned, mask = hampel_filter(spiky, 7, 3.0)
    assert mask[[50, 120, 121], 0].all() and mask.sum() <= 0.15 * len(
        x
    )  # few false alarms, each replaced by a median
    assert np.abs(cleaned - x).max() < 0.1
    with pytest.raises(ValueError, match="odd"):
        median_filter(x, 4)
    with pytest.raises(ValueError, match="filter must be one of"):
        filter_positions(x, 30.0, "kalman")


def test_fill_gaps_short_only():
    t = np.arange(100) / 30.0
    pos = np.tile(np.linspace(0, 1, 100)[:, None, None], (1, 1, 3))
    valid = np.ones((100, 1), bool)
    valid[10:14] = False  # 4 frames: 5/30 s without data -> filled with the default 0.2 s
    valid[40:60] = False  # 20 frames: kept as a gap
    filled, gaps = fill_gaps(t, pos, valid, ("wrist_right",), max_gap=0.2)
    np.testing.assert_allclose(filled[10:14], pos[10:14])
    assert np.isnan(filled[40:60]).all()
    assert [(g.start, g.stop, g.filled) for g in gaps] == [(10, 14, True), (40, 60, False)]
    filled, _ = fill_gaps(t, pos, valid, ("wrist_right",), max_gap=1.0)
    np.testing.assert_allclose(filled[40:60], pos[40:60])


def test_swap_repaired():
    t = np.arange(120) / 30.0
    names = ("shoulder_left", "elbow_left", "shoulder_right", "elbow_right")
    pos = np.zeros((120, 4, 3))
    pos[:, 0] = [0.2, 1.4, 2.5]
    pos[:, 1] = np.c_[0.25 + 0.05 * np.sin(t), 1.1 + 0 * t, 2.5 + 0 * t]
    pos[:, 2] = [-0.2, 1.4, 2.5]
    pos[:, 3] = np.c_[-0.25 - 0.05 * np.sin(t), 1.1 + 0 * t, 2.5 + 0 * t]
    bad = pos.copy()
    bad[40:70] = bad[40:70][:, [2, 3, 0, 1]]
    fixed, swapped = repair_swaps(bad, names)
    np.testing.assert_allclose(fixed, pos)
    assert swapped[40:70, 0].all() and not swapped[:40].any() and not swapped[70:].any()


def test_fits_recover_derivatives():
    t = np.arange(0, 10, 1 / 30)
    y = np.c_[np.sin(1.3 * t), 0.5 * np.cos(0.7 * t)]
    dy = np.c_[1.3 * np.cos(1.3 * t), -0.35 * np.sin(0.7 * t)]
    ddy = np.c_[-1.69 * np.sin(1.3 * t), -0.245 * np.cos(0.7 * t)]
    for fit in (fit_polynomial, fit_spline):
        v, d, dd, _ = fit(t, y)
        assert (
            np.abs(v - y).max() < 2e-3
            and np.abs(d - dy)[15:-15].max() < 0.02
            and np.abs(dd - ddy)[15:-15].max() < 0.1
        )
    # the CV picks a low order for a line with noise and a higher one for a fast sine
    rng = np.random.default_rng(0)
    ts = t[:120]
    data = np.c_[2 * ts + rng.normal(0, 0.01, 120), np.sin(3 * ts)]
    _, _, _, info = fit_polynomial(ts, data, max_order=12)
    assert info["orders"][0, 0] <= 3 and info["orders"][0, 1] >= 6
    q = np.c_[y, y]
    q[100:110] = np.nan
    v, d, dd = fit_derivatives(t, q, "polynomial")
    assert np.isnan(v[100:110]).all() and np.isfinite(dd[:100]).all()
    with pytest.raises(ValueError, match="fit must be one of"):
        fit_derivatives(t, q, "fourier")


def _arm_motion(noise: float, seed: int = 0, rate: float = 30.0, seconds: float = 6.0):
    """Three points (a still shoulder, a moving elbow and wrist: 1.2 Hz with a 3.6 Hz component), metres,
    with white noise of ``noise`` m."""
    t = np.arange(0.0, seconds, 1.0 / rate)
    phase = 2 * np.pi * 1.2 * t
    shoulder = np.zeros((len(t), 3))
    elbow = np.stack(
        [0.3 * np.sin(phase) + 0.03 * np.sin(3 * phase), -0.3 * np.cos(phase), 0.05 * np.sin(2 * phase)], 1
    )
    wrist = elbow * 1.8
    clean = np.stack([shoulder, elbow, wrist], 1)
    rng = np.random.default_rng(seed)
    return clean + rng.normal(0.0, noise, clean.shape), clean, rate


def test_noise_level_recovers_white_noise_and_ignores_the_frame():
    from scipy.spatial.transform import Rotation

    from lfd.human.filters import noise_level

    for sigma in (0.002, 0.01, 0.02):
        noisy, _, _ = _arm_motion(sigma, seed=3)
        assert noise_level(noisy) == pytest.approx(sigma, rel=0.2), sigma
        turned = noisy @ Rotation.from_euler("xyz", [30, -50, 70], degrees=True).as_matrix().T
        assert noise_level(turned) == pytest.approx(noise_level(noisy), rel=1e-9)


def test_auto_cutoff_is_the_discrepancy_principle():
    """The chosen cutoff is the highest whose residual still holds the estimated noise (the next one up
    leaves less than the noise); it falls as the noise grows and does not depend on the frame."""
    from scipy.spatial.transform import Rotation

    from lfd.human.filters import AUTO_CUTOFFS, auto_cutoff, butterworth_filter, noise_level

    cut = {}
    for sigma in (0.0005, 0.005, 0.02):
        noisy, _, rate = _arm_motion(sigma, seed=1)
        cut[sigma] = c = auto_cutoff(noisy, rate)
        level = noise_level(noisy)

        def residual(f, x=noisy, rate=rate):
            return np.sqrt(np.mean((x - butterworth_filter(x, rate, f)) ** 2))

        higher = [f for f in AUTO_CUTOFFS if c < f <= 0.4 * rate]
        assert c == AUTO_CUTOFFS[0] or residual(c) >= level, (sigma, c)
        assert all(residual(f) < level for f in higher), (sigma, c)
        turned = noisy @ Rotation.from_euler("zyx", [10, 20, 80], degrees=True).as_matrix().T
        assert auto_cutoff(turned, rate) == c
    assert cut[0.0005] > cut[0.005] > cut[0.02], cut
    assert auto_cutoff(np.full((5, 3, 3), 0.1), 30.0) == 6.0  # too few frames: the default
    with pytest.raises(ValueError, match=r"\(T, \.\.\., 3\)"):
        auto_cutoff(np.zeros((50, 4)), 30.0)
