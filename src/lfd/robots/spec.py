"""Robot description (the *model*): joint chain, limits, inertials, base and tool.

A :class:`RobotSpec` is an immutable, NumPy-only description of a serial arm of
revolute joints, in the same form as a URDF:

* joint ``i`` sits at ``origin_i = Trans(joint_xyz[i]) @ Rot(joint_rpy[i])`` in the
  frame of link ``i - 1`` (link ``-1`` is the base frame) and rotates about the unit
  vector ``joint_axis[i]`` expressed in its own frame;
* link ``i`` (the child of joint ``i``) carries mass ``link_masses[i]`` with centre of
  mass ``link_coms[i]`` and inertia ``link_inertias[i]`` (about the centre of mass),
  both expressed in the frame of link ``i``;
* the tool frame is ``tool_transform`` in the frame of the last link and the base
  frame is ``base_transform`` in the world frame.

The forward kinematics of the tool is therefore::

    T(q) = base_transform @ prod_i (origin_i @ Rot(joint_axis[i], q[i])) @ tool_transform

Denavit-Hartenberg tables (standard or modified) are converted into this form by
:meth:`RobotSpec.from_dh`. All lengths are metres, angles radians, masses kg and
inertias kg m^2.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Literal

import numpy as np

__all__ = [
    "RobotSpec",
    "composite_inertial",
    "cylinder_inertia",
    "dh_transform",
    "frame_with_z_axis",
    "make_transform",
    "matrix_to_rpy",
    "rpy_to_matrix",
    "segment_inertials",
]

DHConvention = Literal["standard", "modified"]


def rpy_to_matrix(rpy: Sequence[float]) -> np.ndarray:
    """URDF roll-pitch-yaw (rad, fixed axes x then y then z) -> rotation ``Rz @ Ry @ Rx`` (3, 3)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(rotation: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) -> URDF roll-pitch-yaw (3,) in rad, inverse of :func:`rpy_to_matrix`.

    At gimbal lock (pitch = +-pi/2) the yaw is set to zero and the roll absorbs it.
    """
    m = np.asarray(rotation, dtype=float)
    pitch = np.arctan2(-m[2, 0], np.hypot(m[0, 0], m[1, 0]))
    if np.hypot(m[0, 0], m[1, 0]) < 1e-12:
        return np.array([np.arctan2(-m[1, 2], m[1, 1]), pitch, 0.0])
    return np.array([np.arctan2(m[2, 1], m[2, 2]), pitch, np.arctan2(m[1, 0], m[0, 0])])


def make_transform(
    xyz: Sequence[float] = (0.0, 0.0, 0.0), rpy: Sequence[float] = (0.0, 0.0, 0.0)
) -> np.ndarray:
    """Homogeneous transform (4, 4) ``Trans(xyz) @ Rot(rpy)`` as in a URDF ``<origin>``."""
    t = np.eye(4)
    t[:3, :3] = rpy_to_matrix(rpy)
    t[:3, 3] = np.asarray(xyz, dtype=float)
    return t


def _rot_x(angle: float) -> np.ndarray:
    return make_transform(rpy=(angle, 0.0, 0.0))


def _rot_z(angle: float) -> np.ndarray:
    return make_transform(rpy=(0.0, 0.0, angle))


def dh_transform(
    alpha: float, a: float, d: float, theta: float, convention: DHConvention = "standard"
) -> np.ndarray:
    """One Denavit-Hartenberg link transform (4, 4).

    ``standard``: ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``;
    ``modified`` (Craig): ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``.
    """
    if convention == "standard":
        return _rot_z(theta) @ make_transform((a, 0.0, d)) @ _rot_x(alpha)
    if convention == "modified":
        return _rot_x(alpha) @ make_transform((a, 0.0, 0.0)) @ _rot_z(theta) @ make_transform((0.0, 0.0, d))
    raise ValueError(f"DH convention must be 'standard' or 'modified', got {convention!r}")


def frame_with_z_axis(axis: Sequence[float]) -> np.ndarray:
    """Rotation (3, 3) whose third column is the unit vector along ``axis``.

    The first column is the x (or, for axes near x, the y) unit vector made
    orthogonal to ``axis``, so signed coordinate axes give exact permutations.
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    helper = np.eye(3)[0] if abs(a[0]) < 0.9 else np.eye(3)[1]
    first = helper - (helper @ a) * a
    first /= np.linalg.norm(first)
    return np.column_stack([first, np.cross(a, first), a])


def cylinder_inertia(mass: float, radius: float, length: float, direction: Sequence[float]) -> np.ndarray:
    """Inertia (3, 3) about the centre of a solid cylinder whose axis is ``direction``.

    Axial moment ``m r^2 / 2``, transverse moments ``m (3 r^2 + l^2) / 12``.
    """
    u = np.asarray(direction, dtype=float)
    u = u / np.linalg.norm(u)
    axial = mass * radius**2 / 2.0
    transverse = mass * (3.0 * radius**2 + length**2) / 12.0
    return transverse * np.eye(3) + (axial - transverse) * np.outer(u, u)


def composite_inertial(
    parts: Sequence[tuple[float, np.ndarray, np.ndarray]],
) -> tuple[float, np.ndarray, np.ndarray]:
    """Combine rigidly joined bodies ``(mass, com (3,), inertia about com (3, 3))``.

    Returns the total ``(mass, com, inertia about the combined com)`` by the
    parallel-axis theorem. A massless set returns a zero com and inertia.
    """
    mass = float(sum(m for m, _, _ in parts))
    if mass == 0.0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    com = sum(m * np.asarray(c, dtype=float) for m, c, _ in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, i in parts:
        r = np.asarray(c, dtype=float) - com
        inertia += np.asarray(i, dtype=float) + m * (r @ r * np.eye(3) - np.outer(r, r))
    return mass, com, inertia


def segment_inertials(
    joint_xyz: np.ndarray,
    joint_axis: np.ndarray,
    tool_xyz: np.ndarray,
    masses: Sequence[float],
    radii: Sequence[float],
    com_fraction: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Plausible link inertials when only link masses are known.

    Link ``i`` is modelled as a solid cylinder of radius ``radii[i]`` along its
    *segment*, the vector from joint ``i`` to joint ``i + 1`` (to the tool point for
    the last link), with its centre of mass at ``com_fraction`` of the segment. The
    cylinder is at least as long as its diameter; links whose segment is shorter
    than 1 mm (two joints at one point) are cylinders along their own joint axis
    centred on the joint.

    Returns ``(coms (n, 3), inertias (n, 3, 3))`` in the link frames.
    """
    segments = np.vstack([np.asarray(joint_xyz, dtype=float)[1:], np.asarray(tool_xyz, dtype=float)[None]])
    coms, inertias = [], []
    for segment, axis, mass, radius in zip(segments, np.asarray(joint_axis, dtype=float), masses, radii):
        length = float(np.linalg.norm(segment))
        direction = segment if length > 1e-3 else axis
        coms.append(com_fraction * segment if length > 1e-3 else np.zeros(3))
        inertias.append(cylinder_inertia(mass, radius, max(length, 2.0 * radius), direction))
    return np.array(coms), np.array(inertias)


def _frozen_array(value, shape: tuple[int, ...], name: str, dtype=float) -> np.ndarray:
    arr = np.array(value, dtype=dtype)
    if arr.shape != shape:
        raise ValueError(f"RobotSpec.{name} must have shape {shape}, got {arr.shape}")
    if dtype is float and not np.all(np.isfinite(arr)):
        raise ValueError(f"RobotSpec.{name} contains NaN or inf")
    arr.flags.writeable = False
    return arr


def _set(spec: RobotSpec, field: str, value) -> None:
    object.__setattr__(spec, field, value)  # frozen dataclass: normalise fields once, at construction


def _check_rigid(transform: np.ndarray, name: str) -> None:
    rot = transform[:3, :3]
    if not (
        np.allclose(rot @ rot.T, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(rot), 1.0, atol=1e-9)
    ):
        raise ValueError(f"RobotSpec.{name} must be a rigid transform (orthonormal rotation, det +1)")
    if not np.allclose(transform[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"RobotSpec.{name} bottom row must be [0, 0, 0, 1]")


@dataclasses.dataclass(frozen=True, eq=False)
class RobotSpec:
    """Immutable description of a serial arm with ``n`` revolute joints (see module docstring).

    Array fields are stored as read-only float64 NumPy arrays; build variants with
    :func:`dataclasses.replace`, which re-validates.

    Attributes:
        name: Robot name.
        joint_names: ``n`` unique joint names, in chain order.
        link_names: ``n`` unique names of the child link of each joint.
        joint_xyz: (n, 3) m, joint origin translation in the parent link frame.
        joint_rpy: (n, 3) rad, joint origin roll-pitch-yaw in the parent link frame.
        joint_axis: (n, 3) unit rotation axis in the joint frame (normalised here).
        lower, upper: (n,) rad, position limits. Continuous joints use them for
            sampling and IK only (typically -pi..pi).
        continuous: (n,) bool, joints without position limits.
        velocity_limits: (n,) rad/s. effort_limits: (n,) N m.
        link_masses: (n,) kg. link_coms: (n, 3) m in the link frame.
        link_inertias: (n, 3, 3) kg m^2 about the centre of mass, link-frame axes.
        link_radii: (n,) m, radius of the primitive shapes used in the URDF.
        base_transform: (4, 4) pose of the base frame in the world frame.
        tool_transform: (4, 4) pose of the tool frame in the last link frame.
        home: (n,) rad, named home pose (within limits).
    """

    name: str
    joint_names: tuple[str, ...]
    link_names: tuple[str, ...]
    joint_xyz: np.ndarray
    joint_rpy: np.ndarray
    joint_axis: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    continuous: np.ndarray
    velocity_limits: np.ndarray
    effort_limits: np.ndarray
    link_masses: np.ndarray
    link_coms: np.ndarray
    link_inertias: np.ndarray
    link_radii: np.ndarray
    base_transform: np.ndarray
    tool_transform: np.ndarray
    home: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        if n == 0:
            raise ValueError("RobotSpec needs at least one joint")
        _set(self, "joint_names", tuple(str(s) for s in self.joint_names))
        _set(self, "link_names", tuple(str(s) for s in self.link_names))
        if len(self.link_names) != n:
            raise ValueError(f"RobotSpec.link_names must have {n} entries, got {len(self.link_names)}")
        reserved = {"base_link", "tool_link", "tool_joint"}
        names = self.joint_names + self.link_names
        if len(set(names)) != len(names) or reserved & set(names):
            raise ValueError(f"RobotSpec joint and link names must be unique and avoid {sorted(reserved)}")
        for field, shape in [
            ("joint_xyz", (n, 3)),
            ("joint_rpy", (n, 3)),
            ("joint_axis", (n, 3)),
            ("lower", (n,)),
            ("upper", (n,)),
            ("velocity_limits", (n,)),
            ("effort_limits", (n,)),
            ("link_masses", (n,)),
            ("link_coms", (n, 3)),
            ("link_inertias", (n, 3, 3)),
            ("link_radii", (n,)),
            ("base_transform", (4, 4)),
            ("tool_transform", (4, 4)),
            ("home", (n,)),
        ]:
            _set(self, field, _frozen_array(getattr(self, field), shape, field))
        _set(self, "continuous", _frozen_array(self.continuous, (n,), "continuous", dtype=bool))

        norms = np.linalg.norm(self.joint_axis, axis=1)
        if np.any(norms < 1e-9):
            raise ValueError("RobotSpec.joint_axis rows must be non-zero")
        _set(self, "joint_axis", _frozen_array(self.joint_axis / norms[:, None], (n, 3), "joint_axis"))
        if np.any(self.lower >= self.upper):
            raise ValueError(
                f"RobotSpec needs lower < upper for every joint, got {self.lower} and {self.upper}"
            )
        if np.any(self.upper - self.lower > 2 * np.pi + 1e-9, where=self.continuous):
            raise ValueError("RobotSpec continuous joints must span at most 2*pi between lower and upper")
        if np.any(self.home < self.lower) or np.any(self.home > self.upper):
            raise ValueError(f"RobotSpec.home {self.home} is outside the limits [{self.lower}, {self.upper}]")
        for field in ("velocity_limits", "effort_limits"):
            if np.any(getattr(self, field) <= 0):
                raise ValueError(f"RobotSpec.{field} must be positive")
        if np.any(self.link_masses < 0) or np.any(self.link_radii <= 0):
            raise ValueError("RobotSpec.link_masses must be >= 0 and link_radii > 0")
        if not np.allclose(self.link_inertias, np.swapaxes(self.link_inertias, 1, 2), atol=1e-12):
            raise ValueError("RobotSpec.link_inertias must be symmetric")
        if np.any(np.linalg.eigvalsh(self.link_inertias) < -1e-12):
            raise ValueError("RobotSpec.link_inertias must be positive semi-definite")
        _check_rigid(self.base_transform, "base_transform")
        _check_rigid(self.tool_transform, "tool_transform")

    @property
    def n_dof(self) -> int:
        """Number of movable joints ``n``."""
        return len(self.joint_names)

    def joint_origin(self, i: int) -> np.ndarray:
        """Homogeneous origin (4, 4) of joint ``i`` in the frame of link ``i - 1`` (the base for i = 0)."""
        return make_transform(self.joint_xyz[i], self.joint_rpy[i])

    @classmethod
    def from_dh(
        cls,
        name: str,
        dh: Sequence[Sequence[float]],
        *,
        joint_names: Sequence[str],
        lower: Sequence[float],
        upper: Sequence[float],
        velocity_limits: Sequence[float],
        effort_limits: Sequence[float],
        link_masses: Sequence[float],
        link_radii: Sequence[float],
        home: Sequence[float],
        convention: DHConvention = "standard",
        link_names: Sequence[str] | None = None,
        continuous: Sequence[bool] | None = None,
        base_transform: np.ndarray | None = None,
        tool_transform: np.ndarray | None = None,
    ) -> RobotSpec:
        """Build a spec from a Denavit-Hartenberg table, joint angle ``theta_i = q_i + offset_i``.

        Args:
            dh: (n, 3) rows ``(alpha, a, d)`` or (n, 4) rows ``(alpha, a, d, theta_offset)``;
                rad and m. ``standard`` rows give ``Rz(theta) Tz(d) Tx(a) Rx(alpha)``;
                ``modified`` rows give ``Rx(alpha) Tx(a) Rz(theta) Tz(d)``.
            tool_transform: (4, 4) tool pose after the last DH frame (default identity).
            base_transform: (4, 4) base pose in the world (default identity).
            Other arguments: see the class attributes. Link inertials come from
            :func:`segment_inertials` (cylinders of ``link_radii`` along each link).

        Each DH row becomes a URDF-style joint about ``z``: with the standard convention
        the joint origin of joint ``i`` is the constant part of row ``i - 1``
        (``Rz(offset) Tz(d) Tx(a) Rx(alpha)``) and the last row joins the tool transform;
        with the modified convention the origin of joint ``i`` is
        ``Rx(alpha) Tx(a) Tz(d) Rz(offset)`` of row ``i``.
        """
        table = np.asarray(dh, dtype=float)
        if table.ndim != 2 or table.shape[1] not in (3, 4):
            raise ValueError(f"dh must have shape (n, 3) or (n, 4), got {table.shape}")
        if table.shape[1] == 3:
            table = np.hstack([table, np.zeros((len(table), 1))])
        n = len(table)
        tool = np.eye(4) if tool_transform is None else np.asarray(tool_transform, dtype=float)
        fixed = [dh_transform(alpha, a, d, offset, convention) for alpha, a, d, offset in table]
        if convention == "standard":
            origins = [np.eye(4)] + fixed[:-1]
            tool = fixed[-1] @ tool
        else:
            origins = fixed
        xyz = np.array([o[:3, 3] for o in origins])
        rpy = np.array([matrix_to_rpy(o[:3, :3]) for o in origins])
        axis = np.tile([0.0, 0.0, 1.0], (n, 1))
        coms, inertias = segment_inertials(xyz, axis, tool[:3, 3], link_masses, link_radii)
        return cls(
            name=name,
            joint_names=tuple(joint_names),
            link_names=tuple(link_names)
            if link_names is not None
            else tuple(f"{j}_link" for j in joint_names),
            joint_xyz=xyz,
            joint_rpy=rpy,
            joint_axis=axis,
            lower=lower,
            upper=upper,
            continuous=np.zeros(n, bool) if continuous is None else continuous,
            velocity_limits=velocity_limits,
            effort_limits=effort_limits,
            link_masses=link_masses,
            link_coms=coms,
            link_inertias=inertias,
            link_radii=link_radii,
            base_transform=np.eye(4) if base_transform is None else base_transform,
            tool_transform=tool,
            home=home,
        )
