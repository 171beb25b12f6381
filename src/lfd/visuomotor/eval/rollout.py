"""Closed loops: a visuomotor policy's controller in a :class:`~lfd.sim.scene.ReachScene`
(:func:`run_episode`), and learned forward + inverse models driving simulated arms
(:func:`closed_loop_reach`).

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

:func:`closed_loop_reach` (the Sawyer protocol of thesis ch. 5) needs no camera: a forward
model estimates the tool position from the measured joints and an inverse model turns the
estimated error into joint velocities for a batch of arms (:mod:`lfd.sim.arms`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import Tensor

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


@dataclass(frozen=True)
class ReachTrace:
    """One closed-loop reach driven by the models.

    Attributes:
        t: ``(T,)`` times (s). q: ``(T, n)`` joints (rad).
        x: ``(T, 3)`` true end-effector positions (robot FK, m).
        x_model: ``(T, 3)`` forward-model estimates (m).
        reached: the estimated error fell below the threshold before the step cap.
    """

    t: np.ndarray
    q: np.ndarray
    x: np.ndarray
    x_model: np.ndarray
    reached: bool

    def final_error(self, goal: np.ndarray) -> float:
        """True final distance (m) to ``goal``."""
        return float(np.linalg.norm(self.x[-1] - goal))


def closed_loop_reach(
    forward: Callable[[Tensor], Tensor],
    inverse: Callable[[Tensor], Tensor],
    robot,
    goals: np.ndarray,
    q_start: np.ndarray,
    arm,
    max_steps: int = 300,
    threshold: float = 0.02,
) -> list[ReachTrace]:
    """Drive ``B`` arms from ``q_start (n,)`` towards ``goals (B, 3)`` (m).

    Every step: ``x_hat = forward(q)``; arms whose ``||x_hat - goal||`` is below
    ``threshold`` (m) stop; the others get ``qd = inverse(x_hat - goal)`` clamped to the
    robot's velocity limits. ``forward`` maps float32 joints ``(B, n)`` to positions
    ``(B, 3)`` (the forward model), ``inverse`` errors ``(B, 3)`` to joint velocities
    ``(B, n)`` (a task's inverse model); ``arm`` is a :class:`~lfd.sim.arms.KinematicArm`
    or :class:`~lfd.sim.arms.PyBulletArm` (its ``dt`` is the control period).

    Returns:
        One :class:`ReachTrace` per goal, each ending at its stop (or at the cap).
    """
    goals = np.asarray(goals, dtype=np.float64)
    if goals.ndim != 2 or goals.shape[1] != 3 or not np.all(np.isfinite(goals)):
        raise ValueError(
            f"closed_loop_reach: goals must be finite (B, 3) positions (m), got shape {goals.shape}"
        )
    if max_steps < 0 or not threshold > 0:
        raise ValueError(
            f"closed_loop_reach: need max_steps >= 0 and threshold > 0 m, got {max_steps}, {threshold}"
        )
    limit = robot.velocity_limits.numpy()
    q = arm.reset(np.repeat(np.asarray(q_start, dtype=np.float64)[None], len(goals), axis=0))
    active = np.ones(len(goals), dtype=bool)
    stop = np.full(len(goals), max_steps)
    qs, estimates = [q], []
    with torch.no_grad():
        for step in range(max_steps + 1):
            x_hat = forward(torch.from_numpy(q).float()).double().numpy()
            estimates.append(x_hat)
            arrived = active & (np.linalg.norm(x_hat - goals, axis=1) < threshold)
            stop[arrived] = step
            active &= ~arrived
            if step == max_steps or not active.any():
                break
            qd = np.clip(inverse(torch.from_numpy(x_hat - goals).float()).double().numpy(), -limit, limit)
            q = arm.step(np.where(active[:, None], qd, 0.0))
            qs.append(q)
    arm.close()
    qs, estimates = np.stack(qs, axis=1), np.stack(estimates, axis=1)
    truth = robot.fk_positions(qs).numpy()
    return [
        ReachTrace(
            t=np.arange(n + 1) * arm.dt,
            q=qs[b, : n + 1],
            x=truth[b, : n + 1],
            x_model=estimates[b, : n + 1],
            reached=not active[b],
        )
        for b, n in enumerate(stop)
    ]
