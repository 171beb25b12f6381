"""The only owner of PyBullet: reaching scenes, objects, cameras, the scripted expert, simulated
arms, the one joint-trajectory tracker (:mod:`lfd.sim.tracking`) and the collision world with
the one self-collision rule (:mod:`lfd.sim.collision`).

Names are loaded on first use (PEP 562), so the modules without PyBullet
(:mod:`lfd.sim.objects`, :mod:`lfd.sim.approach`, :mod:`lfd.sim.trajectory`, :mod:`lfd.sim.clutter`,
:mod:`lfd.sim.depth`, :mod:`lfd.sim.projection`) import
without a simulator.

Frames and units: every pose is in the robot base (PR2 ``torso_lift_link``) frame, in
metres and radians; the table top lies 0.33 m below it (:data:`TABLE_Z`).

Example (runnable)::

    import numpy as np
    from lfd.robots import load_robot
    from lfd.sim import ReachScene, ScriptedExpert, PlacementRanges, sample_object

    robot = load_robot("pr2_right_arm")
    rng = np.random.default_rng(0)
    obj, placement = sample_object(rng, "cylinder"), PlacementRanges().sample(rng)
    with ReachScene(robot, image_size=64) as scene:
        demo = ScriptedExpert(robot).run(scene, obj, placement)   # or raises DemoDiscarded
    demo.frames.shape, demo.joints.shape, demo.plan.target_point  # (100, 64, 64, 3), (100, 7), (3,)
"""

from typing import TYPE_CHECKING

from lfd._lazy import exports, lazy_getattr

_EXPORTS = exports(
    {
        "approach": [
            "SHOULDER_XY",
            "SIDE_MIN_HEIGHT",
            "TABLE_Z",
            "ApproachPlan",
            "approach_mode",
            "box_grasp_yaw",
            "plan_approach",
            "side_grasp_height",
        ],
        "arms": ["ARMS", "KinematicArm", "PyBulletArm"],
        "collision": ["CollisionReport", "CollisionWorld", "overlapping_link_pairs"],
        "camera": [
            "CAMERA_JITTER",
            "LIGHTING_RANGES",
            "Camera",
            "Lighting",
            "jitter_camera",
            "look_at",
            "perspective",
            "sample_lighting",
        ],
        "projection": ["project_points"],
        "textures": ["TEXTURE_KINDS", "TEXTURE_RANGES", "TableTexture", "sample_table_texture"],
        "clutter": [
            "CLUTTER_RANGES",
            "MAX_CLUTTER",
            "FlatItem",
            "clutter_as_array",
            "clutter_from_array",
            "sample_clutter",
        ],
        "expert": [
            "DISCARD_REASONS",
            "DemoDiscarded",
            "Demonstration",
            "ScriptedExpert",
            "run_demonstration",
        ],
        "objects": [
            "SHAPE_DIMS",
            "SHAPES",
            "ObjectSpec",
            "Placement",
            "PlacementRanges",
            "SIZE_SETS",
            "sample_object",
            "sample_objects",
        ],
        "scene": ["ReachScene"],
        "tracking": [
            "ArmWorld",
            "TrackedPath",
            "execute_joint_trajectory",
            "replay_in_pybullet",
            "track_resampled",
            "track_trajectory",
        ],
        "trajectory": [
            "follow_paths",
            "quintic_coefficients",
            "smoothstep",
            "via_quintic",
            "via_velocities",
            "warp_to_goals",
        ],
    }
)
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_getattr(__name__, _EXPORTS)

if TYPE_CHECKING:
    from .approach import (
        SHOULDER_XY,
        SIDE_MIN_HEIGHT,
        TABLE_Z,
        ApproachPlan,
        approach_mode,
        box_grasp_yaw,
        plan_approach,
        side_grasp_height,
    )
    from .arms import ARMS, KinematicArm, PyBulletArm
    from .camera import (
        CAMERA_JITTER,
        LIGHTING_RANGES,
        Camera,
        Lighting,
        jitter_camera,
        look_at,
        perspective,
        sample_lighting,
    )
    from .clutter import (
        CLUTTER_RANGES,
        MAX_CLUTTER,
        FlatItem,
        clutter_as_array,
        clutter_from_array,
        sample_clutter,
    )
    from .collision import CollisionReport, CollisionWorld, overlapping_link_pairs
    from .expert import DISCARD_REASONS, DemoDiscarded, Demonstration, ScriptedExpert, run_demonstration
    from .objects import (
        SHAPE_DIMS,
        SHAPES,
        SIZE_SETS,
        ObjectSpec,
        Placement,
        PlacementRanges,
        sample_object,
        sample_objects,
    )
    from .projection import project_points
    from .scene import ReachScene
    from .textures import TEXTURE_KINDS, TEXTURE_RANGES, TableTexture, sample_table_texture
    from .tracking import (
        ArmWorld,
        TrackedPath,
        execute_joint_trajectory,
        replay_in_pybullet,
        track_resampled,
        track_trajectory,
    )
    from .trajectory import (
        follow_paths,
        quintic_coefficients,
        smoothstep,
        via_quintic,
        via_velocities,
        warp_to_goals,
    )
