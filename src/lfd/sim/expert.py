"""Scripted expert: reaching demonstrations executed in a :class:`~lfd.sim.scene.ReachScene`.

A demonstration (:meth:`ScriptedExpert.run`):

1. :func:`~lfd.sim.approach.plan_approach` gives the approach and pre-grasp tool poses;
2. the robot's IK solves both (seeding described in :class:`ScriptedExpert`);
3. a piecewise-quintic joint trajectory start -> via posture -> approach -> pre-grasp, at
   rest at both ends (:meth:`ScriptedExpert.trajectory`), sampled at ``n_steps`` times
   ``linspace(0, duration, n_steps)``;
4. executed with position control (velocity feed-forward) one sample at a time, recording
   per sample the RGB frame(s), joint positions/velocities, tool pose and object pose.

It is discarded (:class:`DemoDiscarded`, with one of :data:`DISCARD_REASONS`) when IK
fails, the arm touches the table or the object, or the tool ends more than ``tolerance``
from the target point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from lfd.sim.approach import ApproachPlan, plan_approach
from lfd.sim.objects import ObjectSpec, Placement
from lfd.sim.scene import ReachScene
from lfd.sim.trajectory import via_quintic

#: Why a demonstration can be discarded.
DISCARD_REASONS = ("ik_failed", "table_collision", "object_collision", "tracking_error")


class DemoDiscarded(Exception):
    """A demonstration that must not enter a dataset; ``reason`` is in :data:`DISCARD_REASONS`."""

    def __init__(self, reason: str, detail: str) -> None:
        if reason not in DISCARD_REASONS:
            raise ValueError(f"DemoDiscarded: reason must be one of {DISCARD_REASONS}, got {reason!r}")
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


@dataclass
class Demonstration:
    """One recorded demonstration; ``T = n_steps`` samples, arrays float64 unless noted.

    Attributes:
        t: ``(T,)`` sample times (s), ``linspace(0, duration, T)``.
        joints, velocities: ``(T, 7)`` measured joint positions (rad) and velocities (rad/s).
        ee_poses: ``(T, 4, 4)`` measured tool poses (torso frame).
        object_poses: ``(T, 4, 4)`` object poses (torso frame).
        frames: ``(T, H, W, 3)`` uint8 fixed-camera RGB frames.
        wrist_frames: ``(T, H, W, 3)`` uint8 wrist-camera frames, or None.
        depth: ``(T, H, W)`` uint16 fixed-camera depth (mm), or None (``record_depth``).
        plan: the approach plan; ``plan.target_point`` is the demonstration's target.
        q_approach, q_pregrasp: ``(7,)`` IK solutions for the two target poses.
        final_error: distance (m) from the final tool position to ``plan.target_point``.
    """

    t: np.ndarray
    joints: np.ndarray
    velocities: np.ndarray
    ee_poses: np.ndarray
    object_poses: np.ndarray
    frames: np.ndarray
    wrist_frames: np.ndarray | None
    plan: ApproachPlan
    q_approach: np.ndarray
    q_pregrasp: np.ndarray
    final_error: float
    depth: np.ndarray | None = None


#: PR2 right-arm postures (degrees, chain order) near which the IK of each approach mode
#: is solved, picked by a search over IK solutions for IK success and table clearance
#: across the placement ranges: "side" keeps the elbow up and out (the IK branch found
#: from the start pose drops the elbow and forearm into the table), "top" reaches over
#: the table with the gripper pointing down.
NOMINAL_POSTURES_DEG = {
    "side": (-36.0, 34.0, -135.0, -131.0, 126.0, -101.0, -85.0),
    "top": (-5.0, 33.0, -48.0, -89.0, -131.0, -124.0, -32.0),
}
#: Index of the PR2 shoulder-lift joint (positive = arm down), raised at the via posture.
SHOULDER_LIFT = 1
#: Reference objects whose centre-of-workspace pre-grasp poses pin the nominal postures.
_REFERENCE_OBJECTS = {
    "side": ObjectSpec("cylinder", (0.035, 0.16), (0.5, 0.5, 0.5, 1.0), 0.2, "reference-cylinder"),
    "top": ObjectSpec("box", (0.06, 0.06, 0.08), (0.5, 0.5, 0.5, 1.0), 0.2, "reference-box"),
}
_REFERENCE_PLACEMENT = Placement(0.575, 0.0, 0.0)


class ScriptedExpert:
    """Plans and records reaching demonstrations for one robot.

    IK consistency: every approach pose is solved by a single Levenberg-Marquardt run
    (no random restarts) seeded at a fixed per-mode *nominal* configuration -- the IK
    solution, started from :data:`NOMINAL_POSTURES_DEG`, of a reference object at the
    centre of the workspace -- and the pre-grasp pose is seeded at the approach solution.
    Nearby placements therefore get nearby joint targets on one IK branch (a smooth
    image -> joint-goal map to learn), and a target that this local solve cannot reach is
    discarded as ``"ik_failed"``. Continuous joints are unwrapped to the angle nearest
    their seed.

    Args:
        robot: robot model (:func:`lfd.robots.load_robot`).
        duration: seconds; n_steps: samples ``linspace(0, duration, n_steps)``.
        approach_fraction: fraction of ``duration`` at which the approach pose is reached.
        via_fraction, via_lift: timing (fraction of ``duration``) and shoulder raise (rad)
            of the via posture (:meth:`trajectory`).
        tolerance: maximum final tool distance (m) to the target point.
        record_depth: also record the fixed camera's depth (``Demonstration.depth``).
    """

    def __init__(
        self,
        robot,
        *,
        duration: float = 4.0,
        n_steps: int = 100,
        approach_fraction: float = 0.75,
        via_fraction: float = 0.375,
        via_lift: float = 0.3,
        tolerance: float = 0.01,
        record_depth: bool = False,
    ) -> None:
        if n_steps < 2 or not 0 < via_fraction < approach_fraction < 1 or not duration > 0:
            raise ValueError(
                f"ScriptedExpert: need duration > 0, n_steps >= 2 and 0 < via_fraction < approach_fraction < 1, "
                f"got {duration}, {n_steps}, {via_fraction}, {approach_fraction}"
            )
        self.robot = robot
        self.duration, self.n_steps = float(duration), int(n_steps)
        self.approach_fraction = float(approach_fraction)
        self.via_fraction, self.via_lift = float(via_fraction), float(via_lift)
        self.tolerance = float(tolerance)
        self.record_depth = bool(record_depth)
        self.home = _numpy(robot.home)
        self.continuous = _numpy(robot.continuous).astype(bool)
        self.seeds = {}
        for mode, obj in _REFERENCE_OBJECTS.items():
            posture = np.radians(NOMINAL_POSTURES_DEG[mode])
            seed = self._solve(plan_approach(obj, _REFERENCE_PLACEMENT).pregrasp_pose, posture)
            if seed is None:
                raise RuntimeError(
                    f"ScriptedExpert: no IK solution near the nominal {mode} posture for {robot!r}"
                )
            self.seeds[mode] = seed

    @property
    def t(self) -> np.ndarray:
        """``(n_steps,)`` sample times (s)."""
        return np.linspace(0.0, self.duration, self.n_steps)

    def _solve(self, pose: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
        res = self.robot.ik(torch.as_tensor(pose[None]), q0=torch.as_tensor(seed[None]), restarts=0)
        if not bool((res.success & self.robot.within_limits(res.q))[0]):
            return None
        q = _numpy(res.q[0])
        return np.where(self.continuous, seed + np.remainder(q - seed + np.pi, 2 * np.pi) - np.pi, q)

    def joint_targets(self, plan: ApproachPlan) -> tuple[np.ndarray, np.ndarray]:
        """IK for ``plan``'s approach then pre-grasp pose -> ``(q_approach, q_pregrasp)``.

        Raises:
            DemoDiscarded: ``"ik_failed"`` if either pose has no solution.
        """
        q_app = self._solve(plan.approach_pose, self.seeds[plan.mode])
        q_pre = None if q_app is None else self._solve(plan.pregrasp_pose, q_app)
        if q_pre is None:
            which = "approach" if q_app is None else "pre-grasp"
            raise DemoDiscarded("ik_failed", f"no IK solution for the {which} pose")
        return q_app, q_pre

    def trajectory(self, q_approach: np.ndarray, q_pregrasp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Planned joint positions and velocities ``(n_steps, 7)``: start -> via -> approach
        -> pre-grasp, piecewise quintic, at rest at both ends. The via posture, at
        ``via_fraction`` of the duration, is the joint-space midpoint of the start and
        approach postures with the shoulder raised by ``via_lift`` rad, so the forearm
        swings in above the table instead of cutting through it."""
        via = (self.home + q_approach) / 2
        via[SHOULDER_LIFT] -= self.via_lift
        knots_t = np.array([0.0, self.via_fraction, self.approach_fraction, 1.0]) * self.duration
        q, qd, _ = via_quintic(self.t, knots_t, np.stack([self.home, via, q_approach, q_pregrasp]))
        return q, qd

    def run(self, scene: ReachScene, spec: ObjectSpec, placement: Placement) -> Demonstration:
        """Plan, execute and record one demonstration (module docstring); ``scene`` must
        have ``control_dt = duration / (n_steps - 1)``.

        Raises:
            DemoDiscarded: IK failure, arm-table or arm-object contact, or final tool
                position more than ``tolerance`` from ``plan.target_point``.
        """
        if not np.isclose(scene.control_dt, self.duration / (self.n_steps - 1)):
            raise ValueError(
                f"ScriptedExpert.run: scene.control_dt={scene.control_dt} must equal duration / (n_steps - 1) "
                f"= {self.duration / (self.n_steps - 1)}"
            )
        plan = plan_approach(spec, placement, table_z=scene.table_z)
        q_app, q_pre = self.joint_targets(plan)
        q_plan, qd_plan = self.trajectory(q_app, q_pre)
        scene.reset(spec, placement, q=self.home)
        keys = ("joints", "velocities", "ee_poses", "object_poses", "frames", "wrist_frames", "depth")
        rec: dict[str, list] = {k: [] for k in keys}
        t = self.t
        for k in range(self.n_steps):
            if k > 0:
                scene.step(q_plan[k], qd_plan[k])
                for body in ("table", "object"):
                    if scene.arm_touches(body):
                        raise DemoDiscarded(f"{body}_collision", f"arm touched the {body} at t={t[k]:.2f} s")
            q, qd = scene.joint_state()
            rec["joints"].append(q)
            rec["velocities"].append(qd)
            rec["ee_poses"].append(scene.ee_pose())
            rec["object_poses"].append(scene.object_pose())
            if self.record_depth:
                rgb, depth = scene.render(with_depth=True)
                rec["frames"].append(rgb)
                rec["depth"].append(depth)
            else:
                rec["frames"].append(scene.render())
            if scene.wrist_camera:
                rec["wrist_frames"].append(scene.render_wrist())
        arrays = {k: np.stack(v) if v else None for k, v in rec.items()}
        error = float(np.linalg.norm(arrays["ee_poses"][-1, :3, 3] - plan.target_point))
        if error > self.tolerance:
            raise DemoDiscarded(
                "tracking_error",
                f"final tool position {error * 100:.2f} cm from the target (tolerance {self.tolerance * 100:.2f} cm)",
            )
        return Demonstration(t=t, plan=plan, q_approach=q_app, q_pregrasp=q_pre, final_error=error, **arrays)


def _numpy(x) -> np.ndarray:
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    return np.array(x, dtype=np.float64)


def run_demonstration(
    scene: ReachScene,
    spec: ObjectSpec,
    placement: Placement,
    *,
    duration: float = 4.0,
    n_steps: int = 100,
    approach_fraction: float = 0.75,
    tolerance: float = 0.01,
) -> Demonstration:
    """One demonstration of ``spec`` at ``placement`` by a :class:`ScriptedExpert` for
    ``scene.robot`` (see :meth:`ScriptedExpert.run`)."""
    expert = ScriptedExpert(
        scene.robot,
        duration=duration,
        n_steps=n_steps,
        approach_fraction=approach_fraction,
        tolerance=tolerance,
    )
    return expert.run(scene, spec, placement)
