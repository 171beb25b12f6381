r"""The thesis's shoulder angles (abduction, flexion, rotation), a derived output (docs/human.md).

The thesis (and lfd before the ISB model of :mod:`lfd.human.arm_ik`) described the right arm
by ``R_12 = Rx(-q1) Ry(q2)`` (abduction about -x, then flexion about the moved y), rotation
``q3`` about the upper-arm axis and elbow flexion ``q4`` about -y of the upper arm, in the
trunk frame (x forward, y left, z up; all zero = arm hanging). With ``L1``, ``L2`` the
upper-arm and forearm lengths

.. math::

    e = L_1\,u,\quad u = R_{12}\,(0, 0, -1) = (-\sin q_2,\; -\cos q_2 \sin q_1,\; -\cos q_2 \cos q_1)

    w - e = L_2\,f,\quad f = R_{12} R_z(q_3)\,(\sin q_4,\; 0,\; -\cos q_4)

These angles are kept so results stay comparable with the thesis, with their caveat: the
sequence has a gimbal lock where the upper arm points along the x axis (straight forward or
backward at 90 deg of flexion), where abduction and rotation are not separable, and two
branches (``cos q2 > 0`` or ``< 0``) describe every pose. Near the lock the values change
fast and the branch choice decides whether an arm raised forward above the shoulder reads
as "flexion -130" or "abduction 180, flexion -50". Prefer the ISB angles for analysis.

Solution: ``q4 = arccos(u . f)``; ``q2 = arcsin(-u_x)``, ``q1 = atan2(-u_y, -u_z)``
(branch A) or ``q2 = pi - arcsin(-u_x)``, ``q1 = atan2(u_y, u_z)`` (branch B, rotation
``+ pi``); ``q3 = atan2(d_y, d_x)`` with ``d = R_12^T f``. Singular frames (straight elbow:
rotation undefined; gimbal lock: abduction undefined) are flagged and the undefined angle
is interpolated in time. The branch sequence minimises the distance to the thesis's range
(``THESIS_RANGE``: abduction -90..90, flexion -130..45, rotation -90..90, elbow 0..150 deg)
plus the frame-to-frame change (a two-state Viterbi recursion). Nothing is clamped: poses
outside that range (the arm raised sideways above the shoulder, abduction > 90) keep their
values and are flagged in ``outside_range``.

The left arm is solved as the mirror image (``y -> -y`` in the trunk frame) of a right arm.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .arm_ik import segment_directions

__all__ = ["THESIS_RANGE", "ThesisAngles", "thesis_fk", "thesis_ik"]

# (abduction, flexion, rotation, elbow flexion) range of the thesis model, rad (not a clamp).
THESIS_RANGE = np.deg2rad(np.array([[-90.0, -130.0, -90.0, 0.0], [90.0, 45.0, 90.0, 150.0]]))


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def _r12(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """(T, 3, 3) ``Rx(-q1) @ Ry(q2)``."""
    c1, s1, c2, s2 = np.cos(q1), np.sin(q1), np.cos(q2), np.sin(q2)
    zero = np.zeros_like(q1)
    rx = np.stack([np.ones_like(q1), zero, zero, zero, c1, s1, zero, -s1, c1], -1).reshape(-1, 3, 3)
    ry = np.stack([c2, zero, s2, zero, np.ones_like(q1), zero, -s2, zero, c2], -1).reshape(-1, 3, 3)
    return rx @ ry


def thesis_fk(q: np.ndarray, upper_arm_length: float, forearm_length: float) -> tuple[np.ndarray, np.ndarray]:
    """Elbow and wrist positions ``(T, 3)`` each, m, of the thesis's right-arm model at ``q (T, 4)`` rad."""
    q = np.asarray(q, dtype=float)
    r12 = _r12(q[:, 0], q[:, 1])
    u = -r12[:, :, 2]
    c3, s3, c4, s4 = np.cos(q[:, 2]), np.sin(q[:, 2]), np.cos(q[:, 3]), np.sin(q[:, 3])
    d = np.stack([c3 * s4, s3 * s4, -c4], -1)
    f = np.einsum("tij,tj->ti", r12, d)
    elbow = upper_arm_length * u
    return elbow, elbow + forearm_length * f


@dataclasses.dataclass
class ThesisAngles:
    """Angles of :func:`thesis_ik` and per-frame flags.

    Attributes:
        q: (T, 4) rad (abduction, flexion, rotation, elbow flexion); NaN where the input is.
        elbow_singular: (T,) bool, arm (nearly) straight, rotation interpolated.
        gimbal_lock: (T,) bool, upper arm (nearly) along the x axis, abduction interpolated.
        outside_range: (T,) bool, some angle lies outside ``THESIS_RANGE`` (kept, not clamped).
        branch: (T,) int8, 0 = branch A (cos q2 > 0), 1 = branch B.
    """

    q: np.ndarray
    elbow_singular: np.ndarray
    gimbal_lock: np.ndarray
    outside_range: np.ndarray
    branch: np.ndarray


def _interpolate_over(values: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Replace ``values[bad]`` by linear interpolation over frame index from good finite frames."""
    good = ~bad & np.isfinite(values)
    if not good.any():
        return np.where(np.isfinite(values), 0.0, np.nan)
    idx = np.arange(len(values))
    filled = np.interp(idx, idx[good], values[good])
    return np.where(bad & np.isfinite(values), filled, values)


def _violation(q: np.ndarray, ignore: np.ndarray | None = None) -> np.ndarray:
    v = np.maximum(THESIS_RANGE[0] - q, 0) + np.maximum(q - THESIS_RANGE[1], 0)
    if ignore is not None:
        v = np.where(ignore, 0.0, v)
    return v.sum(-1)


def _angle_step(a: np.ndarray, b: np.ndarray, ignore: np.ndarray) -> np.ndarray:
    """Sum over joints of the wrapped angle change from ``a`` (frame t-1) to ``b`` (frame t), (T-1,)."""
    d = np.abs(_wrap(b - a))
    return np.where(ignore | ~np.isfinite(d), 0.0, d).sum(-1)


def _choose_branch(qa: np.ndarray, qb: np.ndarray, cost_a: np.ndarray, cost_b: np.ndarray,
                   ignore: np.ndarray, weight: float) -> np.ndarray:  # fmt: skip
    """Branch per frame minimising ``sum_t violation(q_t) + weight * sum_t |q_t - q_{t-1}|`` (Viterbi).

    Two states (branch A, B); the transition costs are the angle changes between consecutive
    frames on either branch, so a switch is taken only where it is cheap (where the branches
    meet, near the gimbal lock) or where staying would violate the limits by more than the jump.
    The recursion over time is sequential (a scalar loop); everything else is vectorised.
    """
    n = len(qa)
    if n == 0:
        return np.zeros(0, np.int8)
    skip = ignore[1:] | ignore[:-1]
    trans = weight * np.stack([
        np.stack([_angle_step(qa[:-1], qa[1:], skip), _angle_step(qa[:-1], qb[1:], skip)], -1),
        np.stack([_angle_step(qb[:-1], qa[1:], skip), _angle_step(qb[:-1], qb[1:], skip)], -1),
    ], 1)  # (T-1, from, to)  # fmt: skip
    unary = np.nan_to_num(np.stack([cost_a, cost_b], -1), nan=0.0)
    back = np.zeros((n, 2), np.int8)
    total = unary[0].copy()
    trans_list, unary_list = trans.tolist(), unary.tolist()
    ca, cb = float(total[0]), float(total[1])
    for t in range(1, n):
        (aa, ab), (ba, bb) = trans_list[t - 1]
        ua, ub = unary_list[t]
        from_a_to_a, from_b_to_a = ca + aa, cb + ba
        from_a_to_b, from_b_to_b = ca + ab, cb + bb
        back[t, 0] = 0 if from_a_to_a <= from_b_to_a else 1
        back[t, 1] = 0 if from_a_to_b <= from_b_to_b else 1
        ca, cb = min(from_a_to_a, from_b_to_a) + ua, min(from_a_to_b, from_b_to_b) + ub
    branch = np.zeros(n, np.int8)
    branch[-1] = 0 if ca <= cb else 1
    for t in range(n - 1, 0, -1):
        branch[t - 1] = back[t, branch[t]]
    return branch


def thesis_ik(
    shoulder: np.ndarray,
    elbow: np.ndarray,
    wrist: np.ndarray,
    side: str = "right",
    *,
    singular_deg: float = 10.0,
    continuity: float = 1.0,
) -> ThesisAngles:
    """The thesis's angles of one arm from shoulder, elbow and wrist positions in the trunk frame.

    Args:
        shoulder, elbow, wrist: (T, 3) m in the trunk frame (x forward, y left, z up).
        side: ``"right"`` or ``"left"`` (solved as the mirror image, see module docstring).
        singular_deg: a frame is singular when the elbow is within this angle of straight
            (rotation undefined) or the upper arm within it of the x axis (abduction undefined).
        continuity: weight of the frame-to-frame angle change against the limit violation
            (both in rad) when the branch sequence is chosen; 0 picks the least-violating
            branch in every frame independently (for unordered samples).

    Returns:
        :class:`ThesisAngles`. With exact, non-singular input, ``thesis_fk(q)`` reproduces
        the elbow and wrist directions exactly.

    Raises:
        ValueError: a point array not of shape (T, 3), shapes that differ, a bad side or continuity.

    Example::

        >>> import numpy as np
        >>> from lfd.human.thesis_angles import thesis_fk, thesis_ik
        >>> q = np.array([[0.3, -0.5, 0.2, 1.0]])
        >>> e, w = thesis_fk(q, 0.3, 0.25)
        >>> np.allclose(thesis_ik(np.zeros((1, 3)), e, w).q, q)
        True
    """
    u, f = segment_directions(shoulder, elbow, wrist, side)
    eps = np.sin(np.deg2rad(singular_deg))
    q4 = np.arccos(np.clip((u * f).sum(1), -1.0, 1.0))
    elbow_singular = np.sin(q4) < eps
    shoulder_singular = np.hypot(u[:, 1], u[:, 2]) < eps  # |cos q2| small

    def solve(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
        d = np.einsum("tji,tj->ti", _r12(q1, q2), f)  # R12^T f
        return np.arctan2(d[:, 1], d[:, 0])

    q2a = np.arcsin(np.clip(-u[:, 0], -1.0, 1.0))
    q1a = np.arctan2(-u[:, 1], -u[:, 2])
    q1b, q2b = _wrap(q1a + np.pi), _wrap(np.pi - q2a)
    qa = np.stack([q1a, q2a, solve(q1a, q2a), q4], -1)
    qb = np.stack([q1b, q2b, solve(q1b, q2b), q4], -1)
    ignore = np.zeros((len(u), 4), bool)
    ignore[:, 2] = elbow_singular
    ignore[:, 0] = shoulder_singular
    if not (np.isfinite(continuity) and continuity >= 0):
        raise ValueError(f"continuity must be a non-negative weight, got {continuity!r}")
    branch = _choose_branch(qa, qb, _violation(qa, ignore), _violation(qb, ignore), ignore, continuity)
    q = np.where(branch[:, None] == 1, qb, qa)

    if shoulder_singular.any():
        q1 = _interpolate_over(q[:, 0], shoulder_singular)
        q2 = np.arctan2(-u[:, 0], -(u[:, 1] * np.sin(q1) + u[:, 2] * np.cos(q1)))
        q[:, 0], q[:, 1], q[:, 2] = q1, q2, solve(q1, q2)
    if elbow_singular.any():
        q[:, 2] = _interpolate_over(q[:, 2], elbow_singular)
    branch = np.where(np.isfinite(q[:, 1]), np.cos(q[:, 1]) < 0, branch).astype(
        np.int8
    )  # after the interpolation
    outside = ((q < THESIS_RANGE[0] - 1e-9) | (q > THESIS_RANGE[1] + 1e-9)).any(1)
    return ThesisAngles(q, elbow_singular, shoulder_singular, outside, branch)
