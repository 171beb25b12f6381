"""Catalogue of the project's robots (the thesis's robots): ``load_robot(name, **options)``.

=================  ====  ==========================================================
name               DoF   notes
=================  ====  ==========================================================
``pr2_right_arm``  7     URDF chain from ``torso_lift_link`` (base frame = torso
                         lift link); forearm and wrist roll are continuous; the
                         home pose has the wrist flex at its upper limit (0)
``sawyer``         7     standard DH, base 0.316 m above the world frame
``wam4``           4     standard DH, tool d = 0.35 m; closed-form IK in
                         :mod:`lfd.robots.analytic`
``panda``          7     Franka Emika Panda: Franka's modified (Craig) DH table as
                         published, tool = flange (0.107 m past joint 7); world
                         z = 0 is the mounting plate; home = Franka's ready pose
``iiwa14``         7     KUKA LBR iiwa 14 R820: modified DH from KUKA's dimensions
                         (0.36 / 0.42 / 0.40 / 0.126 m), KUKA's joint zeros and
                         directions; tool = flange; world z = 0 is the mounting plate
``human_arm``      4     right arm, base frame at the shoulder, ISB shoulder angles
                         (plane of elevation, elevation, axial rotation) and elbow
                         flexion; segment lengths, body mass and sex are options
=================  ====  ==========================================================

Where the thesis gives no inertia, links are solid cylinders of their mass along the
link (:func:`lfd.robots.spec.segment_inertials`) with the radii set in each builder
(also used for the URDF shapes); velocity and
effort limits not in the thesis are values from the public robot descriptions (PR2,
Sawyer) or nominal values (WAM, human arm) used only for sampling and URDF limits.

Panda and iiwa 14: position, velocity and torque limits are the manufacturers' data sheets
(Franka Emika "Robot and interface specifications" of the Franka Control Interface; KUKA
"LBR iiwa 7 R800, LBR iiwa 14 R820 Specification", the iiwa 14 R820 columns). Neither publishes
link masses: the Panda's are the identified masses of Gaz et al. (2019, RA-L, "Dynamic
Identification of the Franka Emika Panda Robot"), as in Franka's ``franka_description``; the
iiwa's are those of its public robot description (the ``lbr_iiwa`` URDF PyBullet ships). The
capsule radii are read off the dimension drawings of both data sheets (link housing diameters,
rounded up). Their kinematics are checked against the URDFs in ``pybullet_data`` to 1 mm.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable

import numpy as np

from .robot import Robot
from .spec import RobotSpec, composite_inertial, cylinder_inertia, make_transform, segment_inertials

__all__ = [
    "IIWA14_FLANGE_D",
    "PANDA_FLANGE_D",
    "WAM4_DH",
    "WAM4_TOOL_D",
    "CatalogueEntry",
    "available_robots",
    "catalogue_entries",
    "catalogue_entry",
    "load_robot",
]

_DEG = np.pi / 180.0

# Barrett WAM, standard DH rows (alpha, a, d) and tool offset along the last z axis (thesis).
WAM4_DH = ((-np.pi / 2, 0.0, 0.0), (np.pi / 2, 0.0, 0.0), (-np.pi / 2, 0.045, 0.55), (np.pi / 2, -0.045, 0.0))
WAM4_TOOL_D = 0.35
# Flange distance (m) along the last joint axis: Franka Panda (from the joint-7 frame of Franka's DH
# table) and KUKA LBR iiwa 14 R820 (from the wrist centre, the joint 6 axis).
PANDA_FLANGE_D = 0.107
IIWA14_FLANGE_D = 0.126


def _pr2_right_arm() -> RobotSpec:
    # Link masses (thesis): the roll joints carry the big links behind them (upper arm,
    # forearm), the wrist roll link carries the gripper (0.58 kg) and fingers (0.43 kg).
    masses = [25.8, 2.75, 6.02, 1.90, 2.58, 0.61, 0.58 + 0.43]
    radii = [0.12, 0.08, 0.06, 0.05, 0.05, 0.04, 0.04]
    x, y, z = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    xyz = np.array(
        [(0, -0.188, 0), (0.1, 0, 0), (0, 0, 0), (0.4, 0, 0), (0, 0, 0), (0.321, 0, 0), (0, 0, 0)], float
    )
    axes = np.array([z, y, x, y, x, y, x])
    tool = make_transform((0.18, 0.0, 0.0))
    coms, inertias = segment_inertials(xyz, axes, tool[:3, 3], masses, radii)
    continuous = np.array([False, False, False, False, True, False, True])
    lower = np.where(continuous, -np.pi, [-2.2854, -0.5236, -3.9, -2.3213, 0.0, -2.18, 0.0])
    upper = np.where(continuous, np.pi, [0.7146, 1.3963, 0.8, 0.0, 0.0, 0.0, 0.0])
    return RobotSpec(
        name="pr2_right_arm",
        joint_names=(
            "r_shoulder_pan_joint",
            "r_shoulder_lift_joint",
            "r_upper_arm_roll_joint",
            "r_elbow_flex_joint",
            "r_forearm_roll_joint",
            "r_wrist_flex_joint",
            "r_wrist_roll_joint",
        ),
        link_names=(
            "r_shoulder_pan_link",
            "r_shoulder_lift_link",
            "r_upper_arm_link",
            "r_elbow_flex_link",
            "r_forearm_link",
            "r_wrist_flex_link",
            "r_wrist_roll_link",
        ),
        joint_xyz=xyz,
        joint_rpy=np.zeros((7, 3)),
        joint_axis=axes,
        lower=lower,
        upper=upper,
        continuous=continuous,
        velocity_limits=[2.088, 2.082, 3.27, 3.3, 3.6, 3.078, 3.6],
        # Public PR2 motor limits, except the shoulder lift: on the real arm a passive
        # counterbalance carries the arm's weight, which this model lacks; holding the arm
        # against gravity takes up to 46 N m there, so its limit is raised from 30 to 60 N m.
        effort_limits=[30.0, 60.0, 30.0, 30.0, 30.0, 10.0, 10.0],
        link_masses=masses,
        link_coms=coms,
        link_inertias=inertias,
        link_radii=radii,
        base_transform=np.eye(4),
        tool_transform=tool,
        # Original start pose reordered into chain order; wrist flex 0 is its upper limit.
        home=np.array([-70.0, 0.0, -90.0, -70.0, 0.0, 0.0, 0.0]) * _DEG,
    )


def _sawyer() -> RobotSpec:
    d = _DEG
    dh = [(-90 * d, 0.081, 0.0), (90 * d, 0.0, 0.191), (-90 * d, 0.0, 0.399), (90 * d, 0.0, -0.1683),
          (-90 * d, 0.0, 0.3965), (90 * d, 0.0, 0.136), (0.0, 0.0, 0.1785)]  # fmt: skip
    return RobotSpec.from_dh(
        "sawyer",
        dh,
        joint_names=[f"right_j{i}" for i in range(7)],
        link_names=[f"right_l{i}" for i in range(7)],
        lower=[-3.0503, -3.8095, -3.0426, -3.0439, -2.9761, -2.9761, -4.7124],
        upper=[3.0503, 2.2736, 3.0426, 3.0439, 2.9761, 2.9761, 4.7124],
        velocity_limits=[1.74, 1.328, 1.957, 1.957, 3.485, 3.485, 4.545],
        effort_limits=[80.0, 80.0, 40.0, 40.0, 9.0, 9.0, 9.0],
        link_masses=[5.32, 4.51, 1.75, 2.51, 1.11, 1.56, 0.33],
        link_radii=[0.08, 0.07, 0.06, 0.06, 0.05, 0.05, 0.04],
        home=np.array([0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0]) * d,
        base_transform=make_transform((0.0, 0.0, 0.316)),
    )


def _wam4() -> RobotSpec:
    return RobotSpec.from_dh(
        "wam4",
        WAM4_DH,
        joint_names=[f"wam_j{i}" for i in range(1, 5)],
        link_names=[f"wam_link{i}" for i in range(1, 5)],
        lower=[-2.6, -2.0, -2.8, -0.9],
        upper=[2.6, 2.0, 2.8, 3.1],
        velocity_limits=[2.0, 2.0, 2.0, 2.0],
        effort_limits=[60.0, 60.0, 30.0, 30.0],
        link_masses=[10.77, 3.87, 1.80, 1.07],
        link_radii=[0.1, 0.08, 0.05, 0.04],
        # Elbow bent 90 deg: a non-singular ready pose (q = 0 is the stretched-up singularity).
        home=[0.0, 0.0, 0.0, np.pi / 2],
        tool_transform=make_transform((0.0, 0.0, WAM4_TOOL_D)),
    )


def _panda() -> RobotSpec:
    # Franka Emika Panda, Franka's own modified (Craig) DH table, used as is (convention="modified");
    # rows (alpha, a, d); the flange is d = 0.107 m along the last z axis.
    d = _DEG
    dh = [(0.0, 0.0, 0.333), (-90 * d, 0.0, 0.0), (90 * d, 0.0, 0.316), (90 * d, 0.0825, 0.0),
          (-90 * d, -0.0825, 0.384), (90 * d, 0.0, 0.0), (90 * d, 0.088, 0.0)]  # fmt: skip
    return RobotSpec.from_dh(
        "panda",
        dh,
        convention="modified",
        joint_names=[f"panda_joint{i}" for i in range(1, 8)],
        link_names=[f"panda_link{i}" for i in range(1, 8)],
        lower=[-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973],
        upper=[2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973],
        velocity_limits=[2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100],
        effort_limits=[87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0],
        link_masses=[4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522],
        link_radii=[0.075, 0.07, 0.065, 0.065, 0.06, 0.055, 0.045],
        # Franka's "ready" pose: elbow bent, flange 0.31 m in front of the base, 0.49 m up, pointing down.
        home=np.array([0.0, -45.0, 0.0, -135.0, 0.0, 90.0, 45.0]) * d,
        tool_transform=make_transform((0.0, 0.0, PANDA_FLANGE_D)),
    )


def _iiwa14() -> RobotSpec:
    # KUKA LBR iiwa 14 R820: modified DH rows (alpha, a, d, theta_offset) built from KUKA's dimensions
    # (base to shoulder 0.36 m, shoulder to elbow 0.42 m, elbow to wrist 0.40 m, wrist to flange 0.126 m)
    # with KUKA's joint zeros and directions (q = 0: arm straight up); the flange is the last frame.
    d = _DEG
    pi = np.pi
    dh = [(0.0, 0.0, 0.36, 0.0), (-90 * d, 0.0, 0.0, pi), (-90 * d, 0.0, 0.42, pi), (90 * d, 0.0, 0.0, 0.0),
          (-90 * d, 0.0, 0.40, pi), (90 * d, 0.0, 0.0, 0.0), (-90 * d, 0.0, IIWA14_FLANGE_D, pi)]  # fmt: skip
    return RobotSpec.from_dh(
        "iiwa14",
        dh,
        convention="modified",
        joint_names=[f"iiwa_a{i}" for i in range(1, 8)],
        link_names=[f"iiwa_link{i}" for i in range(1, 8)],
        lower=np.array([-170.0, -120.0, -170.0, -120.0, -170.0, -120.0, -175.0]) * d,
        upper=np.array([170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0]) * d,
        velocity_limits=np.array([85.0, 85.0, 100.0, 75.0, 130.0, 135.0, 135.0]) * d,
        effort_limits=[320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0],
        link_masses=[4.0, 4.0, 3.0, 2.7, 1.7, 1.8, 0.3],
        link_radii=[0.09, 0.085, 0.075, 0.075, 0.065, 0.065, 0.045],
        home=np.array([0.0, 35.0, 0.0, -75.0, 0.0, 70.0, 0.0]) * d,
    )


# de Leva (1996) segment mass as a fraction of body mass, (male, female).
_DE_LEVA_MASS = {"upper_arm": (0.0271, 0.0255), "forearm": (0.0162, 0.0138), "hand": (0.0061, 0.0056)}
_COM_UPPER_ARM, _COM_FOREARM, _COM_HAND = 0.577, 0.457, 0.5
_SEGMENT_RADIUS_FRACTION = 0.15


def _human_arm(
    upper_arm_length: float = 0.30,
    forearm_length: float = 0.27,
    hand_length: float = 0.19,
    body_mass: float = 75.0,
    sex: str = "male",
) -> RobotSpec:
    """Right human arm, base frame at the shoulder centre: x forward, y left, z up.

    Joints (the ISB shoulder, Wu et al. 2005, a Y-X-Y sequence of the humerus relative to the
    thorax, whose X, Y, Z are our x, z, -y): plane of elevation about z (0 = the frontal
    plane, 90 deg = forward flexion), elevation about the moved -x (positive raises the arm,
    0 = hanging, 180 deg = straight up), axial rotation about the upper-arm axis (positive =
    internal rotation), elbow flexion about -y of the upper arm (positive bends the forearm
    forwards); all zero = arm hanging straight down. The position limits are a nominal
    range of motion for sampling and the URDF, not a clamp on measured poses. The tool frame
    is the wrist; the hand is rigidly attached to the forearm. Segment masses are de Leva
    fractions of ``body_mass``; centres of mass at 57.7 % (upper arm) and 45.7 % (forearm)
    of the segment from the proximal joint, the hand's at half its length beyond the wrist
    (assumed); inertias are solid cylinders of radius 0.15 x length.
    """
    lengths = {"upper_arm": upper_arm_length, "forearm": forearm_length, "hand": hand_length}
    for key, value in [*((f"{k}_length", v) for k, v in lengths.items()), ("body_mass", body_mass)]:
        if not np.isfinite(value) or value <= 0:
            raise ValueError(f"human_arm option {key} must be a positive number, got {value!r}")
    if sex not in ("male", "female"):
        raise ValueError(f"human_arm option sex must be 'male' or 'female', got {sex!r}")
    mass = {k: body_mass * v[0 if sex == "male" else 1] for k, v in _DE_LEVA_MASS.items()}
    down = np.array([0.0, 0.0, -1.0])

    def segment(key: str, start: float, com_fraction: float) -> tuple[float, np.ndarray, np.ndarray]:
        radius = _SEGMENT_RADIUS_FRACTION * lengths[key]
        com = (start + com_fraction * lengths[key]) * down
        return mass[key], com, cylinder_inertia(mass[key], radius, lengths[key], down)

    upper = segment("upper_arm", 0.0, _COM_UPPER_ARM)
    lower = composite_inertial(
        [segment("forearm", 0.0, _COM_FOREARM), segment("hand", forearm_length, _COM_HAND)]
    )
    zero = (0.0, np.zeros(3), np.zeros((3, 3)))
    inertials = [zero, zero, upper, lower]
    return RobotSpec(
        name="human_arm",
        joint_names=(
            "shoulder_plane_of_elevation",
            "shoulder_elevation",
            "shoulder_axial_rotation",
            "elbow_flexion",
        ),
        link_names=("shoulder_plane_link", "shoulder_elevation_link", "upper_arm", "forearm"),
        joint_xyz=[(0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), upper_arm_length * down],
        joint_rpy=np.zeros((4, 3)),
        joint_axis=[(0.0, 0.0, 1.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), (0.0, -1.0, 0.0)],
        lower=np.array([-100.0, 0.0, -90.0, 0.0]) * _DEG,
        upper=np.array([160.0, 180.0, 90.0, 150.0]) * _DEG,
        continuous=np.zeros(4, bool),
        velocity_limits=[10.0, 10.0, 10.0, 10.0],
        effort_limits=[80.0, 80.0, 50.0, 70.0],
        link_masses=[m for m, _, _ in inertials],
        link_coms=[c for _, c, _ in inertials],
        link_inertias=[i for _, _, i in inertials],
        link_radii=[
            0.05,
            0.05,
            _SEGMENT_RADIUS_FRACTION * upper_arm_length,
            _SEGMENT_RADIUS_FRACTION * forearm_length,
        ],
        base_transform=np.eye(4),
        tool_transform=make_transform(forearm_length * down),
        home=[0.0, 0.0, 0.0, np.pi / 2],
    )


@dataclasses.dataclass(frozen=True)
class CatalogueEntry:
    """One robot of the catalogue: its builder and what the capabilities offer it for.

    Attributes:
        name: the catalogue name (:func:`load_robot`).
        build: returns the :class:`RobotSpec` (robot-specific keyword options).
        retarget: how :mod:`lfd.imitation` turns a person's arm into this robot's joints:
            ``"posture"`` (the arm's link directions, :func:`lfd.human.retarget.retarget_wam4`),
            ``"wrist_path"`` (the tool follows the wrist path by IK,
            :func:`lfd.human.retarget.retarget_wrist_path`); None: not offered by imitation.
        teach: offered by the teach app (:mod:`lfd.teach`).
        closed_form_held_joint: index of the joint held at its current value by the robot's
            closed-form position IK (:mod:`lfd.robots.analytic`); None: no closed form.
    """

    name: str
    build: Callable[..., RobotSpec]
    retarget: str | None = None
    teach: bool = False
    closed_form_held_joint: int | None = None


_ENTRIES: dict[str, CatalogueEntry] = {
    e.name: e
    for e in (
        CatalogueEntry("pr2_right_arm", _pr2_right_arm, retarget="wrist_path", teach=True),
        CatalogueEntry("sawyer", _sawyer, retarget="wrist_path", teach=True),
        CatalogueEntry("wam4", _wam4, retarget="posture", teach=True, closed_form_held_joint=2),
        CatalogueEntry("human_arm", _human_arm),
        CatalogueEntry("panda", _panda, retarget="wrist_path", teach=True),
        CatalogueEntry("iiwa14", _iiwa14, retarget="wrist_path", teach=True),
    )
}
_BUILDERS: dict[str, Callable[..., RobotSpec]] = {name: e.build for name, e in _ENTRIES.items()}


def available_robots() -> tuple[str, ...]:
    """Names accepted by :func:`load_robot`."""
    return tuple(_BUILDERS)


def catalogue_entries() -> tuple[CatalogueEntry, ...]:
    """Every :class:`CatalogueEntry`, in :func:`available_robots` order."""
    return tuple(_ENTRIES.values())


def catalogue_entry(name: str) -> CatalogueEntry:
    """The :class:`CatalogueEntry` of ``name``.

    Raises:
        ValueError: unknown name (the message lists the valid ones).
    """
    if name not in _ENTRIES:
        raise ValueError(f"unknown robot {name!r}; valid names: {', '.join(available_robots())}")
    return _ENTRIES[name]


def load_robot(name: str, *, base_transform: np.ndarray | None = None, **options) -> Robot:
    """Build a catalogue robot.

    Args:
        name: one of :func:`available_robots`.
        base_transform: optional (4, 4) pose of the robot base in the world frame,
            replacing the catalogue default (identity, or 0.316 m up for the Sawyer; for every
            arm but the WAM and the PR2 the world z = 0 plane is the robot's mounting plate).
        **options: robot-specific options; only ``human_arm`` has any
            (``upper_arm_length``, ``forearm_length``, ``hand_length`` in m,
            ``body_mass`` in kg, ``sex`` ``"male"``/``"female"``).

    Raises:
        ValueError: unknown name (the message lists the valid ones) or bad option.
    """
    if name not in _BUILDERS:
        raise ValueError(f"unknown robot {name!r}; valid names: {', '.join(available_robots())}")
    builder = _BUILDERS[name]
    accepted = tuple(inspect.signature(builder).parameters)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(f"robot {name!r} has no option(s) {unknown}; accepted: {list(accepted) or 'none'}")
    spec = builder(**options)
    if base_transform is not None:
        spec = dataclasses.replace(spec, base_transform=np.asarray(base_transform, dtype=float))
    return Robot(spec)
