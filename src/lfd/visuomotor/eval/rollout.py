"""The closed loop of a visuomotor policy: its controller in a :class:`~lfd.sim.scene.ReachScene`
(:func:`run_episode`).

The policy is reached only through its controller (:class:`lfd.visuomotor.protocols.Controller`,
from :meth:`lfd.visuomotor.policies.VisuomotorPolicy.controller`), which receives an
:class:`~lfd.visuomotor.protocols.Observation`: the fixed camera's image, the measured joint
angles and the robot's clock (seconds since the episode started), nothing else. The scene
(and with it the object's pose) never leaves :func:`run_episode`, so no policy can be given
the object pose by construction.

Every command is clamped into the joint limits before execution: a position target (with
no velocity feed-forward on the clamped joints), or a velocity that would leave the limits
within one control period (reduced to land on the limit); the number of steps whose command
needed it is counted as joint-limit violations. The scene caps velocities and torques at
the URDF limits (:class:`~lfd.sim.scene.ReachScene`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from lfd.sim.depth import rgbd_image
from lfd.visuomotor.protocols import Controller, Observation


def observe(scene, controller: Controller) -> np.ndarray:
    """The fixed camera's image in the form ``controller``'s policy takes: RGB ``(H, W, 3)``,
    or RGB-D ``(H, W, 4)`` uint8 when it takes 4 input channels (one render call), its depth
    channel in the controller's ``depth_encoding`` (``"relief"``: against the scene's table
    plane)."""
    if controller.input_channels == 4:
        relief = controller.depth_encoding == "relief"
        reference = scene.camera.plane_depth_mm(scene.table_z) if relief else None
        return rgbd_image(*scene.render(with_depth=True), reference)
    return scene.render()


@dataclass
class EpisodeTrace:
    """What happened in one closed-loop episode.

    Attributes:
        joints: ``(S + 1, n)`` measured joint angles (start + after each step), rad.
        ee_poses: ``(S + 1, 4, 4)`` tool poses (torso frame).
        limit_violations: control steps whose command lay outside the joint limits.
        latencies_ms: wall time of each policy call, ms.
        frames: uint8 frames for a GIF (every ``frame_every`` steps), empty unless asked.
        table_contact_steps, object_contact_steps: control steps before the end (the
            states after steps ``0 .. S - 1``) at which an arm link touched the table / the
            object (:meth:`~lfd.sim.scene.ReachScene.arm_touches`).
        object_displacement: distance (m) the object's centre moved from the start to the
            end of the episode (0 without an object).
    """

    joints: np.ndarray
    ee_poses: np.ndarray
    limit_violations: int
    latencies_ms: list[float]
    frames: list[np.ndarray] = field(default_factory=list)
    table_contact_steps: int = 0
    object_contact_steps: int = 0
    object_displacement: float = 0.0


def run_episode(
    scene, controller: Controller, steps: int, lower: np.ndarray, upper: np.ndarray, record_every: int = 0
) -> EpisodeTrace:
    """Run ``controller`` for ``steps`` control steps in ``scene`` (already reset with the object).

    Args:
        scene: a :class:`~lfd.sim.scene.ReachScene` (never handed to the controller).
        controller: the policy's :class:`~lfd.visuomotor.protocols.Controller` (executed as its
            ``actuation`` says).
        lower, upper: ``(n,)`` joint limits used to clamp commands (``-inf``/``inf`` for
            continuous joints).
        record_every: keep a camera frame every this many steps for a GIF (0: none).
    """
    controller.start(steps)
    latencies: list[float] = []
    frames: list[np.ndarray] = []
    joints, poses = [], []
    violations = table_contacts = object_contacts = 0
    probe = hasattr(scene, "arm_touches")  # stand-in scenes in tests have no contacts
    has_object = probe and getattr(scene, "object_id", -1) >= 0
    start = scene.object_pose()[:3, 3] if has_object else None
    for step in range(steps + 1):
        q, _ = scene.joint_state()
        joints.append(q)
        poses.append(scene.ee_pose())
        if probe and 0 < step < steps:
            table_contacts += int(scene.arm_touches("table"))
            object_contacts += int(has_object and scene.arm_touches("object"))
        recording = record_every and step % record_every == 0
        image = observe(scene, controller) if controller.needs_image or recording else None
        if recording:
            frames.append(image[..., :3])
        if step == steps:
            break
        obs = Observation(image=image, joints=q, time=step * controller.dt)
        q_target, qd_target = controller.command(obs, step, latencies)
        clamped = np.clip(q_target, lower, upper)
        outside = clamped != q_target
        violations += int(outside.any())
        if controller.actuation == "velocity":
            # the commanded velocity, reduced where it would leave the limits within the period
            scene.step_velocity(np.where(outside, (clamped - q) / controller.dt, qd_target))
        else:
            scene.step(clamped, np.where(outside, 0.0, qd_target))
    moved = float(np.linalg.norm(scene.object_pose()[:3, 3] - start)) if has_object else 0.0
    return EpisodeTrace(
        np.stack(joints),
        np.stack(poses),
        violations,
        latencies,
        frames,
        table_contacts,
        object_contacts,
        moved,
    )
