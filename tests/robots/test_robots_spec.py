"""Robot descriptions: catalogue values against the thesis, DH conversion, validation."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from lfd.robots import Robot, RobotSpec, available_robots, load_robot
from lfd.robots.spec import composite_inertial, cylinder_inertia, make_transform, matrix_to_rpy, rpy_to_matrix

DEG = np.pi / 180


def dh_standard(alpha, a, d, theta):
    """Independent textbook standard DH matrix Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array(
        [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]]
    )


def dh_modified(alpha, a, d, theta):
    """Independent textbook modified (Craig) DH matrix Rx(alpha) Tx(a) Rz(theta) Tz(d)."""
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array(
        [[ct, -st, 0, a], [st * ca, ct * ca, -sa, -d * sa], [st * sa, ct * sa, ca, d * ca], [0, 0, 0, 1]]
    )


def chain(rows, q, matrix, base, tool):
    out = base.copy()
    for (alpha, a, d, offset), angle in zip(rows, q):
        out = out @ matrix(alpha, a, d, angle + offset)
    return out @ tool


SAWYER_DH = [(-90, 0.081, 0), (90, 0, 0.191), (-90, 0, 0.399), (90, 0, -0.1683), (-90, 0, 0.3965), (90, 0, 0.136),
             (0, 0, 0.1785)]  # fmt: skip
WAM_DH = [(-90, 0, 0), (90, 0, 0), (-90, 0.045, 0.55), (90, -0.045, 0)]


def test_available_robots_and_unknown_name():
    assert set(available_robots()) == {"pr2_right_arm", "sawyer", "wam4", "panda", "iiwa14", "human_arm"}
    with pytest.raises(ValueError, match="pr2_right_arm, sawyer, wam4, human_arm"):
        load_robot("ur5")


def test_unknown_option_rejected():
    with pytest.raises(ValueError, match="no option"):
        load_robot("sawyer", body_mass=70.0)


@pytest.mark.parametrize(
    ("name", "dh", "base", "tool"),
    [
        ("sawyer", SAWYER_DH, make_transform((0, 0, 0.316)), np.eye(4)),
        ("wam4", WAM_DH, np.eye(4), make_transform((0, 0, 0.35))),
    ],
)
def test_dh_robots_match_textbook_product(name, dh, base, tool):
    robot = load_robot(name)
    rows = [(alpha * DEG, a, d, 0.0) for alpha, a, d in dh]
    q = robot.sample_q(50, torch.Generator().manual_seed(0))
    expected = np.array([chain(rows, qi, dh_standard, base, tool) for qi in q.numpy()])
    np.testing.assert_allclose(robot.fk(q).numpy(), expected, atol=1e-12)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_from_dh_with_offsets_matches_textbook(convention):
    rng = np.random.default_rng(1)
    rows = np.column_stack(
        [rng.uniform(-np.pi, np.pi, 5), rng.uniform(-0.5, 0.5, (5, 2)), rng.uniform(-1, 1, 5)]
    )
    tool = make_transform((0.01, 0.02, 0.1), (0.1, 0.2, 0.3))
    base = make_transform((0.3, -0.2, 0.5), (0.0, 0.0, 1.0))
    spec = RobotSpec.from_dh(
        "test",
        rows,
        convention=convention,
        joint_names=[f"j{i}" for i in range(5)],
        lower=[-3.0] * 5,
        upper=[3.0] * 5,
        velocity_limits=[1.0] * 5,
        effort_limits=[1.0] * 5,
        link_masses=[1.0] * 5,
        link_radii=[0.05] * 5,
        home=[0.0] * 5,
        base_transform=base,
        tool_transform=tool,
    )
    robot = Robot(spec)
    q = robot.sample_q(20, torch.Generator().manual_seed(2))
    matrix = dh_standard if convention == "standard" else dh_modified
    expected = np.array([chain(rows, qi, matrix, base, tool) for qi in q.numpy()])
    np.testing.assert_allclose(robot.fk(q).numpy(), expected, atol=1e-12)


def test_pr2_matches_spec():
    robot = load_robot("pr2_right_arm")
    spec = robot.spec
    assert robot.n_dof == 7
    assert robot.joint_names[0] == "r_shoulder_pan_joint" and robot.joint_names[-1] == "r_wrist_roll_joint"
    np.testing.assert_allclose(spec.joint_xyz[0], [0, -0.188, 0])
    np.testing.assert_allclose(spec.joint_xyz[[1, 3, 5], 0], [0.1, 0.4, 0.321])
    np.testing.assert_allclose(spec.tool_transform[:3, 3], [0.18, 0, 0])
    np.testing.assert_allclose(spec.joint_axis, np.eye(3)[[2, 1, 0, 1, 0, 1, 0]])
    assert spec.continuous.tolist() == [False, False, False, False, True, False, True]
    limited = ~spec.continuous
    np.testing.assert_allclose(spec.lower[limited], [-2.2854, -0.5236, -3.9, -2.3213, -2.18])
    np.testing.assert_allclose(spec.upper[limited], [0.7146, 1.3963, 0.8, 0, 0])
    np.testing.assert_allclose(spec.lower[~limited], -np.pi)
    np.testing.assert_allclose(spec.upper[~limited], np.pi)
    np.testing.assert_allclose(spec.link_masses, [25.8, 2.75, 6.02, 1.90, 2.58, 0.61, 1.01])
    # Original start pose (upper-arm roll, pan, lift, forearm roll, elbow, wrist flex, wrist roll), reordered.
    original = dict(zip(["uar", "pan", "lift", "fr", "elbow", "wf", "wr"], [-90, -70, 0, 0, -70, 0, 0]))
    chain_order = [original[k] for k in ["pan", "lift", "uar", "elbow", "fr", "wf", "wr"]]
    np.testing.assert_allclose(robot.home.numpy(), np.array(chain_order) * DEG)
    assert bool(robot.within_limits(robot.home[None]))


def test_sawyer_and_wam_limits_masses_home():
    sawyer, wam = load_robot("sawyer"), load_robot("wam4")
    np.testing.assert_allclose(sawyer.lower, [-3.0503, -3.8095, -3.0426, -3.0439, -2.9761, -2.9761, -4.7124])
    np.testing.assert_allclose(sawyer.upper, [3.0503, 2.2736, 3.0426, 3.0439, 2.9761, 2.9761, 4.7124])
    np.testing.assert_allclose(sawyer.spec.link_masses, [5.32, 4.51, 1.75, 2.51, 1.11, 1.56, 0.33])
    np.testing.assert_allclose(sawyer.home, np.array([0, -50, 0, 120, 0, 0, 0]) * DEG)
    np.testing.assert_allclose(sawyer.spec.base_transform[:3, 3], [0, 0, 0.316])
    np.testing.assert_allclose(wam.lower, [-2.6, -2.0, -2.8, -0.9])
    np.testing.assert_allclose(wam.upper, [2.6, 2.0, 2.8, 3.1])
    np.testing.assert_allclose(wam.spec.link_masses, [10.77, 3.87, 1.80, 1.07])
    for robot in (sawyer, wam):
        assert not robot.continuous.any()
        assert bool(robot.within_limits(robot.home[None]))


@pytest.mark.parametrize("sex", ["male", "female"])
def test_human_arm_masses_and_centres_of_mass(sex):
    lengths = dict(upper_arm_length=0.32, forearm_length=0.25, hand_length=0.18)
    robot = load_robot("human_arm", body_mass=80.0, sex=sex, **lengths)
    fractions = {"male": (0.0271, 0.0162, 0.0061), "female": (0.0255, 0.0138, 0.0056)}[sex]
    upper, forearm, hand = (80.0 * f for f in fractions)
    spec = robot.spec
    np.testing.assert_allclose(spec.link_masses, [0, 0, upper, forearm + hand])
    np.testing.assert_allclose(spec.link_coms[2], [0, 0, -0.577 * 0.32])
    forearm_hand_com = (forearm * 0.457 * 0.25 + hand * (0.25 + 0.5 * 0.18)) / (forearm + hand)
    np.testing.assert_allclose(spec.link_coms[3], [0, 0, -forearm_hand_com])
    np.testing.assert_allclose(robot.lower, np.array([-100, 0, -90, 0]) * DEG)
    np.testing.assert_allclose(robot.upper, np.array([160, 180, 90, 150]) * DEG)


def test_human_arm_joint_conventions():
    # ISB shoulder (plane of elevation, elevation, axial rotation) and elbow flexion
    robot = load_robot("human_arm", upper_arm_length=0.3, forearm_length=0.25)
    right = np.pi / 2
    rows = [[0.0, 0, 0, 0], [0, right, 0, 0], [right, right, 0, 0], [0, np.pi, 0, 0], [0, 0, 0, right],
            [0, 0, right, right], [-right, right / 2, 0, 0]]  # fmt: skip
    q = torch.tensor(rows, dtype=torch.float64)
    frames = robot.fk(q, all_links=True).numpy()
    elbow, wrist = frames[:, 3, :3, 3], frames[:, 4, :3, 3]
    np.testing.assert_allclose(wrist[0], [0, 0, -0.55], atol=1e-12)  # hanging straight down
    np.testing.assert_allclose(
        elbow[1], [0, -0.3, 0], atol=1e-12
    )  # plane 0: abduction, sideways away from the body
    np.testing.assert_allclose(elbow[2], [0.3, 0, 0], atol=1e-12)  # plane 90 deg: forward flexion
    np.testing.assert_allclose(elbow[3], [0, 0, 0.3], atol=1e-12)  # elevation 180 deg: straight up
    np.testing.assert_allclose(wrist[4], [0.25, 0, -0.3], atol=1e-12)  # elbow flexion: forearm forwards
    np.testing.assert_allclose(
        wrist[5], [0, 0.25, -0.3], atol=1e-12
    )  # internal rotation: forearm towards the body
    assert elbow[6, 0] < -0.2  # negative plane: the arm behind the body (extension)


@pytest.mark.parametrize(
    "options", [dict(body_mass=-1.0), dict(forearm_length=0.0), dict(sex="x"), dict(hand_length=float("nan"))]
)
def test_human_arm_bad_options(options):
    with pytest.raises(ValueError, match="human_arm option"):
        load_robot("human_arm", **options)


@pytest.mark.parametrize("name", available_robots())
def test_inertias_are_physical(name):
    spec = load_robot(name).spec
    for mass, inertia in zip(spec.link_masses, spec.link_inertias):
        moments = np.linalg.eigvalsh(inertia)
        assert np.all(moments >= 0)
        assert moments[0] + moments[1] >= moments[2] * (1 - 1e-12)  # triangle inequality
        assert (mass == 0) == np.allclose(inertia, 0)


def test_composite_inertial_parallel_axis():
    rod = cylinder_inertia(2.0, 0.01, 1.0, (0, 0, 1))
    halves = [(1.0, np.array([0, 0, 0.25]), rod / 2), (1.0, np.array([0, 0, -0.25]), rod / 2)]
    mass, com, inertia = composite_inertial(halves)
    assert mass == 2.0
    np.testing.assert_allclose(com, 0, atol=1e-15)
    np.testing.assert_allclose(inertia, rod + 2 * 0.25**2 * np.diag([1, 1, 0]))


def test_rpy_round_trip_including_gimbal_lock():
    rng = np.random.default_rng(0)
    cases = [rng.uniform(-np.pi, np.pi, 3) for _ in range(100)] + [
        (0.3, np.pi / 2, -0.2),
        (0.1, -np.pi / 2, 0.4),
    ]
    for rpy in cases:
        rotation = rpy_to_matrix(rpy)
        np.testing.assert_allclose(rpy_to_matrix(matrix_to_rpy(rotation)), rotation, atol=1e-12)


def _sawyer_spec() -> RobotSpec:
    return load_robot("sawyer").spec


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (dict(lower=np.full(7, 4.0)), "lower < upper"),
        (dict(home=np.full(7, 3.1)), "outside the limits"),
        (dict(joint_xyz=np.zeros((6, 3))), "joint_xyz must have shape"),
        (dict(link_masses=np.full(7, np.nan)), "NaN"),
        (dict(base_transform=np.diag([2.0, 1, 1, 1])), "rigid transform"),
        (dict(link_inertias=-np.tile(np.eye(3), (7, 1, 1))), "positive semi-definite"),
        (dict(joint_names=("a",) * 7), "unique"),
        (dict(joint_axis=np.zeros((7, 3))), "non-zero"),
    ],
)
def test_spec_validation(changes, message):
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(_sawyer_spec(), **changes)


def test_spec_is_immutable():
    spec = _sawyer_spec()
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.name = "x"
    with pytest.raises(ValueError):
        spec.lower[0] = 0.0


def test_base_transform_option_moves_the_robot():
    shift = make_transform((1.0, 2.0, 3.0), (0.0, 0.0, 0.5))
    moved, plain = load_robot("wam4", base_transform=shift), load_robot("wam4")
    q = moved.sample_q(10, torch.Generator().manual_seed(0))
    np.testing.assert_allclose(moved.fk(q).numpy(), shift @ plain.fk(q).numpy(), atol=1e-12)
