"""The placement map's segmented variant (:mod:`lfd.visuomotor.policies.placement_map`) against an analytic
reference: demonstrations that move the hand to a point a fixed offset from an object, close the gripper
there (later for a farther object) and carry on to a fixed goal."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.visuomotor.policies.placement_map import SegmentedMap, switch_steps

T, K, DT = 100, 20, 0.0125
OFFSET = np.array([0.03, 0.0, 0.03])
GOAL = np.array([-0.2, 0.5, 0.15])
START = np.array([0.0, 0.6, 0.2])


def _min_jerk(a: np.ndarray, b: np.ndarray, steps: int) -> np.ndarray:
    s = np.linspace(0.0, 1.0, steps)[:, None]
    return a + (b - a) * (10 * s**3 - 15 * s**4 + 6 * s**5)


def _demos(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Objects ``(n, 3)``, states ``(n, T, 4)`` (hand xyz m, gripper -1 open / 1 closed) and switch steps."""
    rng = np.random.default_rng(seed)
    objects = np.column_stack([rng.uniform(-0.15, 0.15, n), rng.uniform(0.45, 0.8, n), np.full(n, 0.02)])
    states, steps = [], []
    for o in objects:
        via = o + OFFSET
        c = int(round(150 * np.linalg.norm(via - START)))  # farther objects are reached later
        first = _min_jerk(START, via, c)
        second = np.concatenate([np.repeat(via[None], 8, 0), _min_jerk(via, GOAL, 32)])  # a dwell to grasp
        hand = np.concatenate([first, second, np.repeat(GOAL[None], T - c - 40, 0)])
        grip = np.where(np.arange(T) < c, -1.0, 1.0)
        states.append(np.column_stack([hand, grip]))
        steps.append(c)
    return objects, np.stack(states), np.array(steps)


def _inputs(objects: np.ndarray, mean: np.ndarray, std: np.ndarray) -> torch.Tensor:
    return torch.as_tensor((objects - mean) / std)


def test_switch_steps_finds_the_first_switch_and_needs_one_in_every_demonstration():
    _, states, steps = _demos(6, 0)
    np.testing.assert_array_equal(switch_steps(states), steps)
    jumped = states.copy()
    jumped[:, 1:, 3] = np.where(
        jumped[:, 1:, 3] < 0, 0.0, 1.0
    )  # a jump into step 1 (the reset's) does not split
    np.testing.assert_array_equal(switch_steps(jumped), steps)
    assert switch_steps(np.zeros((3, T, 4))) is None  # nothing switches
    twice = states.copy()
    twice[0, 90:, 3] = -1.0  # one demonstration switches back later: the first switch still splits
    np.testing.assert_array_equal(switch_steps(twice), steps)
    never = states.copy()
    never[0, :, 3] = -1.0  # one demonstration never switches: nothing to split consistently
    assert switch_steps(never) is None


def test_segmented_map_puts_the_grasp_where_the_object_is_when_it_comes():
    """Held-out placements: the segmented plan is within 1 mm of the grasp point (object + offset) where it
    switches the gripper, within 3 steps of the reference's step plus the delay (the gripper holds its old value
    for the delay, the hand does not wait)."""
    objects, states, steps = _demos(50, 1)
    fit, held = slice(0, 40), slice(40, 50)
    mean, std = objects[fit].mean(0), objects[fit].std(0) + 1e-3
    x = _inputs(objects, mean, std)
    delay = 3
    segmented = SegmentedMap(4, K, DT, scale=2.0, kernel_ridge=0.1, switch_delay=delay, inputs=3)
    assert segmented.fit(x[fit], states[fit], ridge=1e-3) and segmented.fitted
    plans = segmented.plan(x[held], states[held, 0], T)
    assert plans.shape == (10, T, 4)

    seg_err = []
    for plan, o, c in zip(plans, objects[held], steps[held]):
        via = o + OFFSET
        switched = int(np.argmax(plan[:, 3] > 0))
        assert abs(switched - (c + delay)) <= 3, (switched, c)
        seg_err.append(np.linalg.norm(plan[switched - delay, :3] - via))
    assert max(seg_err) < 0.001, seg_err
    assert steps.max() - steps.min() >= 15  # the grasp comes at different times


def test_segmented_map_without_a_switch_stays_empty_and_checkpoint_buffers_are_checked():
    objects, states, _ = _demos(8, 2)
    x = _inputs(objects, objects.mean(0), objects.std(0) + 1e-3)
    segmented = SegmentedMap(4, K, DT, scale=2.0, kernel_ridge=0.1, switch_delay=0, inputs=3)
    still = states.copy()
    still[..., 3] = -1.0
    assert not segmented.fit(x, still, ridge=0.1) and not segmented.fitted

    assert segmented.fit(x, states, ridge=0.1)
    state = {f"m.{k}": v.clone() for k, v in segmented.state_dict().items()}
    other = SegmentedMap(4, K, DT, scale=2.0, kernel_ridge=0.1, switch_delay=0, inputs=3)
    other.resize_for(state, "m.")
    other.load_state_dict({k[2:]: v for k, v in state.items()})
    np.testing.assert_array_equal(other.plan(x, states[:, 0], T), segmented.plan(x, states[:, 0], T))
    empty: dict = {}
    SegmentedMap(4, K, DT, 2.0, 0.1, 0, inputs=3).resize_for(empty, "m.")  # an older checkpoint: none saved
    assert empty["m.bias"].numel() == 0
    for name, bad in (
        ("m.mean", torch.zeros(3, dtype=torch.float64)),
        ("m.slopes", torch.zeros(5, other.size, dtype=torch.float64)),
        ("m.second_length", torch.tensor(0)),
    ):
        with pytest.raises(
            ValueError, match=r"^CNNDMPPolicy: the checkpoint's m\.\* buffers do not form a map from 3 "
        ):
            other.resize_for({**state, name: bad}, "m.")
