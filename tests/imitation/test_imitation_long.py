"""Long recordings: the DMP's basis count grows with the demonstration's duration (``dmp.n_basis=auto``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

import lfd.imitation
from lfd.imitation import ImitationSettings, basis_count
from lfd.imitation.settings import DMPSettings
from lfd.robots import load_robot

ROOT = Path(__file__).resolve().parents[2]


def _cfg(*overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return ImitationSettings.from_mapping(
            compose(config_name="imitate", overrides=["outputs.video=false", "outputs.gif=false", *overrides])
        )


def test_basis_count_grows_with_duration_and_rejects_bad_values():
    auto = DMPSettings(n_basis="auto", basis_per_second=10.0, min_basis=30)
    assert basis_count(auto, 2.0) == 30  # short clips keep the minimum
    assert basis_count(auto, 16.2) == 162
    assert basis_count(DMPSettings(n_basis=25), 100.0) == 25
    for bad in (0, -3, "many", 2.5, True):
        with pytest.raises(ValueError, match="dmp.n_basis must be a positive integer or 'auto'"):
            DMPSettings(n_basis=bad)
    with pytest.raises(ValueError, match="dmp.basis_per_second must be a finite number > 0"):
        DMPSettings(basis_per_second=-1.0)
    with pytest.raises(ValueError, match="dmp.n_basis"):
        _cfg("dmp.n_basis=zero")


def test_a_long_recording_of_repetitions_is_followed(tmp_path):
    """20 s of five repetitions with 1 Hz detail (a joint CSV): 30 bases cannot follow it, the automatic
    count (200) can; the reference is the recording itself."""
    robot = load_robot("wam4")
    t = np.arange(0.0, 20.0, 1 / 30)
    home = robot.home.numpy()
    amp = np.array([0.5, 0.4, 0.3, 0.6])
    q = home + amp * np.sin(2 * np.pi * t / 4.0)[:, None] + 0.1 * np.sin(2 * np.pi * 1.0 * t)[:, None]
    q = np.clip(q, robot.lower.numpy() + 0.05, robot.upper.numpy() - 0.05)
    path = tmp_path / "arm.csv"
    rows = [",".join(["time", *robot.joint_names])] + [
        ",".join(f"{v:.6f}" for v in (ti, *qi)) for ti, qi in zip(t, q)
    ]
    path.write_text("\n".join(rows) + "\n")
    fixed = lfd.imitation.run(_cfg(f"source={path}", "robot=wam4", "dmp.n_basis=30"), tmp_path / "fixed")
    auto = lfd.imitation.run(_cfg(f"source={path}", "robot=wam4"), tmp_path / "auto")
    assert fixed["dmp_n_basis"] == 30 and auto["dmp_n_basis"] == 200
    assert fixed["dmp_vs_reference_rmse_rad"] > 0.05
    assert auto["dmp_vs_reference_rmse_rad"] <= 0.01
    assert auto["limit_violations"] == 0 and auto["executed_vs_dmp_rmse_rad"] <= 0.1
