"""The two policy networks without data: shapes, gradient flow through the DMP layer,
the loss variants, normalisation, and the closed-loop entry points."""

import numpy as np
import pytest
import torch

from lfd.dmp import DMPLayer
from lfd.visuomotor.policies import POLICIES, CNNDMPPolicy, VelocityPolicy

SMALL = dict(channels=[4, 4, 4, 8], hidden=[16, 16], image_size=24, n_steps=12, duration=1.1)


def dmp_batch(b=3, n_basis=5, steps=12, size=24, seed=0):
    g = torch.Generator().manual_seed(seed)
    joints = torch.randn(b, 7, generator=g) * 0.1
    goal = joints + torch.randn(b, 7, generator=g) * 0.3
    weights = torch.randn(b, 7, n_basis, generator=g)
    layer = DMPLayer(n_basis=n_basis, n_steps=steps, dt=1.1 / (steps - 1))
    traj = layer(joints, goal, weights)
    return {
        "image": torch.rand(b, 3, size, size, generator=g),
        "joints": joints,
        "goal": goal,
        "weights": weights,
        "trajectory": traj,
        "ee_path": torch.zeros(b, steps, 3),
        "t": torch.linspace(0, 1.1, steps).expand(b, steps),
        "index": torch.arange(b),
    }


@pytest.fixture
def dmp_policy():
    torch.manual_seed(0)
    return CNNDMPPolicy(n_basis=5, **SMALL)


def test_dmp_policy_shapes(dmp_policy):
    batch = dmp_batch()
    goal_n, weights_n = dmp_policy.predict_params(batch["image"], batch["joints"])
    assert goal_n.shape == (3, 7) and weights_n.shape == (3, 7, 5)
    traj = dmp_policy(batch["image"], batch["joints"])
    assert traj.shape == (3, 12, 7)
    # the DMP starts where the arm is
    torch.testing.assert_close(traj[:, 0], batch["joints"], atol=1e-5, rtol=0)


def test_trajectory_loss_gradient_reaches_the_conv_weights_through_the_dmp_layer(dmp_policy):
    batch = dmp_batch()
    seen = {}
    hp = dmp_policy.hparams
    dmp_policy.layer(hp.n_steps + hp.rest_steps).register_forward_hook(
        lambda mod, inp, out: seen.update(out=out)
    )
    dmp_policy.train()
    loss = dmp_policy.losses(batch)["loss"]
    # the loss is a function of the DMP layer's output ...
    grad_out = torch.autograd.grad(loss, seen["out"], retain_graph=True)[0]
    assert grad_out.abs().sum() > 0
    # ... and its gradient flows back to the first and last conv layers and the temperature
    loss.backward()
    convs = [m for m in dmp_policy.encoder.convs if isinstance(m, torch.nn.Conv2d)]
    for conv in (convs[0], convs[-1]):
        assert conv.weight.grad is not None and conv.weight.grad.abs().sum() > 0
    assert dmp_policy.encoder.softargmax.log_temperature.grad.abs() > 0
    assert dmp_policy.bias_input.grad.abs().sum() > 0


def test_trajectory_loss_covers_rest_samples_after_the_demonstration(dmp_policy, monkeypatch):
    """The loss compares the DMP run on past its duration with the demonstration's last
    sample: about zero for the DMP that drew the demonstration (it rests at its goal, up to
    the forcing term's tail ``K s(tau) (w - (g - y0))`` of the default "pastor" formulation,
    ~1e-4 rad here), and for a wrong goal it counts the rest samples too."""
    batch = dmp_batch()
    pred = {"goal": batch["goal"], "weights": batch["weights"]}
    monkeypatch.setattr(
        dmp_policy,
        "head_outputs",
        lambda image, joints, top=None: (
            torch.cat([pred["goal"], pred["weights"].flatten(1)], 1),
            torch.zeros(len(joints), 0),
        ),
    )
    dmp_policy.hparams.ee_weight = 0.0
    for rest in (0, 8):
        dmp_policy.hparams.rest_steps = rest
        assert dmp_policy.losses(batch)["loss"] < 1e-6
    pred["goal"] = batch["goal"] + 0.3
    on = DMPLayer(n_basis=5, n_steps=20, dt=0.1, tau=1.1)(batch["joints"], pred["goal"], batch["weights"])
    target = torch.cat([batch["trajectory"], batch["trajectory"][:, -1:].expand(-1, 8, -1)], dim=1)
    torch.testing.assert_close(dmp_policy.losses(batch)["loss"], ((on - target) ** 2).mean())
    dmp_policy.hparams.final_weight = 2.0  # the rest samples count as the end of the motion
    assert torch.equal(dmp_policy.time_weights(), torch.tensor([1.0] * 9 + [3.0] * 11))
    with pytest.raises(ValueError, match="rest_steps"):
        CNNDMPPolicy(rest_steps=-1, **SMALL)


def test_parameter_loss_is_the_normalised_mse(dmp_policy):
    batch = dmp_batch()
    dmp_policy.hparams.loss = "params"
    out = dmp_policy.losses(batch)
    goal_n, weights_n = dmp_policy.predict_params(batch["image"], batch["joints"])
    expected = ((goal_n - batch["goal"]) ** 2).mean() + ((weights_n - batch["weights"]) ** 2).mean()
    torch.testing.assert_close(out["loss"], expected)
    with pytest.raises(ValueError, match="loss"):
        CNNDMPPolicy(loss="nope", **SMALL)


def test_ee_term_uses_forward_kinematics(dmp_policy):
    batch = dmp_batch()
    base = dmp_policy.losses(batch)
    dmp_policy.hparams.ee_weight = 2.0
    with_ee = dmp_policy.losses(batch)
    steps = 12 + dmp_policy.hparams.rest_steps  # the demonstration + the rest samples (target: zeros here)
    traj = dmp_policy.rollout(
        batch["joints"], *dmp_policy.predict_params(batch["image"], batch["joints"]), n_steps=steps
    )
    ee = dmp_policy.robot.fk(traj.reshape(-1, 7))[:, :3, 3].reshape(3, steps, 3)
    torch.testing.assert_close(with_ee["ee_mse"], (ee**2).sum(-1).mean())
    torch.testing.assert_close(with_ee["loss"], base["loss"] + 2.0 * with_ee["ee_mse"])


def test_outputs_are_denormalised_with_the_statistics(dmp_policy):
    batch = dmp_batch()
    goal_n, weights_n = dmp_policy.predict_params(batch["image"], batch["joints"])
    dmp_policy.goal_mean.fill_(0.5)
    dmp_policy.goal_std.fill_(2.0)
    dmp_policy.weights_mean.fill_(-0.1)
    dmp_policy.weights_std.fill_(3.0)
    expected = DMPLayer(n_basis=5, n_steps=12, dt=0.1)(
        batch["joints"], 0.5 + 2.0 * goal_n, -0.1 + 3.0 * weights_n
    )
    torch.testing.assert_close(dmp_policy.rollout(batch["joints"], goal_n, weights_n), expected)


def test_plan_and_act_take_camera_frames_and_joints():
    torch.manual_seed(0)
    dmp = CNNDMPPolicy(n_basis=5, **SMALL)
    vel = VelocityPolicy(**SMALL)
    frame = np.random.default_rng(0).integers(0, 256, size=(24, 24, 3), dtype=np.uint8)
    q = np.zeros(7)
    plan = dmp.plan(frame, q)
    assert plan.shape == (12, 7) and plan.dtype == np.float64 and not dmp.training
    assert dmp.plan(np.stack([frame, frame]), np.zeros((2, 7))).shape == (2, 12, 7)
    qd = vel.act(frame, q, 0.2)
    assert qd.shape == (7,) and np.all(np.isfinite(qd))
    assert vel.act(np.stack([frame, frame]), np.zeros((2, 7)), np.array([0.2, 0.3])).shape == (2, 7)
    with pytest.raises(ValueError, match="24x24"):
        vel.act(np.zeros((32, 32, 3), dtype=np.uint8), q, 0.2)


def test_longer_plans_continue_the_same_dmp_to_rest_at_its_goal(dmp_policy):
    """A plan past the demonstrations' length is the same DMP run on: the first T samples are
    unchanged, and the spring-damper then settles at the predicted goal."""
    frame = np.random.default_rng(1).integers(0, 256, size=(24, 24, 3), dtype=np.uint8)
    q = np.full(7, 0.1)
    short, long = dmp_policy.plan(frame, q), dmp_policy.plan(frame, q, n_steps=60)
    assert long.shape == (60, 7)
    np.testing.assert_allclose(long[:12], short, atol=1e-6)
    img, qt, _ = dmp_policy._observation(frame, q)
    goal = dmp_policy.denormalise("goal", dmp_policy.predict_params(img, qt)[0])[0].detach().numpy()
    np.testing.assert_allclose(long[-1], goal, atol=1e-4)
    assert np.abs(np.diff(long[-3:], axis=0)).max() < 1e-5  # at rest
    assert dmp_policy.layer(60) is dmp_policy.layer(60) and dmp_policy.layer() is dmp_policy.dmp
    assert not any("horizon" in k for k in dmp_policy.state_dict())
    with pytest.raises(ValueError, match="n_steps must be >= 2"):
        dmp_policy.plan(frame, q, n_steps=1)


def test_velocity_labels_at_perturbed_states_are_the_experts_correction(monkeypatch):
    torch.manual_seed(0)
    vel = VelocityPolicy(state_noise=0.1, correction_gain=2.0, **SMALL)
    batch = {
        "image": torch.rand(4, 3, 24, 24),
        "joints": torch.randn(4, 7) * 0.1,
        "command": torch.randn(4, 7) * 0.2,
        "t": torch.full((4,), 0.3),
    }
    noise = torch.randn(4, 7) * 0.1
    monkeypatch.setattr(vel, "perturbation", lambda joints: noise)
    pred = vel.features(batch["image"], batch["joints"] + noise, vel.phase(batch["t"], 4))
    expected = ((pred - vel.normalise("velocity", batch["command"] - 2.0 * noise)) ** 2).mean()
    torch.testing.assert_close(vel.losses(batch)["loss"], expected)
    monkeypatch.undo()
    vel.train()
    assert vel.perturbation(batch["joints"]).std() > 0.05
    vel.eval()  # validation and closed loop: the demonstrated states, unperturbed
    assert torch.equal(vel.perturbation(batch["joints"]), torch.zeros(4, 7))
    with pytest.raises(ValueError, match="state_noise"):
        VelocityPolicy(state_noise=-0.1, **SMALL)


def test_velocity_policy_sees_the_phase_of_the_episode():
    """The clock is an input (the demonstrations start at rest: without it the start pose
    is a fixed point of the closed loop); the phase t / duration is held at 1 after the end."""
    torch.manual_seed(0)
    vel = VelocityPolicy(**SMALL)
    frame = np.random.default_rng(0).integers(0, 256, size=(24, 24, 3), dtype=np.uint8)
    q = np.zeros(7)
    early, late = vel.act(frame, q, 0.0), vel.act(frame, q, 0.8)
    assert not np.allclose(early, late)
    np.testing.assert_allclose(vel.act(frame, q, 1.1), vel.act(frame, q, 5.0))
    with pytest.raises(ValueError, match="needs `time`"):
        vel.act(frame, q)
    with pytest.raises(ValueError, match="time must be finite and >= 0"):
        vel.act(frame, q, float("nan"))
    with pytest.raises(ValueError, match="time must be finite and >= 0"):
        vel.act(frame, q, -0.1)
    # the time enters the loss through the batch's "t"
    batch = {"image": torch.rand(4, 3, 24, 24), "joints": torch.zeros(4, 7), "command": torch.zeros(4, 7)}
    loss0 = vel.losses({**batch, "t": torch.zeros(4)})["loss"]
    loss1 = vel.losses({**batch, "t": torch.full((4,), 0.9)})["loss"]
    assert loss0 != loss1
    # without the phase input the head is one input narrower and time is not needed
    blind = VelocityPolicy(phase_input=False, **SMALL)
    assert blind.head[0].in_features == vel.head[0].in_features - 1
    np.testing.assert_allclose(blind.act(frame, q), blind.act(frame, q, 0.5))


def test_auxiliary_labels_train_the_shared_features_and_are_checked():
    """aux_weight > 0: the head's extra outputs learn the approach mode and target point,
    their loss reaches the trunk, and the policy's outputs keep their shape."""
    torch.manual_seed(0)
    policy = CNNDMPPolicy(n_basis=5, aux_weight=1.0, global_pool=True, **SMALL)
    assert policy.n_aux == 4 and "target_point" in policy.stat_names
    batch = dmp_batch()
    with pytest.raises(ValueError, match="'top'"):
        policy.losses(batch)
    batch["top"] = torch.tensor([1.0, 0.0, 1.0])
    batch["target_point"] = torch.tensor([[0.5, 0.0, -0.2], [0.6, 0.1, -0.3], [0.55, -0.1, -0.25]])
    policy.target_point_mean.copy_(batch["target_point"].mean(0))
    policy.target_point_std.copy_(batch["target_point"].std(0))
    policy.train()
    losses = policy.losses(batch)
    no_aux = losses["loss"] - policy.hparams.aux_weight * losses["aux_loss"]
    assert losses["aux_loss"] > 0 and losses["loss"] > no_aux
    losses["aux_loss"].backward()
    assert policy.encoder.convs[0].weight.grad.abs().sum() > 0
    # a few steps on the auxiliary loss alone bring the mode error to 0
    opt = torch.optim.Adam(policy.parameters(), lr=1e-2)
    for _ in range(60):
        opt.zero_grad()
        policy.losses(batch)["aux_loss"].backward()
        opt.step()
    assert policy.losses(batch)["aux_mode_error"] == 0
    assert policy(batch["image"], batch["joints"]).shape == (3, 12, 7)
    with pytest.raises(ValueError, match="aux_weight"):
        CNNDMPPolicy(n_basis=5, aux_weight=-1.0, **SMALL)
    velocity = VelocityPolicy(aux_weight=0.5, **SMALL)
    assert velocity.head[-1].out_features == 7 + 4


def test_a_keypoint_learns_where_the_target_appears_without_a_placement():
    """keypoint_weight > 0 without placement_dim: the first keypoint is trained onto the batch's
    ``target_pixels`` (a bright square on a dark image here), its loss is added to the trajectory
    loss, and a batch without the label gets one line naming it."""
    torch.manual_seed(0)
    policy = CNNDMPPolicy(n_basis=5, keypoint_weight=10.0, **SMALL)
    batch = dmp_batch(b=4)
    with pytest.raises(
        ValueError, match=r"^CNNDMPPolicy\(keypoint_weight > 0\): batches need 'target_pixels'"
    ):
        policy.losses(batch)
    g = torch.Generator().manual_seed(1)
    centres = torch.randint(4, 20, (4, 2), generator=g)
    batch["image"] = torch.zeros(4, 3, 24, 24)
    for k, (u, v) in enumerate(centres.tolist()):
        batch["image"][k, :, v - 1 : v + 2, u - 1 : u + 2] = (
            1.0  # a 3 x 3 px object centred on (u + 0.5, v + 0.5)
        )
    batch["target_pixels"] = centres.float() + 0.5
    policy.train()
    losses = policy.losses(batch)
    plain = CNNDMPPolicy(n_basis=5, **SMALL)
    plain.load_state_dict(policy.state_dict())
    plain.train()
    torch.testing.assert_close(losses["loss"], plain.losses(batch)["loss"] + 10.0 * losses["keypoint_mse"])
    before = float(losses["keypoint_err_px"].detach())
    opt = torch.optim.Adam(policy.parameters(), lr=1e-2)
    for _ in range(150):
        opt.zero_grad()
        policy.losses(batch)["keypoint_mse"].backward()
        opt.step()
    after = float(policy.losses(batch)["keypoint_err_px"].detach())
    assert before > 3.0 and after < 1.5, (before, after)
    with pytest.raises(
        ValueError, match=r"^CNNDMPPolicy.keypoint_head: 'supervised' needs keypoint_weight > 0 and "
    ):
        CNNDMPPolicy(n_basis=5, keypoint_weight=1.0, keypoint_head="supervised", **SMALL)


def test_mode_heads_follow_the_demonstrated_mode_in_training_and_the_logit_at_run_time():
    torch.manual_seed(0)
    with pytest.raises(ValueError, match="mode_heads"):
        CNNDMPPolicy(n_basis=5, mode_heads=True, **SMALL)
    policy = CNNDMPPolicy(n_basis=5, aux_weight=1.0, mode_heads=True, **SMALL).eval()
    k = 7 + 7 * 5
    assert policy.head[-1].out_features == 2 * k + 4
    batch = dmp_batch()
    raw = {}
    policy.head.register_forward_hook(lambda mod, inp, out: raw.update(out=out))
    side, aux = policy.head_outputs(batch["image"], batch["joints"], top=torch.zeros(3))
    torch.testing.assert_close(side, raw["out"][:, :k])
    top, _ = policy.head_outputs(batch["image"], batch["joints"], top=torch.ones(3))
    torch.testing.assert_close(top, raw["out"][:, k : 2 * k])
    chosen, aux = policy.head_outputs(batch["image"], batch["joints"])
    for i in range(3):
        torch.testing.assert_close(chosen[i], (top if aux[i, 0] > 0 else side)[i])
    # the losses train the head of each demonstration's own mode
    batch["top"] = torch.tensor([1.0, 0.0, 1.0])
    batch["target_point"] = torch.zeros(3, 3)
    policy.train()
    policy.losses(batch)["loss"].backward()
    grad = policy.head[-1].weight.grad
    assert grad[:k].abs().sum() > 0 and grad[k : 2 * k].abs().sum() > 0
    policy.zero_grad()
    batch["top"] = torch.zeros(3)
    policy.losses(batch)["loss"].backward()
    assert policy.head[-1].weight.grad[k : 2 * k].abs().sum() == 0


def test_kinds_and_item_modes():
    assert {k: c.item_mode for k, c in POLICIES.items()} == {
        "cnn_dmp": "dmp",
        "velocity": "velocity",
        "act": "velocity",
        "diffusion": "velocity",
    }
    vel = VelocityPolicy(**SMALL)
    assert vel.hparams.kind == "velocity"
    with pytest.raises(ValueError, match="holds 'cnn_dmp' policies"):
        CNNDMPPolicy(kind="velocity", **SMALL)


def test_colour_tta_is_the_mean_over_the_six_channel_orders_and_ignores_colour_order():
    """Test-time colour averaging: the head output (each head and the mode logit) is the mean
    of the plain outputs of the 6 RGB orders, so permuting the input's colours changes
    nothing; the depth channel is never moved, and training batches are not averaged."""
    torch.manual_seed(0)
    policy = CNNDMPPolicy(
        n_basis=5, aux_weight=1.0, mode_heads=True, colour_augment=True, depth=True, **SMALL
    ).eval()
    g = torch.Generator().manual_seed(3)
    image, joints = torch.rand(4, 4, 24, 24, generator=g), torch.randn(4, 7, generator=g) * 0.1
    orders = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    with torch.no_grad():
        plain = [policy._head_raw(image[:, [*o, 3]], joints, None) for o in orders]
        policy.colour_tta = True
        averaged = policy._head_raw(image, joints, None)
        main, aux = policy.head_outputs(image, joints)
        swapped, swapped_aux = policy.head_outputs(image[:, [2, 0, 1, 3]], joints)
        depth_moved = policy.head_outputs(image[:, [3, 1, 2, 0]], joints)[0]
    torch.testing.assert_close(averaged, torch.stack(plain).mean(0))
    k = policy.output_dim
    heads = averaged[:, : 2 * k].view(4, 2, k)
    torch.testing.assert_close(aux, averaged[:, 2 * k :])
    torch.testing.assert_close(main, heads[torch.arange(4), (aux[:, 0] > 0).long()])
    torch.testing.assert_close(swapped, main, rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(swapped_aux, aux, rtol=1e-5, atol=1e-5)
    assert (depth_moved - main).abs().max() > 1e-6  # the depth channel is not averaged over
    policy.train()  # training batches are never averaged (batch-norm uses the batch's statistics here)
    with torch.no_grad():
        on = policy._head_raw(image, joints, None)
        policy.colour_tta = False
        torch.testing.assert_close(on, policy._head_raw(image, joints, None))
    assert on.shape == (4, averaged.shape[1])


def test_colour_tta_needs_a_colour_augmented_policy():
    policy = VelocityPolicy(**SMALL)
    with pytest.raises(ValueError, match="colour_tta.*colour_augment"):
        policy.colour_tta = True
    assert policy.colour_tta is False
    policy.colour_tta = False  # switching it off is always allowed


def test_brightness_augment_is_checked_and_changes_only_training_batches(monkeypatch):
    with pytest.raises(ValueError, match="brightness_augment: needs depth=true"):
        CNNDMPPolicy(n_basis=5, brightness_augment=[0.5, 2.0], **SMALL)
    for bad in ([2.0, 0.5], [0.0, 1.0], [0.5], [0.5, float("nan")], "bright"):
        with pytest.raises(ValueError, match=r"brightness_augment: expected \[low, high\]"):
            CNNDMPPolicy(n_basis=5, brightness_augment=bad, depth=True, **SMALL)
    policy = CNNDMPPolicy(n_basis=5, brightness_augment=[0.25, 0.5], depth=True, **SMALL)
    assert policy.hparams.brightness_augment == [0.25, 0.5]
    batch = dmp_batch()
    g = torch.Generator().manual_seed(5)
    image = torch.cat([torch.rand(3, 3, 24, 24, generator=g), torch.full((3, 1, 24, 24), 0.8)], dim=1)
    for i in range(3):  # an object nearer than the table, somewhere else in each image
        image[i, 3, 4 * i : 4 * i + 5, 3:8] = 0.5
    batch["image"] = image
    seen = []
    monkeypatch.setattr(policy, "losses", lambda b: seen.append(b["image"]) or {"loss": b["image"].sum()})
    monkeypatch.setattr(policy, "log_dict", lambda *a, **k: None)
    monkeypatch.setattr(policy, "log", lambda *a, **k: None)
    monkeypatch.setattr(policy, "optimizers", lambda: torch.optim.SGD(policy.parameters(), lr=0.1))
    policy.training_step(batch, 0)
    out = seen[0]
    obj = image[:, 3:] < 0.8
    assert torch.equal(out[:, 3], image[:, 3]) and torch.equal(
        out[:, :3][~obj.expand(-1, 3, -1, -1)], image[:, :3][~obj.expand(-1, 3, -1, -1)]
    )
    assert (
        out[:, :3][obj.expand(-1, 3, -1, -1)] < image[:, :3][obj.expand(-1, 3, -1, -1)]
    ).all()  # factors <= 0.5 darken


def test_policies_and_their_data_import_without_pybullet():
    """The policies, their datamodule package, the ch. 5 models and the training helpers load
    no simulator: only lfd.sim (and what drives a simulator) may import PyBullet."""
    import subprocess
    import sys

    code = (
        "import sys, lfd.visuomotor.policies, lfd.visuomotor.data, lfd.model_reaching, lfd.training\n"
        "assert 'pybullet' not in sys.modules, sorted(m for m in sys.modules if m.startswith('lfd'))"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
