"""The velocity baseline's labels and actuation agree: commanding the labels
the policy is trained on, by the velocity controller used in evaluation, reproduces the
demonstration they were made from."""

from types import SimpleNamespace

import numpy as np
import pytest
import torch

from lfd.visuomotor.data.datasets import VelocityReachDataset, command_velocities
from lfd.visuomotor.eval.rollout import run_episode
from lfd.visuomotor.policies.control import VelocityController
from lfd.visuomotor.policies.velocity import LABEL, VelocityPolicy


class Replay:
    """A 'policy' that commands a fixed sequence of velocities ``(T, n)``, indexed by time."""

    input_channels, depth_encoding = 3, "range"

    def __init__(self, qd: np.ndarray, dt: float) -> None:
        self.qd, self.dt = qd, dt

    def act(self, image, joints, time):
        return self.qd[min(int(round(time / self.dt)), len(self.qd) - 1)]


@pytest.fixture(scope="module")
def replayed():
    """One scripted demonstration, then two velocity-controlled replays from its start:
    of the training labels and of the recorded (instantaneous) joint velocities."""
    from lfd.robots import load_robot
    from lfd.sim.expert import ScriptedExpert
    from lfd.sim.objects import Placement, sample_object
    from lfd.sim.scene import ReachScene

    robot = load_robot("pr2_right_arm")
    expert = ScriptedExpert(robot)
    dt = expert.duration / (expert.n_steps - 1)
    lower = np.where(robot.continuous.numpy(), -np.inf, robot.lower.numpy())
    upper = np.where(robot.continuous.numpy(), np.inf, robot.upper.numpy())
    obj, placement = sample_object(np.random.default_rng(7), "box"), Placement(0.6, -0.1, 0.5)
    with ReachScene(robot, image_size=8, control_dt=dt) as scene:
        demo = expert.run(scene, obj, placement)
        # the dataset's item for the velocity network, built like the training items
        record = SimpleNamespace(
            arrays={"joints": demo.joints, "velocities": demo.velocities, "t": demo.t},
            index=0,
            frames=lambda: demo.frames,
        )
        items = VelocityReachDataset(SimpleNamespace(split=lambda split: [record], path="demo"), "train")
        runs = {}
        for name, qd in (("label", items.tensors[LABEL].double().numpy()), ("recorded", demo.velocities)):
            scene.reset(obj, placement, q=robot.home.numpy())
            runs[name] = run_episode(
                scene, VelocityController(Replay(qd, dt), dt), expert.n_steps - 1, lower, upper
            )
    return demo, items, runs


def test_commanding_the_labels_reproduces_the_demonstration(replayed):
    demo, items, runs = replayed
    trace = runs["label"]
    np.testing.assert_allclose(trace.joints, demo.joints, atol=0.02)
    assert np.linalg.norm(trace.ee_poses[-1, :3, 3] - demo.ee_poses[-1, :3, 3]) < 0.01


def test_recorded_instantaneous_velocities_are_not_the_command(replayed):
    """The regression: the recorded velocities (the old label) are a fraction of the motion
    per period under the demonstrations' position control; commanded, they leave the arm far
    from the demonstration's end (the baseline's 25-45 cm failure)."""
    demo, items, runs = replayed
    moved = np.abs(demo.joints[-1] - demo.joints[0]).sum()
    assert np.abs(demo.velocities.sum(0) * (demo.t[1] - demo.t[0])).sum() < 0.6 * moved
    assert np.linalg.norm(runs["recorded"].ee_poses[-1, :3, 3] - demo.ee_poses[-1, :3, 3]) > 0.1
    assert not torch.allclose(items.tensors[LABEL], items.tensors["velocity"], atol=0.05)


def test_command_velocities_are_the_next_periods_mean_velocity():
    q = np.array([[0.0, 1.0], [0.1, 1.0], [0.3, 0.8], [0.3, 0.8]])
    t = np.array([0.0, 0.5, 1.0, 1.5])
    np.testing.assert_allclose(command_velocities(q, t), [[0.2, 0.0], [0.4, -0.4], [0.0, 0.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match="increasing times"):
        command_velocities(q, t[::-1])
    with pytest.raises(ValueError, match="joints"):
        command_velocities(q[:, 0], t)


def test_output_statistics_are_those_of_the_labels():
    """Fit-time output normalisation uses the commands, not the recorded velocities."""
    small = dict(image_size=24, duration=1.1, n_steps=12, channels=[4, 4, 4, 4], hidden=[8], bias_dim=2)
    vel = VelocityPolicy(**small)
    command = torch.randn(50, 7) * torch.linspace(0.1, 1.0, 7) + 0.3
    stats = {name: {"mean": torch.zeros(7), "std": torch.ones(7)} for name in ("joints", "velocity")}
    dm = SimpleNamespace(
        stats=stats,
        mode="velocity",
        config=None,
        datasets={"train": SimpleNamespace(tensors={LABEL: command})},
    )
    vel.trainer = SimpleNamespace(datamodule=dm)  # only what setup() reads
    vel.setup("fit")
    torch.testing.assert_close(vel.velocity_mean, command.mean(0))
    torch.testing.assert_close(vel.velocity_std, command.std(0))
    dm.datasets = {"train": SimpleNamespace(tensors={"velocity": command})}
    with pytest.raises(ValueError, match="'command'"):
        vel.setup("fit")


def test_evaluator_split_option():
    """Tuning reads `eval.split=val` (held-out validation objects); only test and val exist."""
    from lfd.visuomotor.eval.evaluator import ReachEvaluator

    assert ReachEvaluator().settings.split == "test" and ReachEvaluator(split="val").settings.split == "val"
    with pytest.raises(ValueError, match="split: expected 'test' or 'val'"):
        ReachEvaluator(split="train")
