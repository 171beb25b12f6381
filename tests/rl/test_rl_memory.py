"""Importance-sampling memory: the best M rollouts across iterations."""

import numpy as np
import pytest

from lfd.rl import keep_best


def test_keeps_best_m_across_iterations_sorted_by_return():
    params, returns = np.empty((0, 2)), np.empty(0)
    batches = [
        (np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]), np.array([0.1, 0.9, 0.5])),
        (np.array([[3.0, 3.0], [4.0, 4.0]]), np.array([0.3, 0.95])),
        (np.array([[5.0, 5.0], [6.0, 6.0]]), np.array([0.05, 0.6])),
    ]
    for new_params, new_returns in batches:
        params, returns = keep_best(params, returns, new_params, new_returns, 3)
    np.testing.assert_array_equal(returns, [0.95, 0.9, 0.6])
    np.testing.assert_array_equal(params[:, 0], [4.0, 1.0, 6.0])


def test_old_rollouts_survive_when_new_ones_are_worse():
    params, returns = keep_best(
        np.empty((0, 1)), np.empty(0), np.array([[1.0], [2.0]]), np.array([0.8, 0.7]), 2
    )
    params, returns = keep_best(params, returns, np.array([[3.0], [4.0]]), np.array([0.1, 0.2]), 2)
    np.testing.assert_array_equal(params[:, 0], [1.0, 2.0])


def test_ties_keep_the_older_rollout_and_small_memories_keep_everything():
    params, returns = keep_best(
        np.array([[1.0]]), np.array([0.5]), np.array([[2.0], [3.0]]), np.array([0.5, 0.4]), 1
    )
    np.testing.assert_array_equal(params, [[1.0]])
    params, returns = keep_best(np.array([[1.0]]), np.array([0.5]), np.array([[2.0]]), np.array([0.4]), 10)
    assert params.shape == (2, 1) and returns.tolist() == [0.5, 0.4]


def test_inputs_are_not_modified():
    old = np.array([[1.0, 2.0]]), np.array([0.2])
    new = np.array([[3.0, 4.0]]), np.array([0.9])
    copies = [a.copy() for a in (*old, *new)]
    params, _ = keep_best(*old, *new, 2)
    params[:] = 0.0
    for original, copy in zip((*old, *new), copies):
        np.testing.assert_array_equal(original, copy)


@pytest.mark.parametrize("m", [0, -1, 2.5])
def test_bad_memory_size_is_rejected(m):
    with pytest.raises(ValueError, match="m"):
        keep_best(np.empty((0, 1)), np.empty(0), np.zeros((1, 1)), np.zeros(1), m)


def test_mismatched_shapes_are_rejected():
    with pytest.raises(ValueError, match="params"):
        keep_best(np.empty((0, 2)), np.empty(0), np.zeros((2, 2)), np.zeros(3), 2)
