"""CNN -> DMP re-planning: the DMP's goal changed online every k steps from a new image.

The reference is a plain numpy RK4 integration of the DMP equations as lfd.dmp's docstrings
write them (lfd.dmp.formulation, lfd.dmp.canonical, lfd.dmp.gains), with the goal switched
at the re-planning steps; it calls none of lfd.dmp's integrators.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lfd.dmp import DMP, DMPLayer, DMPRunner, DMPState
from lfd.dmp.transform import substeps
from lfd.visuomotor.policies import CNNDMPPolicy
from lfd.visuomotor.policies.cnn_dmp import DMPPlan
from lfd.visuomotor.policies.control import PlanController
from lfd.visuomotor.protocols import Observation

N, K, T, DURATION = 4, 5, 41, 1.0  # 4-D tool state, 5 bases, tau = 1 s sampled every 25 ms
DT = DURATION / (T - 1)
STEPS = 120  # 3 tau: the DMP has converged to its (last) goal
START = np.array([0.25, -0.5, 0.125, 0.75])  # exact in float32 (the network's input dtype)
# Docstring defaults (lfd.dmp.gains): beta_z = alpha_z / 4, alpha_s = alpha_z / 3; overlap 0.8.
ALPHA_Z, OVERLAP = 25.0, 0.8
BETA_Z, ALPHA_S = ALPHA_Z / 4, ALPHA_Z / 3
STIFFNESS = ALPHA_Z * BETA_Z


def make_policy(formulation: str = "pastor") -> CNNDMPPolicy:
    torch.manual_seed(0)
    model = CNNDMPPolicy(
        n_basis=K,
        channels=[4, 4, 4, 8],
        hidden=[16, 16],
        image_size=24,
        n_steps=T,
        duration=DURATION,
        robot=None,
        n_joints=N,
    )
    with torch.no_grad():  # statistics that make a motion of a few decimetres
        model.goal_mean.copy_(torch.tensor([0.6, -0.2, 0.4, 0.3]))
        model.goal_std.fill_(0.2)
        model.weights_std.fill_(0.3)
    if formulation != "pastor":  # the policy's DMP is pastor's; the goal change follows any
        model.dmp = DMPLayer(n_basis=K, n_steps=T, dt=DT, formulation=formulation)
        with torch.no_grad():
            model.weights_mean.fill_(1.0)  # dimensionless: about the demonstration's own shape
    assert model.control_dt == pytest.approx(DT) and model.dmp.formulation == formulation
    gains = model.dmp.gains
    assert (gains.alpha_z, gains.beta_z, gains.alpha_s, gains.overlap) == pytest.approx(
        (ALPHA_Z, BETA_Z, ALPHA_S, OVERLAP)
    )
    return model.eval()


@pytest.fixture(scope="module")
def policy():
    return make_policy()


def frame(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, size=(24, 24, 3), dtype=np.uint8)


def run(controller, frames, steps=STEPS):
    """Drive ``controller`` with perfect tracking; the image is given only where it asks.

    Returns the commanded positions and velocities ``(steps, n)``, the steps that looked and,
    per step, the plan and velocities the controller held before its command (None at step 0)."""
    controller.start(steps)
    q, targets, velocities, looked, latencies, held = START.copy(), [], [], [], [], []
    for step in range(steps):
        image = None
        if controller.needs_image:
            looked.append(step)
            image = frames(step)
        held.append(None if controller.plan is None else (controller.plan.copy(), controller.velocity.copy()))
        q_target, qd = controller.command(Observation(image, q.copy(), step * DT), step, latencies)
        targets.append(q_target)
        velocities.append(qd)
        q = q_target
    assert len(latencies) == len(looked)
    return np.array(targets), np.array(velocities), looked, held


def reference(goals, weights, y0=START, steps=STEPS, sub=40, formulation="pastor"):
    """RK4 of ``tau dz = alpha_z (beta_z (g - y) - z) + F``, ``tau dy = z`` with the forcing
    ``F = K x(s) @ w - K (g - y0) s`` (pastor) or ``F = (x(s) @ w) (g - y0)`` (ijspeert), ``x_i = s psi_i / sum psi``,
    ``psi_i = exp(-h_i (s - c_i)^2)``, ``c_i = exp(-alpha_s i / (K - 1))``,
    ``h_i = -ln(overlap) / (c_{i+1} - c_i)^2`` (last copies its neighbour), ``s = exp(-alpha_s t / tau)``;
    ``goals(m)`` is the goal during control step ``m``. Samples ``(steps + 1, n)`` every ``DT``."""
    tau = DURATION
    centres = np.exp(-ALPHA_S * np.arange(K) / (K - 1))
    widths = -np.log(OVERLAP) / np.diff(centres) ** 2
    widths = np.append(widths, widths[-1])

    def derivative(t, y, z, g):
        s = np.exp(-ALPHA_S * t / tau)
        psi = np.exp(-widths * (s - centres) ** 2)
        x = s * psi / psi.sum()
        if formulation == "pastor":
            force = STIFFNESS * (weights @ x) - STIFFNESS * (g - y0) * s
        else:
            force = (weights @ x) * (g - y0)
        return z / tau, (ALPHA_Z * (BETA_Z * (g - y) - z) + force) / tau

    y, z, h = np.array(y0, dtype=np.float64), np.zeros(len(y0)), DT / sub
    out = [y.copy()]
    for m in range(steps):
        g = goals(m)
        for i in range(sub):
            t = m * DT + i * h
            k1 = derivative(t, y, z, g)
            k2 = derivative(t + h / 2, y + h / 2 * k1[0], z + h / 2 * k1[1], g)
            k3 = derivative(t + h / 2, y + h / 2 * k2[0], z + h / 2 * k2[1], g)
            k4 = derivative(t + h, y + h * k3[0], z + h * k3[1], g)
            y = y + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            z = z + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        out.append(y.copy())
    return np.array(out)


def network_parameters(policy, image):
    """The de-normalised goal and weights the network predicts (float64), without the DMP code."""
    img, q, _ = policy._observation(image, START)
    with torch.no_grad():
        goal_n, weights_n = policy.predict_params(img, q)
    goal = policy.denormalise("goal", goal_n)[0].double().numpy()
    return goal, policy.denormalise("weights", weights_n)[0].double().numpy()


def test_plan_once_is_unchanged_and_predict_goal_is_the_planned_goal(policy):
    """Without replan_every the controller tracks ``plan`` bit for bit and looks once;
    ``plan_dmp`` gives the same trajectory and the network's goal and weights."""
    targets, _, looked, _ = run(policy.controller(DT), lambda step: frame(0))
    plan = policy.plan(frame(0), START, n_steps=STEPS + 1)
    assert looked == [0] and np.array_equal(targets, plan[1:])
    dmp_plan = policy.plan_dmp(frame(0), START, n_steps=STEPS + 1)
    goal, weights = network_parameters(policy, frame(0))
    assert np.array_equal(dmp_plan.trajectory, plan)
    assert np.array_equal(dmp_plan.goal, goal) and np.array_equal(dmp_plan.weights, weights)
    assert np.array_equal(policy.predict_goal(frame(0), START), goal)
    assert policy.predict_goal(np.stack([frame(0), frame(1)]), np.stack([START, START])).shape == (2, N)
    np.testing.assert_allclose(plan[-1], goal, atol=1e-5)  # plans converge to the predicted goal


def test_unchanged_goal_replans_to_the_plan_once_trajectory(policy, monkeypatch):
    """(a) The goal prediction does not change (same image): every re-plan continues the DMP as it was."""
    once, once_velocity, _, _ = run(policy.controller(DT), lambda step: frame(0))
    calls = []
    predict = policy.predict_goal

    def counting(image, start_joints):
        calls.append(np.array(start_joints))
        return predict(image, start_joints)

    monkeypatch.setattr(policy, "predict_goal", counting)
    targets, velocity, looked, _ = run(policy.controller(DT, replan_every=7), lambda step: frame(0))
    assert looked == list(range(0, STEPS, 7)) and len(calls) == len(looked) - 1
    assert all(np.array_equal(start, START) for start in calls)  # conditioned on the start state
    np.testing.assert_allclose(targets, once, atol=1e-9, rtol=0)
    np.testing.assert_allclose(velocity, once_velocity, atol=1e-9, rtol=0)


def test_changed_goal_is_continuous_reaches_the_new_goal_and_matches_the_reference(policy, monkeypatch):
    """(b) New goals at steps k and 2k (then unchanged): the commands stay continuous where the
    goal changes, the motion ends at the last goal, and it is the reference integration with
    the goal switched at those steps."""
    k = 10
    goal, weights = network_parameters(policy, frame(0))
    goals = [goal, goal + np.array([0.15, -0.1, 0.05, 0.2]), goal + np.array([0.1, 0.05, -0.1, 0.25])]
    calls = []

    def predict_goal(image, start_joints):
        calls.append(image)
        return goals[min(len(calls), 2)]

    def goal_at(step):
        return goals[min(step // k, 2)]

    monkeypatch.setattr(policy, "predict_goal", predict_goal)
    targets, velocity, looked, held = run(policy.controller(DT, replan_every=k), lambda step: frame(step))
    assert looked == list(range(0, STEPS, k))
    assert all(np.array_equal(image, frame(s)) for image, s in zip(calls, looked[1:]))  # the new images
    once, once_velocity, _, _ = run(policy.controller(DT), lambda step: frame(0))
    np.testing.assert_array_equal(targets[:k], once[:k])  # nothing changes before the first switch
    np.testing.assert_array_equal(velocity[:k], once_velocity[:k])

    # continuous at each switch: the first new sample moves by at most the goal change's
    # acceleration K |dg| / tau^2 over one period, the velocity command by that over two
    for step, change in ((k, goals[1] - goals[0]), (2 * k, goals[2] - goals[1])):
        plan, plan_velocity = held[step]
        jump = np.abs(targets[step] - plan[step + 1])
        assert (
            np.all(jump <= 0.5 * STIFFNESS * np.abs(change) * (DT / DURATION) ** 2 + 1e-9) and jump.max() > 0
        )
        velocity_jump = np.abs(velocity[step] - plan_velocity[step + 1])
        assert np.all(velocity_jump <= STIFFNESS * np.abs(change) * DT / DURATION**2 + 1e-9)

    np.testing.assert_allclose(targets[-1], goals[2], atol=1e-6)  # ends at the new goal, at rest
    np.testing.assert_allclose(velocity[-1], 0.0, atol=1e-5)
    expected = reference(goal_at, weights)
    assert np.abs(expected[-1] - goals[2]).max() < 1e-6
    np.testing.assert_allclose(targets, expected[1:], atol=5e-6, rtol=0)  # measured 8e-7
    assert np.abs(targets - once).max() > 0.1  # the switches did move the arm elsewhere


def test_goal_change_at_the_start_is_the_plan_with_that_goal(policy):
    """Switching the goal at sample 0 gives the closed-form rollout with the new goal (to the
    float32 rounding of the network's plan; the goal change itself is integrated in float64)."""
    plan = policy.plan_dmp(frame(0), START, n_steps=STEPS + 1)
    new_goal = plan.goal + np.array([0.2, -0.1, 0.3, -0.05])
    changed = policy.change_goal(plan, 0, new_goal)
    expected = policy.layer(STEPS + 1)(
        torch.from_numpy(plan.start)[None],
        torch.from_numpy(new_goal)[None],
        torch.from_numpy(plan.weights)[None],
    )[0].numpy()
    np.testing.assert_allclose(changed.trajectory, expected, atol=1e-6, rtol=0)
    assert np.array_equal(changed.goal, new_goal) and np.array_equal(changed.weights, plan.weights)
    assert policy.change_goal(plan, STEPS, new_goal).trajectory is not plan.trajectory
    np.testing.assert_array_equal(policy.change_goal(plan, STEPS, new_goal).trajectory, plan.trajectory)
    with pytest.raises(ValueError, match="step"):
        policy.change_goal(plan, STEPS + 1, new_goal)
    with pytest.raises(ValueError, match="goal"):
        policy.change_goal(plan, 3, new_goal[:2])


@pytest.mark.parametrize("formulation", ["pastor", "ijspeert"])
def test_goal_change_follows_the_formulation(formulation):
    """``change_goal`` at a step after the start, in either formulation of lfd.dmp, is the
    reference integration with the goal switched there (``"ijspeert"`` rescales the forcing
    term by the new ``g - y0``)."""
    policy = make_policy(formulation)
    plan = policy.plan_dmp(frame(0), START, n_steps=STEPS + 1)
    assert policy.layer(STEPS + 1).formulation == formulation
    new_goal = plan.goal + np.array([0.2, -0.1, 0.3, -0.05])
    changed = policy.change_goal(plan, 12, new_goal).trajectory
    np.testing.assert_array_equal(changed[:13], plan.trajectory[:13])
    expected = reference(lambda m: new_goal if m >= 12 else plan.goal, plan.weights, formulation=formulation)
    np.testing.assert_allclose(changed, expected, atol=5e-6, rtol=0)
    np.testing.assert_allclose(changed[-1], new_goal, atol=1e-6)


@pytest.mark.parametrize("formulation", ["pastor", "ijspeert"])
def test_goal_change_is_the_dmp_continued_from_its_state(formulation):
    """The plan after ``change_goal`` is the DMP continued from its position, velocity and phase
    at the switch with the new goal (lfd.dmp's online runner), to rounding, on a float64 plan."""
    policy = make_policy(formulation)
    plan = policy.plan_dmp(frame(0), START, n_steps=STEPS + 1)
    layer, step = policy.layer(STEPS + 1), 13
    y, yd, _ = (
        x[0].numpy()
        for x in layer(
            *(torch.from_numpy(x)[None] for x in (plan.start, plan.goal, plan.weights)),
            return_derivatives=True,
        )
    )
    new_goal = plan.goal + np.array([0.2, -0.1, 0.3, -0.05])
    changed = policy.change_goal(DMPPlan(y, plan.start, plan.goal, plan.weights), step, new_goal).trajectory
    gains = layer.gains
    dmp = DMP(K, gains.alpha_z, gains.beta_z, gains.alpha_s, gains.overlap, formulation=formulation)
    runner = DMPRunner(
        dmp, plan.start, new_goal, layer.tau, plan.weights, yd0=np.zeros(N), substeps=substeps(DT / layer.tau)
    )
    runner.reset(DMPState(y[step], yd[step], step * DT))
    continued = [y[step]] + [runner.step(DT).y for _ in range(STEPS - step)]
    np.testing.assert_allclose(changed[step:], np.stack(continued), atol=1e-12, rtol=0)
    np.testing.assert_array_equal(changed[:step], y[:step])


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "3"])
def test_bad_replan_every_is_refused(policy, bad):
    """(c) replan_every: an int >= 1 or None, a one-line ValueError naming it otherwise."""
    for make in (lambda: policy.controller(DT, replan_every=bad), lambda: PlanController(policy, DT, bad)):
        with pytest.raises(ValueError, match="replan_every") as error:
            make()
        assert "\n" not in str(error.value)


def reference_switching(params, y0=START, steps=STEPS, sub=40):
    """RK4 of the pastor DMP as in :func:`reference`, with goal *and* weights ``params(m)`` during
    control step ``m`` (the state carries over each switch). Samples ``(steps + 1, n)``."""
    tau = DURATION
    centres = np.exp(-ALPHA_S * np.arange(K) / (K - 1))
    widths = -np.log(OVERLAP) / np.diff(centres) ** 2
    widths = np.append(widths, widths[-1])

    def derivative(t, y, z, g, w):
        s = np.exp(-ALPHA_S * t / tau)
        psi = np.exp(-widths * (s - centres) ** 2)
        force = STIFFNESS * (w @ (s * psi / psi.sum())) - STIFFNESS * (g - y0) * s
        return z / tau, (ALPHA_Z * (BETA_Z * (g - y) - z) + force) / tau

    y, z, h = np.array(y0, dtype=np.float64), np.zeros(len(y0)), DT / sub
    out = [y.copy()]
    for m in range(steps):
        g, w = params(m)
        for i in range(sub):
            t = m * DT + i * h
            k1 = derivative(t, y, z, g, w)
            k2 = derivative(t + h / 2, y + h / 2 * k1[0], z + h / 2 * k1[1], g, w)
            k3 = derivative(t + h / 2, y + h / 2 * k2[0], z + h / 2 * k2[1], g, w)
            k4 = derivative(t + h, y + h * k3[0], z + h * k3[1], g, w)
            y = y + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
            z = z + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        out.append(y.copy())
    return np.array(out)


def test_replanning_the_weights_follows_the_new_images_dmp_from_the_current_state(policy, monkeypatch):
    """``replan_weights=True``: at steps k and 2k the goal and the forcing weights both come from
    the new image (through ``plan_dmp`` with the start state as input); the commands are the
    reference integration with both switched there (state carried over), so position is
    continuous, and the arm ends at the last image's goal. Planning the goal only differs."""
    k = 10
    goal, weights = network_parameters(policy, frame(0))
    rng = np.random.default_rng(3)
    params = [(goal, weights)] + [
        (goal + rng.normal(0, 0.1, N), weights + rng.normal(0, 0.3, weights.shape)) for _ in range(2)
    ]
    frames = [frame(0), frame(5), frame(9)]
    planned = []

    def which(image):
        return next(j for j, f in enumerate(frames) if np.array_equal(f, image))

    def plan_dmp(image, joints, n_steps=None):
        i = which(image)
        planned.append((i, np.array(joints)))
        g, w = params[i]
        layer = policy.layer(n_steps)
        inputs = (torch.from_numpy(np.asarray(x, np.float64))[None] for x in (joints, g, w))
        traj, velocity, _ = layer(*inputs, return_derivatives=True)
        return DMPPlan(traj[0].numpy(), np.asarray(joints, np.float64), g, w, velocity[0].numpy())

    monkeypatch.setattr(policy, "plan_dmp", plan_dmp)
    monkeypatch.setattr(policy, "predict_goal", lambda image, start: params[which(image)][0])
    targets, velocity, looked, held = run(
        policy.controller(DT, replan_every=k, replan_weights=True), lambda step: frames[min(step // k, 2)]
    )
    assert looked == list(range(0, STEPS, k))
    assert [i for i, _ in planned] == [0, 1, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2]
    assert all(np.array_equal(q, START) for _, q in planned)  # conditioned on the start state
    expected = reference_switching(lambda m: params[min(m // k, 2)])
    np.testing.assert_allclose(targets, expected[1:], atol=5e-6, rtol=0)
    np.testing.assert_allclose(targets[-1], params[2][0], atol=1e-5)
    for step, i in ((k, 1), (2 * k, 2)):
        # no jump: the first new target leaves the old plan by at most what the change of
        # acceleration, K (2 |dg| + sum |dw|) / tau^2 (pastor, basis activations <= 1), makes in one period
        plan, _ = held[step]
        dg, dw = np.abs(params[i][0] - params[i - 1][0]), np.abs(params[i][1] - params[i - 1][1]).sum(-1)
        bound = 0.5 * STIFFNESS * (2 * dg + dw) * (DT / DURATION) ** 2
        assert np.all(np.abs(targets[step] - plan[step + 1]) <= bound)
    goal_only, _, _, _ = run(policy.controller(DT, replan_every=k), lambda step: frames[min(step // k, 2)])
    assert np.abs(goal_only - targets).max() > 0.01


def test_free_response_is_the_critically_damped_solution(policy):
    """The homogeneous spring-damper from an offset and a velocity: with the default gains
    (beta_z = alpha_z / 4) it is (h0 + (v0 + w h0) t) exp(-w t), w = alpha_z / (2 tau)."""
    offset, rate = np.array([0.1, -0.2, 0.0, 0.05]), np.array([0.0, 0.3, -0.4, 0.1])
    t = np.arange(30) * DT
    omega = ALPHA_Z / (2 * DURATION)
    expected = (offset + (rate + omega * offset) * t[:, None]) * np.exp(-omega * t)[:, None]
    position, velocity = policy.free_response(offset, rate, 30)
    np.testing.assert_allclose(position, expected, atol=1e-12)
    b = rate + omega * offset
    expected_velocity = (b - omega * (offset + b * t[:, None])) * np.exp(-omega * t)[:, None]
    np.testing.assert_allclose(velocity, expected_velocity, atol=1e-12)


@pytest.mark.parametrize("bad", [1.0, "yes", None])
def test_bad_replan_weights_is_refused(policy, bad):
    with pytest.raises(ValueError, match="replan_weights") as error:
        PlanController(policy, DT, 5, bad)
    assert "\n" not in str(error.value)


def test_replan_weights_without_replan_every_is_refused(policy):
    with pytest.raises(ValueError, match="replan_weights=True needs replan_every") as error:
        policy.controller(DT, replan_weights=True)
    assert "\n" not in str(error.value)
