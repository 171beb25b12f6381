"""lfd.teach.settings: configs/teach/teach.yaml as typed settings with one-line errors naming the field,
the robots offered taken from the catalogue, and the entry point building the session and server from them."""

from __future__ import annotations

import dataclasses
import importlib.util

import pytest
from hydra import compose, initialize_config_dir
from teach_helpers import ROOT

from lfd.robots.catalogue import catalogue_entries
from lfd.teach import IKSettings, TeachSession, TeachSettings, teach_robots


def _script():
    spec = importlib.util.spec_from_file_location("teach_script", ROOT / "scripts" / "teach.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _composed(*overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs" / "teach"), version_base="1.3"):
        return compose("teach", overrides=list(overrides))


def test_the_config_defaults_are_the_settings_defaults():
    s = _script().settings_of(_composed())
    assert s.scene == str(ROOT / "configs" / "teach" / "boxes.yaml")
    assert dataclasses.replace(s, scene=None, export_dir=TeachSettings().export_dir) == TeachSettings()


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("robot=ur5", "unknown robot 'ur5'; choose one of: pr2_right_arm, sawyer, wam4"),
        ("robot=human_arm", "not a teachable arm"),
        ("port=70000", "port must be an integer in 0..65535"),
        ("token=s3cret", "token must be auto, true or false"),
        ("mode=4d", "mode must be one of 3d, 2d"),
        ("ik.time_budget=0", "ik.time_budget must be a finite number > 0, got 0"),
        ("ik.max_joint_step=-1", "ik.max_joint_step must be a finite number > 0, got -1"),
        ("ik.wam_q3=loose", "ik.wam_q3 must be one of fixed, free"),
        ("margin=-0.1", "margin must be a finite number >= 0, got -0.1"),
        ("duration_s=-1", r"duration_s must be a finite number >= 0 \(or None\), got -1"),
        (
            "+ik.speed=1",
            "ik must have keys among max_joint_step, orientation_weight, time_budget, wam_q3, got unknown speed",
        ),
        ("ik.orientation_weight=-1", "ik.orientation_weight must be a finite number >= 0, got -1"),
        ("idle_speed=0", "idle_speed must be a finite number > 0, got 0"),
        ("trim_idle=maybe", "trim_idle must be true or false"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_field(override, message):
    with pytest.raises(ValueError, match=message) as error:
        _script().settings_of(_composed(override))
    assert "\n" not in str(error.value)


def test_robots_come_from_the_catalogue():
    assert set(teach_robots()) == {e.name for e in catalogue_entries() if e.teach}
    assert "human_arm" not in teach_robots()


def test_session_from_settings():
    settings = TeachSettings(robot="sawyer", mode="2d", ik=IKSettings(max_joint_step=0.3), panel_speed=0.4)
    s = TeachSession.from_settings(settings)
    try:
        assert s.robot_name == "sawyer" and s.mode == "2d" and s.max_joint_step == 0.3
        assert s.settings == settings and s.panel_speed == 0.4 and not s.scene.obstacles
    finally:
        s.close()
    with pytest.raises(ValueError, match="panel_speed must be a finite number > 0"):
        TeachSession(robot="wam4", panel_speed=0.0)
