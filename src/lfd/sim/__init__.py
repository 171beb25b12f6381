"""PyBullet reaching scenes, objects, cameras and the scripted expert.

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

from .approach import SHOULDER_XY, TABLE_Z, ApproachPlan, box_grasp_yaw, plan_approach, side_grasp_height
from .camera import Camera, look_at, perspective, project_points
from .expert import DISCARD_REASONS, DemoDiscarded, Demonstration, ScriptedExpert, run_demonstration
from .objects import SHAPE_DIMS, SHAPES, ObjectSpec, Placement, PlacementRanges, sample_object, sample_objects
from .scene import ReachScene
from .trajectory import quintic_coefficients, via_quintic, via_velocities

__all__ = [
    "DISCARD_REASONS",
    "SHAPES",
    "SHAPE_DIMS",
    "SHOULDER_XY",
    "TABLE_Z",
    "ApproachPlan",
    "Camera",
    "DemoDiscarded",
    "Demonstration",
    "ObjectSpec",
    "Placement",
    "PlacementRanges",
    "ReachScene",
    "ScriptedExpert",
    "box_grasp_yaw",
    "look_at",
    "perspective",
    "plan_approach",
    "project_points",
    "quintic_coefficients",
    "run_demonstration",
    "sample_object",
    "sample_objects",
    "side_grasp_height",
    "via_quintic",
    "via_velocities",
]
