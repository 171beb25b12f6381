"""The cases of a closed-loop evaluation: objects at placements, with what the evaluator knows
about them and the policies never see (the approach rule's target, the demonstrated path).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lfd.sim.approach import TABLE_Z, ApproachPlan, plan_approach
from lfd.sim.camera import Lighting
from lfd.sim.clutter import FlatItem, clutter_from_array
from lfd.sim.expert import DemoDiscarded, ScriptedExpert
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.textures import TableTexture
from lfd.visuomotor.eval.scenario import Scenario, load_scenario

__all__ = ["Case", "evaluation_cases"]


@dataclass(frozen=True)
class Case:
    """One object at one placement, with what the evaluation knows about it (the policy
    never sees any of it).

    Attributes:
        object_index, placement_index: position in the scenario / test split.
        obj, placement: the object and where it stands.
        plan: the approach rule's target poses (grasp target point, approach direction).
        demo_ee: ``(T, 3)`` demonstrated tool path, or None if the expert failed here.
        ood: why the case lies outside the training ranges ("" = inside; scenario cases only).
        lighting: the light its dataset episode was recorded under (None: the default light;
            scenario cases and datasets made with ``lighting="fixed"``).
        camera_pose: 9 numbers, the fixed camera's eye, target and up its dataset episode was
            recorded through (:meth:`lfd.sim.camera.Camera.pose_array`; None: the default pose).
        table_texture: the table top its dataset episode was recorded with (None: the plain table).
        clutter: the flat items its dataset episode was recorded with (``()``: none).
    """

    object_index: int
    placement_index: int
    obj: ObjectSpec
    placement: Placement
    plan: ApproachPlan
    demo_ee: np.ndarray | None
    ood: str = ""
    table_z: float = TABLE_Z
    lighting: Lighting | None = None
    camera_pose: tuple[float, ...] | None = None
    table_texture: TableTexture | None = None
    clutter: tuple[FlatItem, ...] = ()

    @property
    def object_centre(self) -> np.ndarray:
        """``(3,)`` the object's centre where it was placed (torso frame)."""
        return np.array([self.placement.x, self.placement.y, self.table_z + self.obj.height / 2])

    @property
    def label(self) -> str:
        p = self.placement
        return f"p{self.placement_index} ({p.x:.2f}, {p.y:+.2f}, {math.degrees(p.yaw):+.0f} deg)"


def _expert_path(expert: ScriptedExpert, scene, obj: ObjectSpec, placement: Placement) -> np.ndarray | None:
    """Tool path ``(T, 3)`` of the scripted expert's demonstration of a case (None if discarded)."""
    try:
        return expert.run(scene, obj, placement).ee_poses[:, :3, 3]
    except DemoDiscarded:
        return None


def evaluation_cases(
    data, scene, scenario_file: Scenario | str | Path | None, split: str = "test", limit: int | None = None
) -> tuple[list[Case], str]:
    """The evaluation cases and a description of their source: every object x placement of
    ``scenario_file`` (a loaded :class:`~lfd.visuomotor.eval.scenario.Scenario`, or a file
    loaded here against ``scene``; its cases get the scripted expert's demonstration, the
    jerk reference, run in ``scene``), else the ``split`` (``"test"``, or ``"val"``: its
    held-out validation objects) of the loaded dataset ``data``; the first ``limit`` (None: all).

    Raises:
        ValueError: the dataset has no such split.
        lfd.visuomotor.eval.scenario.ScenarioError: a bad scenario file.
    """
    table_z = scene.table_z
    if scenario_file is not None:
        gen = data.config
        scenario = (
            scenario_file
            if isinstance(scenario_file, Scenario)
            else load_scenario(
                scenario_file, camera=scene.camera, robot=scene.robot, training=gen, table_z=table_z
            )
        )
        expert = ScriptedExpert(
            scene.robot,
            duration=gen.duration,
            n_steps=gen.n_steps,
            approach_fraction=gen.approach_fraction,
            tolerance=gen.tolerance,
        )
        cases = [
            Case(
                i,
                j,
                obj,
                placement,
                plan_approach(obj, placement, table_z=table_z),
                _expert_path(expert, scene, obj, placement),
                scenario.ood(i, j),
                table_z,
            )
            for i, obj, j, placement in scenario.cases()
        ]
        return cases[:limit], f"scenario {scenario.source}"
    records = data.split("test") if split == "test" else [r for r in data.split("val") if r.group == "val"]
    if not records:
        raise ValueError(
            f"dataset {data.path} has no {split} split; give eval.scenario=FILE or another eval.split"
        )
    cases = [
        Case(
            r.object_index,
            int(r.arrays["placement_index"]),
            r.obj,
            r.placement,
            plan_approach(r.obj, r.placement, table_z=table_z),
            r.arrays["ee_poses"][:, :3, 3],
            "",
            table_z,
            Lighting.from_array(r.arrays["lighting"]) if "lighting" in r.arrays else None,
            tuple(r.arrays["camera_pose"].tolist()) if "camera_pose" in r.arrays else None,
            TableTexture.from_array(r.arrays["table_texture"]) if "table_texture" in r.arrays else None,
            clutter_from_array(r.arrays["clutter"]) if "clutter" in r.arrays else (),
        )
        for r in records
    ]
    return cases[:limit], f"{split} split of {data.path}"
