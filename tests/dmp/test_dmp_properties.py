"""Property tests: output shapes over random sizes, and bad inputs always raise ValueError."""

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from lfd.dmp import DMP, FIT_METHODS, DMPLayer, RhythmicDMP, rollout_batch

SETTINGS = settings(max_examples=25, deadline=None)
sizes = st.fixed_dictionaries(
    {"B": st.integers(1, 6), "T": st.integers(3, 150), "D": st.integers(1, 5), "K": st.integers(1, 12)}
)


@SETTINGS
@given(sizes, st.booleans(), st.booleans(), st.booleans(), st.integers(0, 2**31))
def test_rollout_batch_shapes(n, batched_y0, batched_goal, batched_weights, seed):
    rng = np.random.default_rng(seed)
    y0 = rng.normal(size=(n["B"], n["D"]) if batched_y0 else n["D"])
    goal = rng.normal(size=(n["B"], n["D"]) if batched_goal else n["D"])
    weights = rng.normal(size=(n["B"], n["D"], n["K"]) if batched_weights else (n["D"], n["K"])) * 10
    out = rollout_batch(y0, goal, weights, n_steps=n["T"], dt=0.01, return_derivatives=True)
    expected = ((n["B"],) if batched_y0 or batched_goal or batched_weights else ()) + (n["T"], n["D"])
    assert all(x.shape == expected and np.all(np.isfinite(x)) for x in out)


@SETTINGS
@given(sizes, st.sampled_from([torch.float32, torch.float64]))
def test_layer_shapes(n, dtype):
    layer = DMPLayer(n["K"], n["T"], 0.02)
    y0, goal = torch.randn(2, n["B"], n["D"], dtype=dtype)
    weights = torch.randn(n["B"], n["D"], n["K"], dtype=dtype, requires_grad=True)
    y, yd, ydd = layer(y0, goal, weights, return_derivatives=True)
    assert y.shape == yd.shape == ydd.shape == (n["B"], n["T"], n["D"]) and y.dtype == dtype
    y.sum().backward()
    assert weights.grad.shape == weights.shape


@settings(max_examples=12, deadline=None)
@given(sizes, st.sampled_from(FIT_METHODS), st.booleans(), st.integers(0, 2**31))
def test_fit_and_rollout_shapes(n, method, batched, seed):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.005, 0.05, size=n["T"]))  # arbitrary non-uniform grid
    y = rng.normal(size=((n["B"],) if batched else ()) + (n["T"], n["D"])).cumsum(axis=-2)
    batch = (n["B"],) if batched else ()
    for model in (DMP(n["K"]), RhythmicDMP(n["K"])):
        model.fit(t, y, method=method)
        assert model.weights_.shape == batch + (n["D"], n["K"]) and np.all(np.isfinite(model.weights_))
        assert model.rollout().shape == batch + (n["T"], n["D"])


def _corrupt(kind, t, y):
    if kind == "nan_y":
        y = y.copy()
        y.flat[len(y.flat) // 2] = np.nan
    elif kind == "inf_t":
        t = t.copy()
        t[-1] = np.inf
    elif kind == "repeated_time":
        t = t.copy()
        t[len(t) // 2] = t[len(t) // 2 - 1]
    elif kind == "reversed_time":
        t = t[::-1].copy()
    elif kind == "length_mismatch":
        y = y[:-1]
    elif kind == "too_short":
        t, y = t[:2], y[:2]
    elif kind == "flat_y":
        y = y.reshape(-1)
    return t, y


@SETTINGS
@given(
    st.integers(4, 60),
    st.integers(1, 4),
    st.sampled_from(
        ["nan_y", "inf_t", "repeated_time", "reversed_time", "length_mismatch", "too_short", "flat_y"]
    ),
    st.sampled_from([DMP, RhythmicDMP]),
)
def test_bad_demonstrations_raise_value_error(n_steps, n_dims, kind, model):
    t = np.linspace(0, 1, n_steps)
    y = np.random.default_rng(n_steps).normal(size=(n_steps, n_dims))
    with pytest.raises(ValueError):
        model().fit(*_corrupt(kind, t, y))


@SETTINGS
@given(
    st.integers(1, 4),
    st.integers(1, 6),
    st.sampled_from(["y0_width", "goal_width", "weights_basis", "weights_dims", "batch", "nan_goal", "tau"]),
)
def test_bad_rollout_arguments_raise_value_error(n_dims, n_basis, kind):
    dmp = DMP(n_basis).fit(np.linspace(0, 1, 10), np.linspace(0, 1, 10)[:, None] * np.arange(1, n_dims + 1))
    bad = {
        "y0_width": dict(y0=np.zeros(n_dims + 1)),
        "goal_width": dict(goal=np.zeros((2, n_dims + 2))),
        "weights_basis": dict(weights=np.zeros((n_dims, n_basis + 1))),
        "weights_dims": dict(weights=np.zeros((n_dims + 1, n_basis))),
        "batch": dict(weights=np.zeros((3, n_dims, n_basis)), goal=np.zeros((2, n_dims))),
        "nan_goal": dict(goal=np.full(n_dims, np.nan)),
        "tau": dict(tau=-0.5),
    }[kind]
    with pytest.raises(ValueError):
        dmp.rollout(**bad)
