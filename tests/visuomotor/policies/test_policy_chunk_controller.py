"""The chunked controller (ACT, Diffusion Policy) against hand computations, with scripted chunks."""

import math

import numpy as np
import pytest

from lfd.visuomotor.eval.rollout import run_episode
from lfd.visuomotor.policies.control import ChunkController
from lfd.visuomotor.protocols import Controller, Observation

DT = 0.1


class ScriptedChunks:
    """Query j (0-based) returns the chunk ``10 j + 0.1 (i + 1)``, i = 0..k-1, on every joint."""

    input_channels, depth_encoding = 3, "range"

    def __init__(self, k=3, n=2):
        self.k, self.n, self.calls = k, n, []

    def act_chunk(self, image, joints):
        j = len(self.calls)
        self.calls.append((image, np.array(joints)))
        return np.repeat((10.0 * j + 0.1 * np.arange(1, self.k + 1))[:, None], self.n, axis=1)


def run(controller, steps, q0=None):
    controller.start(steps)
    q = np.zeros(2) if q0 is None else q0
    out, looked = [], []
    for s in range(steps):
        looked.append(controller.needs_image)
        q_cmd, qd_cmd = controller.command(Observation(image=np.zeros((4, 4, 3), np.uint8), joints=q), s, [])
        out.append((q_cmd, qd_cmd))
        q = q_cmd
    return out, looked


def test_temporal_ensembling_by_hand():
    """ACT's ensemble at step s: chunks queried at s-2, s-1, s (k = 3) give targets
    c_j[s - j] = 10 j + 0.1 (s - j + 1), weighted w_0 = 1, w_1 = e^-m, w_2 = e^-2m, oldest first."""
    m = 0.5
    w1, w2 = math.exp(-m), math.exp(-2 * m)
    policy = ScriptedChunks()
    ctl = ChunkController(policy, DT, replan_every=1, ensemble_m=m)
    assert isinstance(ctl, Controller)
    out, looked = run(ctl, 4)
    expected = [
        0.1,
        (1 * 0.2 + w1 * 10.1) / (1 + w1),
        (1 * 0.3 + w1 * 10.2 + w2 * 20.1) / (1 + w1 + w2),
        (1 * 10.3 + w1 * 20.2 + w2 * 30.1) / (1 + w1 + w2),
    ]
    for (q, _), e in zip(out, expected):
        np.testing.assert_allclose(q, [e, e], rtol=0, atol=1e-12)
    assert len(policy.calls) == 4 and all(looked)
    # velocity feed-forward at step 0: the chunk's central difference on [q0, 0.1, 0.2, 0.3]
    np.testing.assert_allclose(out[0][1], [(0.2 - 0.0) / (2 * DT)] * 2, atol=1e-12)


def test_without_ensembling_the_newest_chunk_runs_for_the_action_horizon():
    """Receding horizon (Diffusion Policy): a query every 2 steps, its first 2 samples executed."""
    policy = ScriptedChunks(k=4)
    ctl = ChunkController(policy, DT, replan_every=2)
    out, looked = run(ctl, 5)
    np.testing.assert_allclose([q[0] for q, _ in out], [0.1, 0.2, 10.1, 10.2, 20.1], atol=1e-12)
    assert looked == [True, False, True, False, True] and len(policy.calls) == 3
    # each query sees the joints reached by then (the last command)
    np.testing.assert_allclose(policy.calls[1][1], [0.2, 0.2])


def test_whole_chunks_without_replan_every_and_a_fresh_start():
    policy = ScriptedChunks(k=3)
    ctl = ChunkController(policy, DT)
    out, looked = run(ctl, 4)
    np.testing.assert_allclose([q[0] for q, _ in out], [0.1, 0.2, 0.3, 10.1], atol=1e-12)
    assert looked == [True, False, False, True]
    run(ctl, 1)  # start() forgets the chunks: the next episode queries at once
    assert len(policy.calls) == 3


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="replan_every"):
        ChunkController(ScriptedChunks(), DT, replan_every=0)
    with pytest.raises(ValueError, match="ensemble_m"):
        ChunkController(ScriptedChunks(), DT, ensemble_m=-1.0)


class IdealScene:
    """Tracks every (clamped) position command exactly."""

    def __init__(self, n):
        self.q, self.commands = np.zeros(n), []

    def joint_state(self):
        return self.q.copy(), np.zeros_like(self.q)

    def ee_pose(self):
        return np.eye(4)

    def render(self):
        return np.zeros((4, 4, 3), np.uint8)

    def step(self, q_target, qd_target):
        self.commands.append(np.array(q_target))
        self.q = np.array(q_target, dtype=float)


def test_commands_are_clamped_to_the_limits_in_the_episode_loop():
    """Chunks beyond the limits (10 j + ...) are clamped by the evaluator's loop and counted."""
    scene = IdealScene(2)
    lower, upper = np.array([-1.0, -np.inf]), np.array([0.15, np.inf])
    trace = run_episode(
        scene, ChunkController(ScriptedChunks(k=3), DT, replan_every=1, ensemble_m=0.01), 3, lower, upper
    )
    assert np.all(trace.joints[:, 0] <= 0.15) and trace.joints[-1, 1] > 5.0
    assert trace.limit_violations == 2 and len(trace.latencies_ms) == 3
