r"""Closed-form inverse kinematics of the human arm in the ISB convention (docs/human.md), both sides.

Shoulder angles follow the ISB recommendation (Wu et al. 2005, J. Biomech. 38:981): the
humerus relative to the thorax as a Y-X-Y Euler sequence, *plane of elevation* ``phi``
(about the thorax's vertical axis; 0 = the frontal plane, i.e. abduction, 90 deg = the
sagittal plane in front, i.e. forward flexion, negative = behind the body), *elevation*
``theta`` (0 = arm hanging, 180 deg = straight up; ISB's "negative rotation about the moved
X") and *axial rotation* ``psi`` about the humerus (positive = internal); then elbow
flexion ``q4`` (0 = straight). OpenSim's upper-limb models (``elv_angle``, ``shoulder_elv``,
``shoulder_rot``) use the same sequence.

Model (``load_robot("human_arm")``, right arm, base at the shoulder, trunk frame x forward,
y left, z up, so ISB's thorax X, Y, Z are our x, z, -y):
``R = Rz(phi) Rx(-theta) Rz(psi)``, upper-arm direction ``u = R (0, 0, -1)`` and forearm
direction ``f = R (sin q4, 0, -cos q4)``, i.e.

.. math::

    u = (\sin\theta \sin\varphi,\; -\sin\theta \cos\varphi,\; -\cos\theta)

Solution: ``theta = arccos(-u_z)`` (in ``[0, pi]``, always exact), ``phi = atan2(u_x, -u_y)``,
``q4 = arccos(u . f)`` (in ``[0, pi]``), ``psi = atan2(d_y, d_x)`` with
``d = (Rz(phi) Rx(-theta))^T f = (cos psi sin q4, sin psi sin q4, -cos q4)``.

Singular poses are handled by continuity, never by clamping. Every pose has a second
description ``(phi + pi, -theta, psi + pi)``; frame by frame the one nearest to the previous
frame is kept (the *continuous branch*), so a swing through hanging keeps its plane and the
elevation passes through 0 (through straight up: beyond 180 deg) instead of the plane turning
by 180 deg in one frame. With the arm within ``singular_deg`` of hanging or straight up the
plane is undefined (only ``phi + psi``, resp. ``phi - psi``, is): it is interpolated in time
between the well-defined frames around it (held at the ends; 0 if the arm never leaves the
singular zone), the elevation keeps its exact magnitude (on the neighbours' side of the
singular pose; on a swing through, the side changes once, at the frame nearest to it), and
``psi`` is recomputed from the interpolated plane, which keeps the forearm's orientation.
With a straight elbow ``psi`` is undefined and is interpolated. Those frames are flagged.
``phi`` and ``psi`` are unwrapped over time (no 360 deg jumps) and shifted by whole turns so
that their medians lie in ``(-180, 180]`` deg. By default the result is returned in the ISB
form (:func:`canonical_angles`: elevation in ``[0, 180]`` deg, the plane turning by 180 deg
where the arm passes through hanging); ``canonical=False`` keeps the continuous branch, the
one to fit smooth trajectories and derivatives on (what :func:`lfd.human.analyze_arm` does
before converting the fit, its derivatives and torques to the ISB form).

The left arm is solved as the mirror image (``y -> -y`` in the trunk frame) of a right
arm, so its angles carry the same anatomical meaning on either side.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = [
    "ArmIKResult",
    "arm_fk",
    "arm_frames",
    "arm_ik",
    "canonical_angles",
    "forearm_pronation",
    "mirror",
    "unwrap_finite",
]

_MIRROR = np.array([1.0, -1.0, 1.0])


def mirror(points: np.ndarray, side: str) -> np.ndarray:
    """Map trunk-frame points of ``side`` onto the right-arm model (identity for the right)."""
    if side == "right":
        return points
    if side == "left":
        return points * _MIRROR
    raise ValueError(f"side must be 'left' or 'right', got {side!r}")


def _rz(a: np.ndarray) -> np.ndarray:
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([c, -s, z, s, c, z, z, z, o], -1).reshape(*np.shape(a), 3, 3)


def _rx(a: np.ndarray) -> np.ndarray:
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([o, z, z, z, c, -s, z, s, c], -1).reshape(*np.shape(a), 3, 3)


def arm_frames(q: np.ndarray) -> np.ndarray:
    """(T, 3, 3) orientation of the upper arm (humerus) in the trunk frame, ``Rz(phi) Rx(-theta) Rz(psi)``."""
    q = np.asarray(q, dtype=float)
    return _rz(q[:, 0]) @ _rx(-q[:, 1]) @ _rz(q[:, 2])


def arm_fk(q: np.ndarray, upper_arm_length: float, forearm_length: float) -> tuple[np.ndarray, np.ndarray]:
    """Elbow and wrist positions ``(T, 3)`` each, m, of the right-arm model (shoulder at 0) at ``q (T, 4)`` rad."""
    q = np.asarray(q, dtype=float)
    r = arm_frames(q)
    local = np.stack([np.sin(q[:, 3]), np.zeros(len(q)), -np.cos(q[:, 3])], -1)
    elbow = -upper_arm_length * r[:, :, 2]
    return elbow, elbow + forearm_length * np.einsum("tij,tj->ti", r, local)


def unwrap_finite(a: np.ndarray) -> np.ndarray:
    """Unwrap an angle series (rad) over its finite samples (NaN kept), then shift it by whole turns
    so that its median lies in ``(-pi, pi]``."""
    out = np.array(a, dtype=float)
    ok = np.isfinite(out)
    if ok.any():
        out[ok] = np.unwrap(out[ok])
        out[ok] -= 2 * np.pi * np.round((np.median(out[ok]) - 1e-12) / (2 * np.pi))
    return out


def _interpolate_over(values: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Fill ``values[bad]`` by linear interpolation over frame index from the finite values of the other
    frames (held at the ends; 0 when there are none)."""
    good = ~bad & np.isfinite(values)
    if not good.any():
        return np.where(bad, 0.0, values)
    idx = np.arange(len(values))
    return np.where(bad, np.interp(idx, idx[good], values[good]), values)


@dataclasses.dataclass
class ArmIKResult:
    """Joint angles and per-frame flags of :func:`arm_ik`.

    Attributes:
        q: (T, 4) rad (plane of elevation, elevation, axial rotation, elbow flexion); NaN where
            the input is. Elevation in ``[0, pi]``, elbow flexion in ``[0, pi]``; plane and
            rotation unwrapped (continuous, may leave ``(-pi, pi]``).
        shoulder_singular: (T,) bool, arm (nearly) hanging or straight up, plane interpolated.
        elbow_singular: (T,) bool, elbow (nearly) straight, axial rotation interpolated.
    """

    q: np.ndarray
    shoulder_singular: np.ndarray
    elbow_singular: np.ndarray


def segment_directions(shoulder, elbow, wrist, side: str) -> tuple[np.ndarray, np.ndarray]:
    """Unit upper-arm and forearm directions ``(T, 3)`` of shoulder, elbow and wrist points ``(T, 3)``
    (trunk frame), a left arm mirrored into a right one (:func:`mirror`); NaN where a point is missing.

    Raises:
        ValueError: a shape other than ``(T, 3)``, or the three of different lengths.
    """
    for name, x in (("shoulder", shoulder), ("elbow", elbow), ("wrist", wrist)):
        if np.ndim(x) != 2 or np.shape(x)[1] != 3:
            raise ValueError(f"{name} must have shape (T, 3), got {np.shape(x)}")
    s, e, w = (mirror(np.asarray(x, dtype=float), side) for x in (shoulder, elbow, wrist))
    if not (s.shape == e.shape == w.shape):
        raise ValueError(
            f"shoulder, elbow and wrist must have the same shape, got {s.shape}, {e.shape}, {w.shape}"
        )
    upper, fore = e - s, w - e
    with np.errstate(invalid="ignore", divide="ignore"):
        return (
            upper / np.linalg.norm(upper, axis=1, keepdims=True),
            fore / np.linalg.norm(fore, axis=1, keepdims=True),
        )


def arm_ik(
    shoulder: np.ndarray,
    elbow: np.ndarray,
    wrist: np.ndarray,
    side: str = "right",
    *,
    singular_deg: float = 10.0,
    canonical: bool = True,
) -> ArmIKResult:
    """ISB joint angles of one arm from shoulder, elbow and wrist positions in the trunk frame.

    Args:
        shoulder, elbow, wrist: (T, 3) m in the trunk frame (x forward, y left, z up), in time order.
        side: ``"right"`` or ``"left"`` (solved as the mirror image, see module docstring).
        singular_deg: a frame is singular when the upper arm is within this angle of hanging or
            straight up (plane of elevation undefined) or the elbow within it of straight
            (axial rotation undefined).
        canonical: return the ISB form (elevation in ``[0, pi]``); ``False`` keeps the
            continuous branch (elevation may leave ``[0, pi]`` where the arm swings through
            hanging or straight up, see :func:`canonical_angles`), which is what a smooth fit needs.

    Returns:
        :class:`ArmIKResult`. With exact non-singular input ``arm_fk(q)`` reproduces the elbow
        and wrist directions exactly; the elevation and the elbow flexion are exact in every frame.

    Raises:
        ValueError: a point array not of shape (T, 3), shapes that differ, a bad side or
        singular_deg outside (0, 45).

    Example::

        >>> import numpy as np
        >>> from lfd.human.arm_ik import arm_fk, arm_ik
        >>> q = np.array([[0.3, 2.4, 0.2, 1.0]])  # arm raised 137 deg, 17 deg in front of the frontal plane
        >>> e, w = arm_fk(q, 0.3, 0.25)
        >>> np.allclose(arm_ik(np.zeros((1, 3)), e, w).q, q)
        True
    """
    if not (isinstance(singular_deg, (int, float)) and 0 < singular_deg < 45):
        raise ValueError(f"singular_deg must be a number of degrees in (0, 45), got {singular_deg!r}")
    u, f = segment_directions(shoulder, elbow, wrist, side)
    eps = np.sin(np.deg2rad(singular_deg))
    elbow_flexion = np.arccos(np.clip((u * f).sum(1), -1.0, 1.0))
    elevation = np.arccos(np.clip(-u[:, 2], -1.0, 1.0))
    shoulder_singular = np.hypot(u[:, 0], u[:, 1]) < eps  # sin(elevation) small
    elbow_singular = np.sin(elbow_flexion) < eps
    good = ~shoulder_singular & np.isfinite(elevation)
    plane = np.where(good, np.arctan2(u[:, 0], -u[:, 1]), np.nan)
    rotation = np.where(good & ~elbow_singular, _rotation(plane, elevation, f), np.nan)
    flip = _continuous_branch(plane, elevation, rotation, good)
    plane = unwrap_finite(np.where(flip, plane + np.pi, plane))
    plane = _interpolate_over(plane, shoulder_singular & np.isfinite(elevation))
    elevation = _continuous_elevation(np.where(flip, -elevation, elevation), good, shoulder_singular)
    rotation = np.where(elbow_singular, np.nan, _rotation(plane, elevation, f))
    rotation = _interpolate_over(unwrap_finite(rotation), elbow_singular & np.isfinite(elbow_flexion))
    q = np.stack([plane, elevation, rotation, elbow_flexion], -1)
    q[~np.isfinite(q).all(1)] = np.nan
    if canonical:
        q = canonical_angles(q)[0]
    return ArmIKResult(q, shoulder_singular, elbow_singular)


def _rotation(plane: np.ndarray, elevation: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Axial rotation (T,) rad of the forearm direction ``f`` in the upper-arm frame at ``(plane, elevation)``."""
    d = np.einsum("tji,tj->ti", _rz(plane) @ _rx(-elevation), f)  # R^T f
    return np.arctan2(d[:, 1], d[:, 0])


def _continuous_branch(
    plane: np.ndarray, elevation: np.ndarray, rotation: np.ndarray, good: np.ndarray
) -> np.ndarray:
    """(T,) bool: use the other representation ``(phi + pi, -theta, psi + pi)`` of the same pose in this
    frame, chosen frame by frame (over the ``good`` frames in time order) as the one nearest to the
    previous choice, so that a swing through the singular poses keeps its plane and reverses the
    elevation instead of turning the plane by 180 deg."""
    flip = np.zeros(len(plane), bool)
    prev = None
    for t in np.flatnonzero(good).tolist():
        a = (plane[t], elevation[t], rotation[t])
        if prev is not None:
            b = (a[0] + np.pi, -a[1], a[2] + np.pi)
            cost = [
                sum(abs(_wrap(x - y)) for x, y in zip(c, prev) if np.isfinite(x) and np.isfinite(y))
                for c in (a, b)
            ]
            if cost[1] < cost[0]:
                flip[t], a = True, b
        prev = (a[0], a[1], a[2] if np.isfinite(a[2]) or prev is None else prev[2])
    return flip


def _continuous_elevation(elevation: np.ndarray, good: np.ndarray, singular: np.ndarray) -> np.ndarray:
    """Elevation (T,) on the continuous branch: unwrapped over the ``good`` frames; in each run of
    singular frames its magnitude is kept exact and its side of the singular pose (below/above 0, or
    180 deg) is the neighbours'; where they differ (a swing through) the side changes once, at the
    frame closest to the singular pose."""
    out = np.array(elevation, dtype=float)
    out[good] = unwrap_finite(out[good])
    magnitude = np.abs(_wrap(elevation))  # in [0, pi]
    zones = singular & np.isfinite(elevation)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], zones.astype(np.int8), [0]])))
    for start, stop in zip(edges[::2].tolist(), edges[1::2].tolist()):
        left, right = np.flatnonzero(good[:start]), np.flatnonzero(good[stop:])
        ends = [out[left[-1]]] if len(left) else []
        ends += [out[stop + right[0]]] if len(right) else []
        parity = int(np.mean(magnitude[start:stop]) > np.pi / 2)  # 0: near hanging, 1: near straight up
        k = parity + 2 * int(np.round((ends[0] / np.pi - parity) / 2)) if ends else parity
        sides = [1.0 if v - k * np.pi >= 0 else -1.0 for v in ends] or [1.0]
        distance = magnitude[start:stop] if k % 2 == 0 else np.pi - magnitude[start:stop]
        side = np.full(stop - start, sides[0])
        if sides[-1] != sides[0]:
            side[int(np.argmin(distance)) + 1 :] = sides[-1]
        out[start:stop] = k * np.pi + side * distance
    return out


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def canonical_angles(
    q: np.ndarray, qd: np.ndarray | None = None, qdd: np.ndarray | None = None, tau: np.ndarray | None = None
) -> tuple[np.ndarray, ...]:
    """The ISB form (elevation in ``[0, pi]``) of continuous-branch angles, with their derivatives and torques.

    Where the elevation ``theta`` (taken modulo 2 pi) is negative, the pose is the same as
    ``(phi + pi, -theta, psi + pi)``; there the elevation velocity, acceleration and torque
    change sign (the elevation axis is reversed) and the others stay. ``phi`` and ``psi``
    are then unwrapped over time (:func:`unwrap_finite`).

    Args:
        q: (T, 4) rad. qd, qdd, tau: (T, 4) or None.

    Returns:
        ``(q, qd, qdd, tau)`` converted (None stays None).
    """
    q = np.array(q, dtype=float)
    theta = _wrap(q[:, 1])
    flip = theta < 0
    q[:, 1] = np.abs(theta)
    for j in (0, 2):
        q[:, j] = unwrap_finite(np.where(flip, q[:, j] + np.pi, q[:, j]))
    out = [q]
    for x in (qd, qdd, tau):
        if x is not None:
            x = np.array(x, dtype=float)
            x[:, 1] = np.where(flip, -x[:, 1], x[:, 1])
        out.append(x)
    return tuple(out)


def forearm_pronation(
    shoulder: np.ndarray,
    elbow: np.ndarray,
    wrist: np.ndarray,
    thumb: np.ndarray,
    side: str = "right",
    *,
    singular_deg: float = 10.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Forearm pronation (T,) rad from a thumb (radial-side) point, and the frames where it is interpolated.

    The angle is that of the wrist -> thumb direction about the forearm axis, measured from the
    upper arm's side of the elbow's flexion plane (the component of the elbow -> shoulder
    direction perpendicular to the forearm): 0 = mid-position (thumb towards the shoulder side,
    e.g. thumb up with the arm hanging and the elbow bent 90 deg), positive = pronation (thumb
    turning medially, palm down), negative = supination; ISB's anatomical position (palm
    forward) is about -90 deg on this scale. With the elbow within ``singular_deg`` of straight
    the reference is undefined: those frames are interpolated in time (held at the ends) and
    flagged. The series is unwrapped (:func:`unwrap_finite`).

    Args:
        shoulder, elbow, wrist, thumb: (T, 3) m in the trunk frame (x forward, y left, z up).
        side: ``"right"`` or ``"left"`` (mirror image, the same anatomical sign).

    Returns:
        ``(pronation (T,) rad, interpolated (T,) bool)``; NaN where a point is missing.

    Raises:
        ValueError: a point array not of shape (T, 3) or shapes that differ; a bad side.
    """
    pts = []
    for name, x in (("shoulder", shoulder), ("elbow", elbow), ("wrist", wrist), ("thumb", thumb)):
        if np.ndim(x) != 2 or np.shape(x)[1] != 3:
            raise ValueError(f"{name} must have shape (T, 3), got {np.shape(x)}")
        pts.append(mirror(np.asarray(x, dtype=float), side))
    if len({p.shape for p in pts}) != 1:
        raise ValueError(
            f"shoulder, elbow, wrist and thumb must have the same shape, got {[p.shape for p in pts]}"
        )
    s, e, w, th = pts
    with np.errstate(invalid="ignore", divide="ignore"):
        u = (e - s) / np.linalg.norm(e - s, axis=1, keepdims=True)
        f = (w - e) / np.linalg.norm(w - e, axis=1, keepdims=True)
        up = -u - (-u * f).sum(1, keepdims=True) * f  # the shoulder side, perpendicular to the forearm
        straight = np.linalg.norm(up, axis=1) < np.sin(np.deg2rad(singular_deg))
        up = up / np.linalg.norm(up, axis=1, keepdims=True)
    medial = np.cross(up, f)  # right arm: towards +y (medial) when up = z, f = x
    t = th - w
    angle = np.where(straight, np.nan, np.arctan2((t * medial).sum(1), (t * up).sum(1)))
    valid = np.isfinite(t).all(1) & np.isfinite(u).all(1) & np.isfinite(f).all(1)
    angle = _interpolate_over(unwrap_finite(angle), straight & valid)
    return np.where(valid, angle, np.nan), straight & valid
