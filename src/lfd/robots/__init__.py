"""Robot models: descriptions, batched differentiable kinematics and dynamics, IK, reach tests, URDF.

Pure torch + NumPy (no simulator inside). A :class:`RobotSpec` is the immutable
description (joint chain in URDF form, limits, inertials, base and tool); a
:class:`Robot` evaluates it on batches ``q`` of shape ``(B, n)`` on any device/dtype.
Units: metres, radians, kilograms, seconds; poses are ``(B, 4, 4)`` homogeneous
matrices in the world frame.

Example (runnable)::

    import torch
    from lfd.robots import load_robot

    robot = load_robot("sawyer")                      # also: pr2_right_arm, wam4, human_arm
    q = robot.sample_q(100, torch.Generator().manual_seed(0))   # (100, 7) rad
    pose = robot.fk(q)                                # (100, 4, 4) tool poses
    frames = robot.fk(q, all_links=True)              # (100, 8, 4, 4): 7 links + tool
    jac = robot.jacobian(q)                           # (100, 6, 7), linear rows first
    tau = robot.inverse_dynamics(q, torch.zeros_like(q), torch.zeros_like(q))  # gravity torques
    result = robot.ik(pose)                           # IKResult: q, success, pos/rot errors
    assert result.success.float().mean() >= 0.99
    tips = robot.fk_positions(q.reshape(10, 10, 7))  # (10, 10, 3): any leading dims
    urdf_text = robot.to_urdf()                       # or robot.to_urdf("sawyer.urdf")
"""

from .analytic import wam4_ik_closed_form
from .catalogue import available_robots, load_robot
from .chain import ChainKinematics
from .ik import IKResult, rotation_log, solve_ik, solve_near
from .robot import Robot
from .spec import RobotSpec, make_transform
from .workspace import ReachTest, Workspace

__all__ = [
    "ChainKinematics",
    "IKResult",
    "ReachTest",
    "Robot",
    "RobotSpec",
    "Workspace",
    "available_robots",
    "load_robot",
    "make_transform",
    "rotation_log",
    "solve_ik",
    "solve_near",
    "wam4_ik_closed_form",
]
