"""URDF writer for a :class:`~lfd.robots.spec.RobotSpec`.

Layout (the contract with the simulator):

* ``base_link``: the world frame of the spec (massless); the spec's base transform is
  folded into the origin of the first joint, and a cylinder from the origin to the
  first joint stands for the pedestal when they are apart;
* one link per movable joint, named ``spec.link_names[i]``, child of joint
  ``spec.joint_names[i]`` (``revolute`` with limits, or ``continuous``), with the
  spec's inertial (written in its principal axes) and, as visual and collision
  shapes, a sphere of radius ``link_radii[i]`` at the joint plus a cylinder along the
  link to the next joint (or tool point);
* ``tool_joint`` (fixed) and the massless ``tool_link`` at the tool transform.

In PyBullet the joint indices ``0..n-1`` are therefore the movable joints in chain
order and index ``n`` is the tool joint. Joint damping and friction are zero so the
dynamics match :meth:`lfd.robots.Robot.inverse_dynamics`.
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np

from .spec import RobotSpec, frame_with_z_axis, matrix_to_rpy

__all__ = ["spec_to_urdf"]

_MIN_SHAPE_LENGTH = 1e-3  # m; shorter link segments get no cylinder


def _num(values) -> str:
    return " ".join(format(float(v), ".17g") for v in np.atleast_1d(values))


def _origin(transform: np.ndarray) -> str:
    return f'<origin xyz="{_num(transform[:3, 3])}" rpy="{_num(matrix_to_rpy(transform[:3, :3]))}"/>'


def _inertial(mass: float, com: np.ndarray, inertia: np.ndarray) -> str:
    """``<inertial>`` with the inertia in its principal axes (a diagonal tensor)."""
    frame = np.eye(4)
    frame[:3, 3] = com
    if np.count_nonzero(inertia - np.diag(np.diag(inertia))) == 0:
        moments = np.diag(inertia)
    else:
        moments, axes = np.linalg.eigh(inertia)
        axes[:, 2] *= np.sign(np.linalg.det(axes))
        frame[:3, :3] = axes
    ixx, iyy, izz = (max(float(m), 0.0) for m in moments)
    return (
        f'    <inertial>\n      {_origin(frame)}\n      <mass value="{_num(mass)}"/>\n'
        f'      <inertia ixx="{_num(ixx)}" ixy="0" ixz="0" iyy="{_num(iyy)}" iyz="0" izz="{_num(izz)}"/>\n'
        "    </inertial>"
    )


def _shapes(segment: np.ndarray, radius: float, with_sphere: bool) -> list[str]:
    """Visual + collision geometry: a sphere at the link origin and a cylinder along ``segment``."""
    geometries = []
    if with_sphere:
        geometries.append((np.eye(4), f'<sphere radius="{_num(radius)}"/>'))
    length = float(np.linalg.norm(segment))
    if length > _MIN_SHAPE_LENGTH:
        frame = np.eye(4)
        frame[:3, :3] = frame_with_z_axis(segment)
        frame[:3, 3] = segment / 2.0
        geometries.append((frame, f'<cylinder radius="{_num(radius)}" length="{_num(length)}"/>'))
    out = []
    for frame, geometry in geometries:
        body = f"      {_origin(frame)}\n      <geometry>{geometry}</geometry>\n"
        out.append(f'    <visual>\n{body}      <material name="lfd_grey"/>\n    </visual>')
        out.append(f"    <collision>\n{body}    </collision>")
    return out


def _link(name: str, inertial: str, shapes: list[str]) -> str:
    return "\n".join([f"  <link name={quoteattr(name)}>", inertial, *shapes, "  </link>"])


def spec_to_urdf(spec: RobotSpec) -> str:
    """URDF text (see module docstring) for ``spec``; numbers written with 17 digits."""
    n = spec.n_dof
    first_origin = spec.base_transform @ spec.joint_origin(0)
    origins = [first_origin] + [spec.joint_origin(i) for i in range(1, n)]
    segments = np.vstack([spec.joint_xyz[1:], spec.tool_transform[None, :3, 3]])
    zero_inertial = _inertial(0.0, np.zeros(3), np.zeros((3, 3)))
    parts = [
        '<?xml version="1.0"?>',
        f"<robot name={quoteattr(spec.name)}>",
        '  <material name="lfd_grey"><color rgba="0.6 0.6 0.65 1"/></material>',
        _link(
            "base_link", zero_inertial, _shapes(first_origin[:3, 3], spec.link_radii[0], with_sphere=False)
        ),
    ]
    for i in range(n):
        parent = "base_link" if i == 0 else spec.link_names[i - 1]
        kind = "continuous" if spec.continuous[i] else "revolute"
        limits = "" if spec.continuous[i] else f'lower="{_num(spec.lower[i])}" upper="{_num(spec.upper[i])}" '
        parts.append(
            f'  <joint name={quoteattr(spec.joint_names[i])} type="{kind}">\n'
            f"    <parent link={quoteattr(parent)}/>\n    <child link={quoteattr(spec.link_names[i])}/>\n"
            f'    {_origin(origins[i])}\n    <axis xyz="{_num(spec.joint_axis[i])}"/>\n'
            f'    <limit {limits}effort="{_num(spec.effort_limits[i])}" velocity="{_num(spec.velocity_limits[i])}"/>\n'
            '    <dynamics damping="0" friction="0"/>\n  </joint>'
        )
        inertial = _inertial(spec.link_masses[i], spec.link_coms[i], spec.link_inertias[i])
        parts.append(
            _link(spec.link_names[i], inertial, _shapes(segments[i], spec.link_radii[i], with_sphere=True))
        )
    parts += [
        f'  <joint name="tool_joint" type="fixed">\n    <parent link={quoteattr(spec.link_names[-1])}/>\n'
        f'    <child link="tool_link"/>\n    {_origin(spec.tool_transform)}\n  </joint>',
        _link("tool_link", zero_inertial, []),
        "</robot>",
        "",
    ]
    return "\n".join(parts)
