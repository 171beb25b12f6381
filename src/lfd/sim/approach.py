"""Approach rule: where and how the gripper should end up for a given object placement.

A pure function of the object spec and its placement (torso frame, metres, radians).
Tool-frame convention of the PR2 arm: the tool x-axis points out of the gripper (from
the wrist through the fingertips) and the fingers close along the tool y-axis.

The approach mode is a function of geometry a camera sees (:func:`approach_mode`): the
footprint's shape (round or rectangular) and the object's height.

* **Round objects at least** :data:`SIDE_MIN_HEIGHT` **tall** (cylinders, capsules and
  spheres: symmetric about their vertical axis) are approached **from the side**: tool x
  horizontal, tool z up, the grasp point on the object's axis at :func:`side_grasp_height`.
  The horizontal approach direction is the direction from the right shoulder
  (:data:`SHOULDER_XY`) to the object. The object's yaw does not enter: it is invisible for
  a rotationally symmetric object (a policy could never infer it from an image), and
  approaching along the object's yaw direction is often out of reach (IK success over the
  default placement ranges: about 78 %, 60 % at ``|yaw| > 45`` degrees, against 99-100 %
  along the shoulder-to-object line, which is always "from the robot side").
* **Everything else** -- boxes, and round objects lower than :data:`SIDE_MIN_HEIGHT` (tins,
  small balls), which the PR2's forearm cannot reach from the side without touching the
  table -- is approached **from the top**: tool x pointing down. A box looks the same
  after a 90 degree turn (up to its aspect ratio), so the wrist roll follows the yaw modulo
  90 degrees: the fingers close across the box axis nearest the torso x-axis, at the yaw
  folded into ``[-45, 45)`` degrees (:func:`box_grasp_yaw`). A round object's yaw is
  invisible, so its fingers close along the torso x-axis (roll 0, the middle of the box
  range). The grasp point is on the vertical axis, ``finger_depth`` below the top.

The plan holds three tool poses, each ``(4, 4)`` homogeneous in the torso frame:
``grasp_pose`` (tool at the grasp point), ``pregrasp_pose`` (backed off along the approach
direction until the tool origin is ``clearance`` from the object's surface) and
``approach_pose`` (another ``approach_offset`` further back). A demonstration ends at the
pre-grasp pose, so its position, :attr:`ApproachPlan.target_point` (the *grasp target
point*), is the point evaluation measures the final end-effector distance to. Box grasps
are 99 % reachable over the default ranges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lfd.sim.objects import ObjectSpec, Placement

#: Horizontal position (m) of the PR2 right shoulder-pan axis in the torso frame.
SHOULDER_XY = (0.0, -0.188)
#: Height (m) of the table top in the torso frame.
TABLE_Z = -0.33
#: Lowest round object (m) approached from the side. The PR2 forearm and gripper links are
#: 4-5 cm radius cylinders: over 12 placements each, the scripted side approach touched the
#: table every time for a cylinder 5.5 cm high and a ball of 2.75 cm radius, and never for
#: 6 cm and 3 cm (docs/decisions.md).
SIDE_MIN_HEIGHT = 0.06


@dataclass(frozen=True)
class ApproachPlan:
    """Target poses for one object placement (torso frame, ``(4, 4)`` float64 each).

    Attributes:
        mode: ``"side"`` or ``"top"``.
        grasp_pose: tool pose with the tool origin at the object's grasp point.
        pregrasp_pose: end pose of a demonstration (``clearance`` off the object's surface).
        approach_pose: via pose before the pre-grasp (a further ``approach_offset`` back).
    """

    mode: str
    grasp_pose: np.ndarray
    pregrasp_pose: np.ndarray
    approach_pose: np.ndarray

    @property
    def approach_dir(self) -> np.ndarray:
        """``(3,)`` unit direction the gripper moves in when closing in on the object
        (the tool x-axis)."""
        return self.grasp_pose[:3, 0].copy()

    @property
    def grasp_point(self) -> np.ndarray:
        """``(3,)`` point on the object the fingers would close on."""
        return self.grasp_pose[:3, 3].copy()

    @property
    def target_point(self) -> np.ndarray:
        """``(3,)`` the grasp target point: where a demonstration's tool frame ends (the
        pre-grasp position) and what evaluation measures the final distance to."""
        return self.pregrasp_pose[:3, 3].copy()


def approach_mode(spec: ObjectSpec) -> str:
    """``"side"`` for a round object (cylinder, capsule, sphere) at least
    :data:`SIDE_MIN_HEIGHT` tall, ``"top"`` for boxes and lower round objects."""
    return "side" if spec.round and spec.height >= SIDE_MIN_HEIGHT else "top"


def side_grasp_height(spec: ObjectSpec, min_height: float = 0.08) -> float:
    """Height (m) above the table of the side grasp point: the object's mid-height, but at
    least ``min_height`` (the forearm and gripper links are 4-5 cm radius cylinders that
    must stay clear of the table) and never above the object's top."""
    return min(max(spec.height / 2, min_height), spec.height)


def box_grasp_yaw(yaw: float) -> float:
    """Closing-axis yaw (rad) for a box with yaw ``yaw``: ``yaw`` folded by the box's 90
    degree symmetry into ``[-pi/4, pi/4)``."""
    quarter = math.pi / 2
    return (yaw + quarter / 2) % quarter - quarter / 2


def plan_approach(
    spec: ObjectSpec,
    placement: Placement,
    *,
    clearance: float = 0.03,
    approach_offset: float = 0.10,
    finger_depth: float = 0.02,
    table_z: float = TABLE_Z,
    mode: str | None = None,
) -> ApproachPlan:
    """Grasp, pre-grasp and approach tool poses for ``spec`` at ``placement`` (module
    docstring has the rule).

    Args:
        spec: the object.
        placement: its table position and yaw (torso frame).
        clearance: metres between the object's surface and the tool origin at the
            pre-grasp pose, along the approach direction (>= 0).
        approach_offset: metres from the pre-grasp back to the approach position (>= 0).
        finger_depth: how far (m) below the top of an object approached from the top the
            grasp point lies; capped at half the object's height.
        table_z: height of the table top in the torso frame.
        mode: ``"side"`` or ``"top"`` to override the rule (:func:`approach_mode`, the
            default ``None``), e.g. to see why the rule says otherwise.
    """
    for label, value in (
        ("clearance", clearance),
        ("approach_offset", approach_offset),
        ("finger_depth", finger_depth),
    ):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"plan_approach: {label} must be finite and >= 0 m, got {value}")
    if mode is None:
        mode = approach_mode(spec)
    elif mode not in ("side", "top"):
        raise ValueError(f"plan_approach: mode must be 'side', 'top' or None, got {mode!r}")
    if mode == "side":
        dx, dy = placement.x - SHOULDER_XY[0], placement.y - SHOULDER_XY[1]
        norm = math.hypot(dx, dy)
        if norm < 1e-6:
            raise ValueError(f"plan_approach: placement {placement} lies on the shoulder axis")
        x_axis = np.array([dx / norm, dy / norm, 0.0])
        z_axis = np.array([0.0, 0.0, 1.0])
        y_axis = np.cross(z_axis, x_axis)
        height = side_grasp_height(spec)
        backoff = spec.dims[0] + clearance  # every round shape's first dim is its radius
    else:
        psi = 0.0 if spec.round else box_grasp_yaw(placement.yaw)
        x_axis = np.array([0.0, 0.0, -1.0])
        y_axis = np.array([math.cos(psi), math.sin(psi), 0.0])
        z_axis = np.cross(x_axis, y_axis)
        depth = min(finger_depth, spec.height / 2)
        height = spec.height - depth
        backoff = depth + clearance
    grasp = np.eye(4)
    grasp[:3, :3] = np.stack([x_axis, y_axis, z_axis], axis=1)
    grasp[:3, 3] = (placement.x, placement.y, table_z + height)
    pregrasp = _backed_off(grasp, backoff)
    approach = _backed_off(pregrasp, approach_offset)
    return ApproachPlan(mode=mode, grasp_pose=grasp, pregrasp_pose=pregrasp, approach_pose=approach)


def _backed_off(pose: np.ndarray, distance: float) -> np.ndarray:
    """``pose`` moved ``distance`` metres back along its own x-axis."""
    out = pose.copy()
    out[:3, 3] -= distance * pose[:3, 0]
    return out
