"""Stages of lfd.imitation called from the package, on synthetic data (no video, no MediaPipe)."""

from __future__ import annotations

import numpy as np
import pytest

import lfd.imitation
from lfd.dmp import DMP
from lfd.imitation import ImitationSettings
from lfd.imitation.settings import DMPSettings, OutputSettings, SimSettings
from lfd.robots import load_robot


def _cfg(**over):
    return ImitationSettings(
        dmp=DMPSettings(n_basis=20),
        sim=SimSettings(image_size=(32, 32)),
        outputs=OutputSettings(video=False, gif=False, gif_frames=5),
        **over,
    )


def test_fill_missing_interpolates_inside_and_drops_the_ends():
    t = np.arange(8, dtype=float)
    x = np.arange(8, dtype=float)[:, None].repeat(3, 1)
    x[[0, 3, 7]] = np.nan
    t2, x2 = lfd.imitation.fill_missing(t, x)
    np.testing.assert_array_equal(t2, np.arange(1, 7))
    np.testing.assert_allclose(x2[:, 0], np.arange(1, 7))
    with pytest.raises(ValueError, match="need at least 4"):
        lfd.imitation.fill_missing(t[:3], x[1:4] * 0)


def test_fit_dmp_then_execute_keep_the_robot_limits(tmp_path):
    robot = load_robot("wam4")
    t = np.linspace(0.0, 1.0, 60)
    # a fast motion: 2 rad in 1 s on the elbow needs time scaling
    q = robot.home.numpy() + np.outer(0.5 - 0.5 * np.cos(np.pi * t), [0.5, 0.3, 0.0, 2.0])
    cfg = _cfg()
    fit = lfd.imitation.fit_dmp(cfg, robot, t, q, tmp_path)
    saved = DMP.load(tmp_path / "dmp.json")  # the file is what its name says
    np.testing.assert_allclose(saved.weights_, fit.dmp.weights_)
    assert fit.factor >= 1.0 and fit.t_robot[-1] == pytest.approx(fit.factor * t[-1], rel=1e-6)
    speed = np.abs(np.diff(fit.q_dmp, axis=0) / np.diff(fit.t_robot)[:, None])
    assert (speed <= robot.velocity_limits.numpy() * 1.05).all()
    run = lfd.imitation.execute(cfg, robot, np.eye(3), fit, q[-1])
    assert run.q_exec.shape == q.shape and run.goal is None and run.images == []
    assert np.sqrt(np.mean((run.q_exec - fit.q_dmp) ** 2)) < 0.05


def test_config_errors():
    with pytest.raises(ValueError, match="robot must be one of"):
        _cfg(robot="ur5")
    with pytest.raises(ValueError, match="side must be"):
        _cfg(side="middle")
