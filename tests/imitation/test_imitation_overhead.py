"""An arm raised above the head (a real UI-PRMD shoulder abduction, m07) to the Sawyer: the scaled wrist
path is kept inside the robot's reach, so the tool follows it and the DMP the retargeted joints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from hydra import compose, initialize_config_dir

import lfd.imitation
from lfd.human.retarget import retarget_wrist_path
from lfd.imitation import ImitationSettings
from lfd.imitation.pipeline import fill_missing
from lfd.robots import load_robot

ROOT = Path(__file__).resolve().parents[2]
ABDUCTION = (
    ROOT
    / "tests"
    / "fixtures"
    / "human"
    / "ui_prmd"
    / "Kinect"
    / "Positions"
    / "m07_s04_e01_positions.txt.gz"
)


def _cfg(*overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return ImitationSettings.from_mapping(
            compose(config_name="imitate", overrides=["outputs.video=false", "outputs.gif=false", *overrides])
        )


def test_overhead_abduction_stays_in_the_sawyers_reach(tmp_path):
    cfg = _cfg(f"source={ABDUCTION}", "robot=sawyer", "side=right")
    analysis = lfd.imitation.analyse_skeleton(cfg, str(ABDUCTION), tmp_path)
    _, positions = fill_missing(analysis.t, analysis.positions)
    s, e, w = positions[:, 0], positions[:, 1], positions[:, 2]
    model = load_robot("sawyer")
    shoulder = model.fk(model.home[None], all_links=True)[0, 1, :3, 3].numpy()
    # the person's wrist spans more than the arm's length (hanging down to above the head)
    assert np.ptp(w[:, 2] - s[:, 2]) > 0.8 * np.median(
        np.linalg.norm(w - e, axis=1) + np.linalg.norm(e - s, axis=1)
    )
    fitted = retarget_wrist_path(s, e, w, robot="sawyer")
    unbounded = retarget_wrist_path(s, e, w, robot="sawyer", within_reach=False)
    # centred on the home tool at the full scale, the path leaves the workspace: the tool misses by decimetres
    assert unbounded.error.max() > 0.2
    assert fitted.scale < unbounded.scale
    # inside the reach: the tool (robot FK, independent of the IK's own error) follows every target within 1 cm
    tool = model.fk(torch.from_numpy(fitted.q)).numpy()[:, :3, 3]
    assert np.linalg.norm(tool - fitted.target, axis=1).max() < 0.01
    reach = np.quantile(
        np.linalg.norm(
            model.fk(model.sample_q(2048, torch.Generator().manual_seed(0))).numpy()[:, :3, 3] - shoulder,
            axis=1,
        ),
        0.95,
    )
    assert np.linalg.norm(fitted.target - shoulder, axis=1).max() <= 0.8 * reach + 1e-9
    # same shape: the targets are the wrist path (relative to the shoulder) scaled
    rel = w - s
    np.testing.assert_allclose((fitted.target - fitted.target[0]) / fitted.scale, rel - rel[0], atol=1e-9)
    assert np.abs(np.diff(fitted.q, axis=0)).max() < 0.5  # no IK branch jump between frames

    summary = lfd.imitation.run(cfg, tmp_path / "run")
    assert summary["limit_violations"] == 0 and summary["clamped_frames"] == 0
    assert summary["dmp_vs_reference_rmse_rad"] <= 0.05
    assert summary["executed_vs_dmp_rmse_rad"] <= 0.1
