"""lfd.imitation.settings: configs/imitate.yaml as typed settings, one-line errors naming the field, the
robots offered taken from the catalogue, and no import circle between the pipeline and its helpers."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

from lfd.imitation import ImitationSettings, imitation_robots
from lfd.imitation.settings import RefineSettings
from lfd.robots.catalogue import catalogue_entries

ROOT = Path(__file__).resolve().parents[2]


def _composed(*overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="imitate", overrides=list(overrides))


def test_the_config_defaults_are_the_settings_defaults():
    """The YAML and the dataclasses agree: a plain config is ImitationSettings()."""
    assert ImitationSettings.from_mapping(_composed()) == ImitationSettings()


def test_documented_overrides_become_typed_values():
    s = ImitationSettings.from_mapping(
        _composed(
            "source=[cam01.mp4,cam02.mp4]",
            "calibration=Calib.qca.txt",
            "goal=[0.3,-0.5,0.2]",
            "refine.task=reach",
            "refine.target=[0.40,0.28,0.17]",
            "refine.method=pibb",
            "outputs.bag=null",
        )
    )
    assert s.source == ("cam01.mp4", "cam02.mp4") and s.demonstration == ["cam01.mp4", "cam02.mp4"]
    assert s.goal == (0.3, -0.5, 0.2) and s.refine.target == (0.40, 0.28, 0.17)
    assert s.refine.method == "pibb" and s.outputs.bag is None


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("robot=ur5", "robot must be one of pr2_right_arm, sawyer, wam4, panda, iiwa14, got 'ur5'"),
        ("side=middle", "side must be one of left, right, got 'middle'"),
        ("wam_mount=top", "wam_mount must be one of auto, side"),
        ("source_type=pdf", "source_type must be one of video, multiview"),
        ("units=km", "units must be one of m, cm, mm"),
        ("goal=[1,2]", r"goal must be a tool position \[x, y, z\] in metres \(or None\), got \[1, 2\]"),
        ("pose.model=tiny", "pose.model must be one of full, heavy"),
        ("pose.stride=0", "pose.stride must be an integer >= 1, got 0"),
        ("pose.min_visibility=2", r"pose.min_visibility must be a finite number in \[0, 1\], got 2"),
        ("multiview.up=[0,0,0]", "multiview.up must be a non-zero vector"),
        ("pose.person=tallest", r"pose.person must be one of largest, central, a point \[x, y\] or a box"),
        ("pose.person=[1,2,3]", r"pose.person must be one of largest, central, .* got \[1, 2, 3\]"),
        ("pose.person=[5,5,1,1]", r"pose.person box \[x0, y0, x1, y1\] must have x1 > x0 and y1 > y0"),
        ("multiview.person_view=-1", "multiview.person_view must be an integer >= 0, got -1"),
        ("analysis.sex=other", "analysis.sex must be one of male, female"),
        ("analysis.cutoff=-1", "analysis.cutoff must be a finite number > 0, got -1"),
        ("dmp.n_basis=zero", "dmp.n_basis must be a positive integer or 'auto'"),
        ("sim.image_size=[32]", r"sim.image_size must be \[width, height\]"),
        ("refine.task=push", "refine.task must be one of reach, via_point, avoid"),
        ("refine.task=reach", "refine.target must be a tool position"),
        ("refine.max_rollouts=1", "refine.max_rollouts must be an integer >= 2"),
        ("outputs.bag=ros3", "outputs.bag must be one of ros1, ros2, mcap"),
        ("+pose.speed=1", "pose must have keys among .*stride, width, got unknown speed"),
    ],
)
def test_a_bad_value_is_one_line_naming_the_field(override, message):
    with pytest.raises(ValueError, match=message) as error:
        ImitationSettings.from_mapping(_composed(override))
    assert "\n" not in str(error.value)


def test_settings_are_frozen_and_checked_when_built_in_python():
    s = ImitationSettings(source="arm.bag")
    with pytest.raises(AttributeError):
        s.robot = "sawyer"  # type: ignore[misc]
    with pytest.raises(ValueError, match="refine.target"):
        RefineSettings(task="reach")
    with pytest.raises(ValueError, match="source: give the demonstration"):
        _ = ImitationSettings().demonstration


def test_robots_come_from_the_catalogue():
    offered = {e.name for e in catalogue_entries() if e.retarget is not None}
    assert set(imitation_robots()) == offered and "human_arm" not in offered
    for name in offered:
        assert ImitationSettings(robot=name).robot == name


def _imports(path: Path) -> set[str]:
    """Modules of lfd.imitation that ``path`` imports (anywhere in it, functions included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            found.add((node.module or "").split(".")[0])
        elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith("lfd.imitation."):
            found.add(node.module.split(".")[2])
    return found


def test_no_module_of_the_package_imports_the_pipeline():
    package = ROOT / "src" / "lfd" / "imitation"
    for path in package.glob("*.py"):
        if path.stem not in ("pipeline", "__init__"):
            assert "pipeline" not in _imports(path), path.name
