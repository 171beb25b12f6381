"""Tracking a joint trajectory in PyBullet under the URDF's effort and velocity limits.

One tracker, :func:`track_trajectory`, drives every replay of a joint trajectory:

* :func:`replay_in_pybullet`: the Sawyer forward/inverse-model protocol (thesis ch. 5) in
  a :class:`~lfd.sim.scene.ReachScene`, with velocity feed-forward; returns the final tool
  position;
* :func:`execute_joint_trajectory`: teach's Send, the arm alone at 240 Hz, targets clipped
  into the joint limits; returns the measured path;
* :func:`track_resampled`: imitation from video, the reference interpolated onto the
  physics grid, optional renders.

A *world* is any object with ``set_joints(q)``, ``command(q, qd)``, ``step_physics(k)``,
``joint_state()``, ``tool_position()`` (and ``render()`` when frames are asked for):
:class:`ArmWorld` (the arm alone) or :class:`~lfd.sim.scene.ReachScene` (arm, table,
object). Joints are driven by :func:`lfd.sim.joints.command_joints`: position control towards
the target with optional velocity feed-forward, the torque capped at the joint's force limit and
the speed at its velocity limit. Units: rad, rad/s, s, m.

Example::

    >>> import numpy as np
    >>> from lfd.robots import load_robot
    >>> from lfd.sim.tracking import execute_joint_trajectory
    >>> robot = load_robot("wam4")
    >>> t = np.linspace(0.0, 2.0, 50)
    >>> q = robot.home.numpy() + np.outer(t / 2.0, [0.3, 0.2, 0.0, -0.2])
    >>> run = execute_joint_trajectory(robot, t, q)
    >>> run.q.shape, bool(np.abs(run.q[-1] - q[-1]).max() < 0.01)
    ((50, 4), True)
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lfd.sim._pybullet import pybullet as p
from lfd.sim.joints import ArmJoints, command_joints
from lfd.sim.scene import ReachScene

__all__ = [
    "ArmWorld",
    "TrackedPath",
    "command_joints",
    "execute_joint_trajectory",
    "replay_in_pybullet",
    "sample_steps",
    "track_resampled",
    "track_trajectory",
]

#: Physics rate (Hz) of :func:`execute_joint_trajectory`.
EXECUTE_HZ = 240.0


@dataclass(frozen=True)
class TrackedPath:
    """What the simulated arm did: ``t`` (T,) s, measured ``q`` (T, n) rad and ``tool``
    (T, 3) m at the commanded samples (empty ``(0, n)``/``(0, 3)`` when not recorded),
    ``q_final``/``tool_final`` after settling, ``clipped_samples`` (samples with a target
    outside the joint limits) and ``images`` (renders at the requested samples)."""

    t: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    q_final: np.ndarray
    tool_final: np.ndarray
    clipped_samples: int
    images: tuple = ()


class ArmWorld(ArmJoints):
    """The arm alone in its own PyBullet ``p.DIRECT`` client (gravity, fixed base).

    Args:
        robot: :class:`lfd.robots.Robot` (its generated URDF, loaded with
            ``URDF_USE_INERTIA_FROM_FILE``).
        timestep: physics step, s.
        gravity: m/s^2 along world z.
        base_position: (3,) m; base_rotation: (3, 3) rotation of the base in the world.
        max_force: one torque limit (N m) for every joint; None: the URDF effort limits.
        limit_velocity: cap each joint's speed at its URDF velocity limit.
        position_gain, velocity_gain: position-control gains (None: PyBullet's defaults).
        image_size: (width, height) px of :meth:`render`.
    """

    def __init__(
        self,
        robot: Any,
        *,
        timestep: float,
        gravity: float = -9.81,
        base_position: Sequence[float] = (0.0, 0.0, 0.0),
        base_rotation: np.ndarray | None = None,
        max_force: float | None = None,
        limit_velocity: bool = True,
        position_gain: float | None = None,
        velocity_gain: float | None = None,
        image_size: tuple[int, int] = (320, 320),
    ) -> None:
        self.robot, self.n_joints = robot, robot.n_dof
        efforts = robot.effort_limits.numpy().astype(float)
        self.forces = efforts if max_force is None else np.full(self.n_joints, float(max_force))
        speeds = robot.velocity_limits.numpy().astype(float)
        self.max_velocities = speeds if limit_velocity else np.full(self.n_joints, np.inf)
        self.position_gain, self.velocity_gain = position_gain, velocity_gain
        self.size = tuple(image_size)
        orientation = [0.0, 0.0, 0.0, 1.0]
        if base_rotation is not None:
            from scipy.spatial.transform import Rotation

            orientation = Rotation.from_matrix(base_rotation).as_quat().tolist()
        self.client = p.connect(p.DIRECT)
        self._dir = Path(tempfile.mkdtemp(prefix="lfd-arm-"))
        try:
            p.setGravity(0, 0, gravity, physicsClientId=self.client)
            p.setTimeStep(timestep, physicsClientId=self.client)
            urdf = self._dir / f"{robot.name}.urdf"
            robot.to_urdf(urdf)
            self.body = p.loadURDF(
                str(urdf),
                basePosition=list(base_position),
                baseOrientation=orientation,
                useFixedBase=True,
                flags=p.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=self.client,
            )
        except Exception:
            self.close()
            raise

    def set_joints(self, q: np.ndarray) -> None:
        """Teleport the joints to ``q (n,)`` rad at rest (no physics step, motors untouched)."""
        for j in range(self.n_joints):
            p.resetJointState(self.body, j, float(q[j]), 0.0, physicsClientId=self.client)

    def tool_position(self) -> np.ndarray:
        """(3,) tool point (the URDF's last, fixed link) in the world, m."""
        state = p.getLinkState(
            self.body, self.n_joints, computeForwardKinematics=True, physicsClientId=self.client
        )
        return np.array(state[4])

    def render(self) -> np.ndarray:
        """``(H, W, 3)`` uint8 TinyRenderer image from a fixed camera at (1.8, -1.2, 1.5) m looking
        at (0, 0, 0.9) m."""
        w, h = self.size
        view = p.computeViewMatrix([1.8, -1.2, 1.5], [0, 0, 0.9], [0, 0, 1])
        proj = p.computeProjectionMatrixFOV(50, w / h, 0.05, 10)
        img = p.getCameraImage(w, h, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=self.client)[2]
        return np.asarray(img, np.uint8).reshape(h, w, 4)[:, :, :3]

    def close(self) -> None:
        """Disconnect the client and remove the temporary URDF (idempotent)."""
        if self.client is not None:
            p.disconnect(physicsClientId=self.client)
            self.client = None
        shutil.rmtree(self._dir, ignore_errors=True)


def track_trajectory(
    world: Any,
    q: np.ndarray,
    steps: Sequence[int],
    *,
    velocity: np.ndarray | None = None,
    settle_steps: int = 0,
    limits: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    record: bool = True,
    render_at: Collection[int] = (),
    t: np.ndarray | None = None,
) -> TrackedPath:
    """Track ``q (T, n)`` rad in ``world``: the one trajectory tracker.

    The joints start at rest at ``q[0]``; for each sample ``k`` the target ``q[k]`` (with
    feed-forward ``velocity[k]`` if given) is commanded, then ``steps[k]`` physics steps
    run and (with ``record``) the joints and tool are measured; ``render_at`` lists the
    samples after which ``world.render()`` is kept. Then the last target is held, without
    feed-forward, for ``settle_steps`` physics steps.

    Args:
        limits: ``(lower, upper, limited)`` (n,) arrays: targets of the ``limited`` joints
            are clipped into ``[lower, upper]`` (and such samples counted); None: no clipping.
        t: (T,) sample times stored in the result (default ``0..T-1``).

    Raises:
        ValueError: ``steps`` or ``velocity`` do not match ``q``.
    """
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or len(steps) != q.shape[0] or (velocity is not None and velocity.shape != q.shape):
        raise ValueError(f"track_trajectory: need q (T, n), T steps and velocity (T, n); got {q.shape}")
    world.set_joints(q[0])
    qs, tools, images, clipped = [], [], [], 0
    target = q[0]
    for k in range(q.shape[0]):
        target = q[k]
        if limits is not None:
            lower, upper, limited = limits
            clipped += bool((limited & ((target < lower) | (target > upper))).any())
            target = np.where(limited, np.clip(target, lower, upper), target)
        world.command(target, None if velocity is None else velocity[k])
        world.step_physics(int(steps[k]))
        if record:
            qs.append(world.joint_state()[0])
            tools.append(world.tool_position())
        if k in render_at:
            images.append(world.render())
    if settle_steps:
        world.command(target, None if velocity is None else np.zeros_like(target))
        world.step_physics(int(settle_steps))
    n = q.shape[1]
    return TrackedPath(
        t=np.arange(q.shape[0], dtype=float) if t is None else np.array(t, dtype=float),
        q=np.array(qs).reshape(-1, n),
        tool=np.array(tools).reshape(-1, 3),
        q_final=world.joint_state()[0],
        tool_final=world.tool_position(),
        clipped_samples=clipped,
        images=tuple(images),
    )


def sample_steps(t: np.ndarray, rate: float) -> list[int]:
    """Physics steps before each sample of times ``t (T,)`` s at ``rate`` Hz: none before the
    first, then at least one per sample, rounding so the simulated time stays close to ``t``."""
    steps, elapsed = [0], t[0]
    for k in range(1, len(t)):
        n = max(1, int(round((t[k] - elapsed) * rate)))
        elapsed += n / rate
        steps.append(n)
    return steps


def replay_in_pybullet(
    robot: Any, trajectory: np.ndarray, dt: float, substeps: int = 10, settle_steps: int = 25
) -> np.ndarray:
    """Track ``trajectory (T, n)`` (rad, one sample per ``dt`` s) in a
    :class:`~lfd.sim.scene.ReachScene` (URDF limits, self-collision) with velocity
    feed-forward (``np.gradient``), ``substeps`` physics steps per sample, hold the last
    sample for ``settle_steps`` periods, and return the final tool position ``(3,)`` (m,
    robot base frame)."""
    velocity = np.gradient(trajectory, dt, axis=0)
    steps = [0] + [substeps] * (len(trajectory) - 1)
    with ReachScene(robot, image_size=8, control_dt=dt, substeps=substeps) as scene:
        run = track_trajectory(
            scene, trajectory, steps, velocity=velocity, settle_steps=settle_steps * substeps, record=False
        )
    return run.tool_final


def execute_joint_trajectory(robot: Any, t, q, settle: float = 0.5, gravity: float = -9.81) -> TrackedPath:
    """Execute ``q (T, n)`` rad at times ``t (T,)`` s on the arm alone (:class:`ArmWorld`,
    PyBullet's default gains) at :data:`EXECUTE_HZ`: targets clipped into the URDF position
    limits (continuous joints excepted), the URDF effort and velocity limits on the motors;
    the last target held ``settle`` s. Tool positions are in the robot's world frame.

    Raises:
        ValueError: wrong shapes, NaN, times not increasing.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    n = robot.n_dof
    if t.ndim != 1 or q.shape != (t.shape[0], n) or t.shape[0] < 2:
        raise ValueError(
            f"execute_joint_trajectory needs t (T,) and q (T, {n}) with T >= 2, got {t.shape} and {q.shape}"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))) or np.any(np.diff(t) <= 0):
        raise ValueError("execute_joint_trajectory needs finite q and strictly increasing finite t")
    spec = robot.spec
    limits = (np.asarray(spec.lower), np.asarray(spec.upper), ~np.asarray(spec.continuous))
    with ArmWorld(robot, timestep=1.0 / EXECUTE_HZ, gravity=gravity) as world:
        return track_trajectory(
            world,
            q,
            sample_steps(t, EXECUTE_HZ),
            settle_steps=int(round(settle * EXECUTE_HZ)),
            limits=limits,
            t=t,
        )


def track_resampled(
    world: ArmWorld, t: np.ndarray, q_ref: np.ndarray, rate: float, frames_at: np.ndarray | None = None
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Track ``q_ref (T, n)`` rad given at times ``t (T,)`` s, linearly interpolated onto a
    ``rate`` Hz grid (one physics step per grid point; ``world``'s timestep should be
    ``1 / rate``). Returns the executed joints interpolated back at ``t`` ``(T, n)`` and the
    renders at the grid points nearest after each time in ``frames_at``."""
    n = q_ref.shape[1]
    count = int(np.ceil((t[-1] - t[0]) * rate)) + 1
    sim_t = t[0] + np.arange(count) / rate
    targets = np.stack([np.interp(sim_t, t, q_ref[:, j]) for j in range(n)], 1)
    want = set() if frames_at is None else set(np.searchsorted(sim_t, frames_at).tolist())
    run = track_trajectory(world, targets, [1] * count, render_at=want, t=sim_t)
    q_exec = np.stack([np.interp(t, sim_t, run.q[:, j]) for j in range(n)], 1)
    return q_exec, list(run.images)
