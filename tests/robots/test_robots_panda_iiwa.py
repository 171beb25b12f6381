"""The Franka Emika Panda and KUKA LBR iiwa 14 R820 of the catalogue against an independent reference.

The reference is the robots' own URDFs shipped in the ``pybullet_data`` package (``franka_panda/panda.urdf``,
``kuka_iiwa/model.urdf``), not lfd's generated URDF: lfd's forward kinematics (:class:`ChainKinematics`) of
every link frame and of the flange must equal PyBullet's link world frames on random configurations within
the limits. Panda: lfd's link ``i`` is ``panda_link{i+1}`` and the tool is the flange ``panda_link8``
(a fixed link 0.107 m along the joint 7 axis). iiwa: PyBullet's ``lbr_iiwa_link_k`` frames sit part way
along the links, so lfd's link frame is PyBullet's moved along its own z axis by a fixed distance (0 for
links 2, 4, 6); the tool is the flange, 0.045 m along z from ``lbr_iiwa_link_7`` (0.126 m from the wrist).
Both position and orientation are compared.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as p
import pybullet_data
import pytest
import torch
import yaml

from lfd.robots import ChainKinematics, load_robot
from lfd.robots.catalogue import catalogue_entry
from lfd.teach import TeachSession, teach_robots

ROOT = Path(__file__).resolve().parents[2]
BOXES = ROOT / "configs" / "teach" / "boxes.yaml"
N_CONFIGS = 200
TOL_M = 1e-3  # the required agreement, 1 mm
TOL_RAD = 1e-3

# name -> (URDF in pybullet_data, PyBullet link name per lfd frame (links then tool), z shift (m) from the
# PyBullet link frame to lfd's frame along the PyBullet link's z axis)
REFERENCES = {
    "panda": (
        "franka_panda/panda.urdf",
        [f"panda_link{k}" for k in range(1, 9)],
        [0.0] * 8,
    ),
    "iiwa14": (
        "kuka_iiwa/model.urdf",
        [f"lbr_iiwa_link_{k}" for k in range(1, 8)] + ["lbr_iiwa_link_7"],
        [0.2025, 0.0, 0.2155, 0.0, 0.2155, 0.0, 0.045, 0.045],
    ),
}


class ReferenceArm:
    """A pybullet_data URDF (fixed base at the world origin) in its own DIRECT client."""

    def __init__(self, urdf: str, joint_names, link_names) -> None:
        self.client = p.connect(p.DIRECT)
        self.body = p.loadURDF(
            str(Path(pybullet_data.getDataPath()) / urdf), useFixedBase=True, physicsClientId=self.client
        )
        info = [p.getJointInfo(self.body, j, physicsClientId=self.client) for j in range(self._n_joints())]
        by_joint = {i[1].decode(): i[0] for i in info}
        by_link = {i[12].decode(): i[0] for i in info}
        missing = [n for n in (*joint_names, *link_names) if n not in by_joint and n not in by_link]
        assert not missing, f"{urdf} lacks {missing}"
        self.joints = [by_joint[n] for n in joint_names]
        self.links = [by_link[n] for n in link_names]

    def _n_joints(self) -> int:
        return p.getNumJoints(self.body, physicsClientId=self.client)

    def frames(self, q: np.ndarray) -> np.ndarray:
        """(len(links), 4, 4) world URDF link frames at joint angles ``q``."""
        for j, angle in zip(self.joints, q):
            p.resetJointState(self.body, j, float(angle), physicsClientId=self.client)
        out = np.tile(np.eye(4), (len(self.links), 1, 1))
        for k, link in enumerate(self.links):
            state = p.getLinkState(
                self.body, link, computeForwardKinematics=True, physicsClientId=self.client
            )
            out[k, :3, :3] = np.reshape(p.getMatrixFromQuaternion(state[5]), (3, 3))
            out[k, :3, 3] = state[4]
        return out

    def close(self) -> None:
        p.disconnect(physicsClientId=self.client)


def _reference_joint_names(name: str) -> list[str]:
    return (
        [f"panda_joint{k}" for k in range(1, 8)]
        if name == "panda"
        else [f"lbr_iiwa_joint_{k}" for k in range(1, 8)]
    )


def fk_errors(name: str, n_configs: int = N_CONFIGS, seed: int = 0) -> tuple[float, float]:
    """Largest position (m) and orientation (rad) difference between lfd's frames (links and flange) and
    the pybullet_data URDF's over ``n_configs`` random configurations within lfd's limits."""
    urdf, links, shifts = REFERENCES[name]
    robot = load_robot(name)
    kin = ChainKinematics(robot.spec)
    ref = ReferenceArm(urdf, _reference_joint_names(name), links)
    shift = np.tile(np.eye(4), (len(shifts), 1, 1))
    shift[:, 2, 3] = shifts
    pos, ang = 0.0, 0.0
    try:
        for q in robot.sample_q(n_configs, torch.Generator().manual_seed(seed)).numpy():
            ours, theirs = kin.frames(q), ref.frames(q) @ shift
            pos = max(pos, float(np.abs(ours[:, :3, 3] - theirs[:, :3, 3]).max()))
            rel = np.swapaxes(ours[:, :3, :3], 1, 2) @ theirs[:, :3, :3]
            cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
            ang = max(ang, float(np.arccos(cos).max()))
    finally:
        ref.close()
    return pos, ang


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_fk_matches_the_pybullet_data_urdf(name):
    pos, ang = fk_errors(name)
    assert pos < TOL_M, f"{name}: largest position error {pos * 1e3:.4f} mm over {N_CONFIGS} configurations"
    assert ang < TOL_RAD, f"{name}: largest orientation error {ang:.2e} rad"


def test_limits_lie_within_the_reference_urdfs():
    """The data-sheet limits are no wider than the public robot descriptions' (the PyBullet URDFs')."""
    for name in ("panda", "iiwa14"):
        urdf, _, _ = REFERENCES[name]
        ref = ReferenceArm(urdf, _reference_joint_names(name), [])
        try:
            info = [p.getJointInfo(ref.body, j, physicsClientId=ref.client) for j in ref.joints]
        finally:
            ref.close()
        spec = load_robot(name).spec
        assert np.all(spec.lower >= np.array([i[8] for i in info]) - 1e-4), name
        assert np.all(spec.upper <= np.array([i[9] for i in info]) + 1e-4), name


def _boxes_scene_without_start() -> dict:
    """The default teach scene (table, wall, block, goal) without its 4-joint WAM start pose."""
    scene = yaml.safe_load(BOXES.read_text())
    scene.pop("start")
    return scene


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_offered_by_teach_and_imitation(name):
    assert name in teach_robots()
    entry = catalogue_entry(name)
    assert entry.teach and entry.retarget == "wrist_path" and entry.closed_form_held_joint is None


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_home_pose_is_a_ready_pose(name):
    robot = load_robot(name)
    kin = ChainKinematics(robot.spec)
    home = robot.home.numpy()
    frames = kin.frames(home)
    tool = frames[-1, :3, 3]
    # tool in front of the robot (+x), above the table, and every link above the base
    assert 0.25 < tool[0] < 0.8 and abs(tool[1]) < 0.05 and 0.3 < tool[2] < 0.8
    assert frames[:, 2, 3].min() > 0.2
    # not singular: the 6 x 7 Jacobian has full rank with margin
    assert np.linalg.svd(kin.jacobian(home), compute_uv=False).min() > 0.1


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_teach_session_starts_on_the_default_scene_and_accepts_a_drag(name):
    scene = _boxes_scene_without_start()
    session = TeachSession(robot=name, scene=scene)  # validates: start (home) within limits, not in collision
    try:
        np.testing.assert_allclose(session.q, load_robot(name).home.numpy())
        assert session.scene.table_z == scene["table_z"]
        assert not session.checker.check(session.q).in_collision
        p0 = session.tool_position.copy()
        for k in range(1, 6):
            result = session.drag(p0 + [0.0, 0.0, 0.01 * k])
            assert result.accepted and result.reachable
        np.testing.assert_allclose(session.tool_position, p0 + [0.0, 0.0, 0.05], atol=1e-3)
    finally:
        session.close()


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_imitation_retargets_a_wrist_path(name):
    """The catalogue's ``wrist_path`` kind works on the arm: the tool follows a person's scaled wrist path."""
    from lfd.human.arm_ik import arm_fk
    from lfd.human.retarget import retarget_wrist_path

    t = np.arange(90) / 30.0  # 3 s at 30 Hz
    angles = np.deg2rad([40.0, 50.0, 10.0, 70.0]) + np.deg2rad(20.0) * np.sin(2 * np.pi * 0.3 * t)[:, None]
    elbow, wrist = arm_fk(angles, 0.30, 0.26)
    shoulder = np.zeros_like(elbow)
    res = retarget_wrist_path(shoulder, elbow, wrist, robot=name)
    model = load_robot(name)
    q = torch.from_numpy(res.q)
    assert model.within_limits(q).all()
    err = np.linalg.norm(model.fk(q).numpy()[:, :3, 3] - res.target, axis=1)
    assert err.max() < 0.01, err.max()
    np.testing.assert_allclose((res.target - res.target[0]) / res.scale, wrist - wrist[0], atol=1e-12)
    assert np.abs(np.diff(res.q, axis=0)).max() < 0.15


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_imitation_executes_a_fitted_motion_in_pybullet(name, tmp_path):
    import lfd.imitation
    from lfd.imitation import ImitationSettings
    from lfd.imitation.settings import DMPSettings, OutputSettings, SimSettings

    robot = load_robot(name)
    t = np.linspace(0.0, 1.0, 60)
    q = robot.home.numpy() + np.outer(0.5 - 0.5 * np.cos(np.pi * t), [0.3, 0.2, 0.0, 0.3, 0.0, 0.2, 0.0])
    cfg = ImitationSettings(
        robot=name,
        dmp=DMPSettings(n_basis=20),
        sim=SimSettings(image_size=(32, 32)),
        outputs=OutputSettings(video=False, gif=False, gif_frames=5),
    )
    fit = lfd.imitation.fit_dmp(cfg, robot, t, q, tmp_path)
    run = lfd.imitation.execute(cfg, robot, np.eye(3), fit, q[-1])
    assert run.q_exec.shape == q.shape
    assert np.sqrt(np.mean((run.q_exec - fit.q_dmp) ** 2)) < 0.05


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_the_wam_closed_form_ik_refuses_the_arm_in_one_line(name):
    from lfd.robots.analytic import wam4_ik_closed_form

    with pytest.raises(ValueError, match="needs the catalogue 'wam4' chain") as error:
        wam4_ik_closed_form(np.zeros((1, 3)), robot=load_robot(name))
    assert "\n" not in str(error.value)
