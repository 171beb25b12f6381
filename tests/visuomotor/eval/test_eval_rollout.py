"""Closed-loop controllers and the episode loop, against a scripted stand-in scene."""

import numpy as np
import pytest

from lfd.visuomotor.eval.rollout import run_episode
from lfd.visuomotor.policies.control import PlanController, VelocityController
from lfd.visuomotor.protocols import Controller

N = 3
DT = 0.1


class IdealScene:
    """Tracks every command exactly; renders a frame that encodes the step number."""

    table_z = -0.33

    def __init__(self):
        self.q = np.zeros(N)
        self.commands = []
        self.renders = 0

    def joint_state(self):
        return self.q.copy(), np.zeros(N)

    def ee_pose(self):
        pose = np.eye(4)
        pose[:3, 3] = self.q
        return pose

    def render(self):
        self.renders += 1
        return np.full((4, 4, 3), len(self.commands), dtype=np.uint8)

    def step(self, q_target, qd_target):
        self.commands.append((np.array(q_target), np.array(qd_target)))
        self.q = np.array(q_target, dtype=float)

    def step_velocity(self, qd_target):
        """Velocity control: the joints move at the commanded velocity."""
        self.commands.append((self.q + DT * np.asarray(qd_target), np.array(qd_target)))
        self.q = self.q + DT * np.asarray(qd_target, dtype=float)


class LinePlanner:
    kind = "cnn_dmp"
    input_channels, depth_encoding = 3, "range"

    def __init__(self):
        self.calls, self.horizons = [], []

    def plan(self, image, joints, n_steps=None):
        """A 5-sample line whatever the horizon asked for (shorter plans are held)."""
        self.calls.append((image.copy(), joints.copy()))
        self.horizons.append(n_steps)
        return joints + np.linspace(0.0, 1.0, 5)[:, None] * np.array([1.0, 2.0, 3.0])


class ConstantVelocity:
    kind = "velocity"
    input_channels, depth_encoding = 3, "range"

    def __init__(self, qd):
        self.qd, self.calls = np.asarray(qd, dtype=float), []

    def act(self, image, joints, time):
        self.calls.append((image.copy(), joints.copy(), time))
        return self.qd


LIMITS = (np.array([-1.0, -1.0, -np.inf]), np.array([1.0, 1.5, np.inf]))


def test_plan_controller_plans_once_tracks_then_holds():
    scene, policy = IdealScene(), LinePlanner()
    trace = run_episode(scene, PlanController(policy, DT), steps=7, lower=LIMITS[0], upper=LIMITS[1])
    assert len(policy.calls) == 1 and scene.renders == 1  # one image, at the start
    assert policy.horizons == [8]  # a plan for the whole episode: start + 7 steps
    targets = np.array([c[0] for c in scene.commands])
    plan = np.linspace(0.0, 1.0, 5)[:, None] * np.array([1.0, 2.0, 3.0])
    expected = np.clip(np.concatenate([plan[1:], np.repeat(plan[-1:], 3, axis=0)]), *LIMITS)
    np.testing.assert_allclose(targets, expected)
    # joint 1 (limit 1.5) is clamped from plan sample 4 on (step 3 + 3 holding steps):
    # counted, and no feed-forward on it there
    assert trace.limit_violations == 4
    ff = np.array([c[1] for c in scene.commands])
    assert np.all(ff[3:, 1] == 0.0) and np.all(ff[:3, 1] > 0)
    assert np.all(ff[4:] == 0.0)  # holding after the plan: at rest
    assert trace.joints.shape == (8, N) and trace.ee_poses.shape == (8, 4, 4)
    assert len(trace.latencies_ms) == 1


def test_velocity_controller_acts_every_step_on_fresh_observations():
    scene, policy = IdealScene(), ConstantVelocity([0.5, -20.0, 1.0])
    trace = run_episode(
        scene, VelocityController(policy, DT), steps=4, lower=LIMITS[0], upper=LIMITS[1], record_every=2
    )
    assert len(policy.calls) == 4 and len(trace.latencies_ms) == 4
    # each call sees the frame and the joints measured at that step
    for k, (image, joints, time) in enumerate(policy.calls):
        assert image[0, 0, 0] == k
        np.testing.assert_allclose(joints, trace.joints[k])
        assert time == pytest.approx(k * DT)  # the robot's clock, s since the start
    np.testing.assert_allclose(trace.joints[1], [0.05, -1.0, 0.1])  # q + qd dt, joint 1 clamped
    assert trace.limit_violations == 4
    assert [f[0, 0, 0] for f in trace.frames] == [0, 2, 4]


def test_no_frames_recorded_unless_asked():
    trace = run_episode(
        IdealScene(), PlanController(LinePlanner(), DT), steps=3, lower=LIMITS[0], upper=LIMITS[1]
    )
    assert trace.frames == []


@pytest.mark.parametrize("controller", [PlanController, VelocityController])
def test_policy_calls_carry_only_image_and_joints(controller):
    policy = LinePlanner() if controller is PlanController else ConstantVelocity(np.zeros(N))
    assert isinstance(controller(policy, DT), Controller)
    run_episode(IdealScene(), controller(policy, DT), steps=3, lower=LIMITS[0], upper=LIMITS[1])
    for image, joints, *time in policy.calls:
        assert image.shape == (4, 4, 3) and image.dtype == np.uint8 and joints.shape == (N,)
        assert all(isinstance(t, float) for t in time)


def test_executed_joint_velocity_matches_the_command_in_pybullet():
    """The velocity baseline's actuation executes what the policy commands
    (within 5 %), for speeds like the demonstrations' and inside the URDF limits."""
    from lfd.robots import load_robot
    from lfd.sim.scene import ReachScene

    robot = load_robot("pr2_right_arm")
    qd = np.array(
        [0.3, 0.25, 0.2, 0.3, -0.4, -0.3, 0.5]
    )  # rad/s, below every velocity limit, away from the joint limits
    dt = 4.0 / 99
    lower = np.where(robot.continuous.numpy(), -np.inf, robot.lower.numpy())
    upper = np.where(robot.continuous.numpy(), np.inf, robot.upper.numpy())
    with ReachScene(robot, image_size=8, control_dt=dt, substeps=10) as scene:
        trace = run_episode(
            scene, VelocityController(ConstantVelocity(qd), dt), steps=25, lower=lower, upper=upper
        )
    assert trace.limit_violations == 0
    executed = np.diff(trace.joints, axis=0)[5:] / dt  # after a 0.2 s start
    np.testing.assert_allclose(executed.mean(0), qd, rtol=0.05)
    assert np.abs(executed - qd).max() < 0.05 * np.abs(qd).max()


def test_scene_applies_urdf_effort_and_velocity_limits():
    """A step command far away moves no joint faster than its URDF limit."""
    from lfd.robots import load_robot
    from lfd.sim.scene import ReachScene

    robot = load_robot("pr2_right_arm")
    limits = robot.velocity_limits.numpy()
    with ReachScene(robot, image_size=8) as scene:
        np.testing.assert_allclose(scene.forces, robot.effort_limits.numpy())
        assert scene.self_collision and scene.overlapping_links  # on, with the by-construction pairs off
        target = scene.joint_state()[0] + np.array([1.5, -1.0, 1.5, 1.0, 2.0, 1.0, 2.0])
        speeds = []
        for _ in range(15):
            scene.step(target, np.zeros(7))
            speeds.append(np.abs(scene.joint_state()[1]))
    assert np.max(np.stack(speeds) / limits) <= 1.05
