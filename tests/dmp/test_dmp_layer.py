"""DMPLayer and rollout_batch: agreement with DMP.rollout, gradients, dtypes, devices, errors."""

import numpy as np
import pytest
import torch

from lfd.dmp import DMP, DMPLayer, rollout_batch

DEVICES = ["cpu"] + (["cuda"] if torch.cuda.is_available() else [])


def _parameters(batch, n_dims, n_basis, seed=0, dtype=torch.float64, device="cpu"):
    generator = torch.Generator().manual_seed(seed)
    y0 = torch.randn(batch, n_dims, generator=generator, dtype=dtype)
    goal = y0 + torch.randn(batch, n_dims, generator=generator, dtype=dtype)
    weights = 30 * torch.randn(batch, n_dims, n_basis, generator=generator, dtype=dtype)
    return y0.to(device), goal.to(device), weights.to(device)


@pytest.mark.parametrize("tau", [None, 1.7])
def test_layer_matches_dmp_rollout(tau):
    layer = DMPLayer(n_basis=9, n_steps=70, dt=0.03, alpha_z=20.0, alpha_s=4.0)
    y0, goal, weights = _parameters(5, 3, 9)
    expected = DMP(9, alpha_z=20.0, alpha_s=4.0).rollout(
        t=np.arange(70) * 0.03,
        y0=y0.numpy(),
        goal=goal.numpy(),
        weights=weights.numpy(),
        tau=69 * 0.03 if tau is None else tau,
        return_derivatives=True,
    )
    actual = layer(y0, goal, weights, tau=tau, return_derivatives=True)
    for a, e in zip(actual, expected, strict=True):
        assert a.shape == (5, 70, 3) and a.dtype == torch.float64
        np.testing.assert_allclose(a.numpy(), e, rtol=0, atol=1e-6 * np.abs(e).max())
    np.testing.assert_allclose(layer.t.numpy(), np.arange(70) * 0.03)


def test_gradcheck_all_inputs():
    layer = DMPLayer(n_basis=3, n_steps=6, dt=0.15)
    y0, goal, weights = (x.requires_grad_() for x in _parameters(2, 1, 3, seed=1))
    tau = torch.tensor([0.9, 1.4], dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda a, b, c, d: layer(a, b, c, tau=d), (y0, goal, weights, tau))
    shared_tau = torch.tensor(1.2, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(
        lambda a, b, c, d: layer(a, b, c, tau=d, return_derivatives=True),
        (y0, goal, weights, shared_tau),
        fast_mode=True,
    )
    assert torch.autograd.gradcheck(lambda a, b, c: layer(a, b, c), (y0, goal, weights))


def test_per_sample_tau_equals_one_rollout_per_tau():
    layer = DMPLayer(n_basis=6, n_steps=40, dt=0.05)
    y0, goal, weights = _parameters(4, 2, 6, seed=2)
    taus = torch.tensor([0.7, 1.0, 1.95, 3.0], dtype=torch.float64)
    batched = layer(y0, goal, weights, tau=taus)
    for b in range(4):
        single = layer(y0[b : b + 1], goal[b : b + 1], weights[b : b + 1], tau=float(taus[b]))
        torch.testing.assert_close(batched[b : b + 1], single, rtol=1e-9, atol=1e-10)


@pytest.mark.parametrize("device", DEVICES)
def test_float32_and_devices(device):
    layer = DMPLayer(n_basis=20, n_steps=100, dt=0.04).to(device)
    assert layer.forced.device.type == device and layer.forced.dtype == torch.float64
    y0, goal, weights = _parameters(16, 7, 20, seed=3, device=device)
    reference = layer(y0, goal, weights)
    single = [x.float().requires_grad_() for x in (y0, goal, weights)]
    out = layer(*single)
    assert out.dtype == torch.float32 and out.device.type == device
    torch.testing.assert_close(out.double(), reference, rtol=1e-4, atol=1e-4 * reference.abs().max().item())
    out.square().mean().backward()
    assert all(x.grad is not None and torch.isfinite(x.grad).all() for x in single)
    tau = torch.full((16,), 3.0, device=device, requires_grad=True)
    layer(*single, tau=tau).sum().backward()
    assert tau.grad.shape == (16,) and torch.isfinite(tau.grad).all()


def test_layer_learns_weights_by_gradient_descent():
    # the point of the layer: a trajectory loss trains DMP parameters end to end
    layer = DMPLayer(n_basis=10, n_steps=50, dt=0.02)
    y0, goal, target_weights = _parameters(2, 2, 10, seed=4)
    target = layer(y0, goal, target_weights)
    weights = torch.zeros_like(target_weights, requires_grad=True)
    optimiser = torch.optim.LBFGS([weights], max_iter=60, line_search_fn="strong_wolfe")

    def closure():
        optimiser.zero_grad()
        loss = (layer(y0, goal, weights) - target).square().mean()
        loss.backward()
        return loss

    initial_loss = closure().item()
    optimiser.step(closure)
    assert closure().item() < 1e-2 * initial_loss


def test_rollout_batch_numpy_and_torch_agree_and_broadcast():
    rng = np.random.default_rng(5)
    y0, goal, weights = rng.normal(size=7), rng.normal(size=7), rng.normal(size=(100, 7, 20)) * 20
    t = np.linspace(0, 2, 50)
    out = rollout_batch(y0, goal, weights, t)
    assert isinstance(out, np.ndarray) and out.shape == (100, 50, 7)
    np.testing.assert_allclose(out, rollout_batch(y0, goal, weights, n_steps=50, dt=2 / 49), atol=1e-12)
    np.testing.assert_allclose(out[42], rollout_batch(y0, goal, weights[42], t), atol=1e-12)
    as_tensor = rollout_batch(torch.from_numpy(y0), goal, torch.from_numpy(weights), t)
    assert isinstance(as_tensor, torch.Tensor)
    np.testing.assert_allclose(as_tensor.numpy(), out, atol=1e-12)
    assert rollout_batch(y0, goal, weights[0], t).shape == (50, 7)
    taus = np.array([1.0, 2.0, 3.0])
    per_sample = rollout_batch(y0, goal, weights[:3], t, tau=taus)
    np.testing.assert_allclose(per_sample[2], rollout_batch(y0, goal, weights[2], t, tau=3.0), atol=1e-10)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            (torch.zeros(2, 3), torch.zeros(2, 3), torch.zeros(2, 3, 5)),
            r"weights must have shape \(B, D, 4\)",
        ),
        ((torch.zeros(2, 3), torch.zeros(2, 3), torch.zeros(3, 4)), r"weights must have shape \(B, D, 4\)"),
        ((torch.zeros(2, 2), torch.zeros(2, 3), torch.zeros(2, 3, 4)), r"y0 must have shape \(2, 3\)"),
        ((torch.zeros(2, 3), torch.zeros(1, 3), torch.zeros(2, 3, 4)), r"goal must have shape \(2, 3\)"),
    ],
)
def test_layer_rejects_bad_shapes(args, message):
    with pytest.raises(ValueError, match=message):
        DMPLayer(4, 10, 0.1)(*args)


def test_layer_and_rollout_batch_reject_bad_arguments():
    layer = DMPLayer(4, 10, 0.1)
    with pytest.raises(ValueError, match="tau must be a scalar or have shape"):
        layer(torch.zeros(2, 3), torch.zeros(2, 3), torch.zeros(2, 3, 4), tau=torch.ones(3))
    with pytest.raises(ValueError, match="tau must be"):
        layer(torch.zeros(2, 3), torch.zeros(2, 3), torch.zeros(2, 3, 4), tau=-1.0)
    for kwargs, message in [
        (dict(n_basis=0, n_steps=10, dt=0.1), "n_basis"),
        (dict(n_basis=3, n_steps=0, dt=0.1), "n_steps"),
        (dict(n_basis=3, n_steps=10, dt=0.0), "dt"),
        (dict(n_basis=3, n_steps=1, dt=0.1), "tau is required"),
    ]:
        with pytest.raises(ValueError, match=message):
            DMPLayer(**kwargs)
    with pytest.raises(ValueError, match="either t"):
        rollout_batch(np.zeros(2), np.ones(2), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="either t"):
        rollout_batch(np.zeros(2), np.ones(2), np.zeros((2, 3)), np.linspace(0, 1, 5), n_steps=5, dt=0.1)
    with pytest.raises(ValueError, match="tau must be > 0"):
        rollout_batch(
            np.zeros(2), np.ones(2), np.zeros((2, 3)), np.linspace(0, 1, 5), tau=np.array([1.0, -1.0])
        )
    with pytest.raises(ValueError, match="weights contains NaN"):
        rollout_batch(np.zeros(2), np.ones(2), np.full((2, 3), np.nan), np.linspace(0, 1, 5))


@pytest.mark.parametrize("formulation", ["pastor", "ijspeert"])
def test_layer_formulation_and_start_velocity_match_the_numpy_rollout(formulation):
    rng = np.random.default_rng(12)
    y0, goal, yd0 = (torch.from_numpy(rng.normal(size=(4, 3))) for _ in range(3))
    weights = torch.from_numpy(rng.normal(size=(4, 3, 10)))
    layer = DMPLayer(n_basis=10, n_steps=40, dt=0.05, formulation=formulation)
    out = layer(y0, goal, weights, yd0=yd0)
    expected = rollout_batch(
        y0.numpy(),
        goal.numpy(),
        weights.numpy(),
        n_steps=40,
        dt=0.05,
        yd0=yd0.numpy(),
        formulation=formulation,
    )
    np.testing.assert_allclose(out.numpy(), expected, atol=1e-12)
    _, velocity, _ = layer(y0, goal, weights, return_derivatives=True, yd0=yd0)
    np.testing.assert_allclose(velocity[:, 0].numpy(), yd0.numpy(), atol=1e-12)
    other = "ijspeert" if formulation == "pastor" else "pastor"
    assert not np.allclose(
        DMPLayer(10, 40, 0.05, formulation=other)(y0, goal, weights).numpy(), layer(y0, goal, weights).numpy()
    )
    with pytest.raises(ValueError, match="formulation"):
        DMPLayer(10, 40, 0.05, formulation="schaal")


@pytest.mark.parametrize("dtype", [torch.float16, torch.bfloat16])
def test_half_precision_weights_roll_out_in_float32_outside_autocast(dtype):
    """A network under mixed precision hands the layer half-precision weights inside autocast: the
    rollout runs in float32 (float16 overflows on DMP forcing weights of this size)."""
    layer = DMPLayer(n_basis=20, n_steps=100, dt=0.04)
    y0, goal, weights = _parameters(6, 7, 20, dtype=torch.float32)
    weights = (100 * weights).to(dtype)  # |w| up to ~10^4, as fitted reaching demonstrations have
    expected = layer(y0, goal, weights.float(), return_derivatives=True)
    with torch.autocast("cpu", dtype=dtype):
        actual = layer(y0.to(dtype), goal, weights, return_derivatives=True)
    for a, e in zip(actual, expected, strict=True):
        assert a.dtype == torch.float32 and bool(torch.isfinite(a).all())
        torch.testing.assert_close(a, e, rtol=1e-5, atol=1e-5 * float(e.abs().max()))
