"""Coupling terms: accelerations added to a discrete DMP's transformation system.

A coupling term is any callable ``term(y, yd) -> a`` with ``y``, ``yd`` of shape ``(D,)`` or
``(B, D)`` (positions in the DMP's units, velocities in units/s) returning an acceleration
``a`` of the same shape in units/s^2. It enters the DMP as
``tau^2 d2y/dt2 = alpha_z (beta_z (g - y) - tau dy/dt) + F(s) + tau^2 a``. Terms are used by
:meth:`lfd.dmp.DMP.rollout` / :func:`lfd.dmp.rollout_batch` (``coupling=[...]``: integrated
step-wise, vectorised over the batch) and by :class:`lfd.dmp.DMPRunner` /
:meth:`lfd.dmp.DMP.step` (online; obstacles may move between steps: assign ``points``).

- :class:`ObstacleAvoidance`: point obstacles in the DMP's own space (task space for a
  Cartesian DMP, joint space for a joint DMP), either Park et al. 2008's dynamic potential
  (any dimension, default) or Hoffmann et al. 2009's steering angle (2-D or 3-D).
- :class:`JointLimits`: a repulsion near ``lower``/``upper`` plus a hard stop (a term may
  define ``project(y, yd) -> (y, yd)``, applied after every integration sub-step).

References: D.-H. Park, H. Hoffmann, P. Pastor, S. Schaal, "Movement reproduction and
obstacle avoidance with dynamic movement primitives and potential fields", Humanoids 2008;
H. Hoffmann, P. Pastor, D.-H. Park, S. Schaal, "Biologically-inspired dynamical systems for
movement generation: automatic real-time goal adaptation and obstacle avoidance", ICRA 2009.
"""

from __future__ import annotations

import numpy as np

from lfd import checks

__all__ = ["JointLimits", "ObstacleAvoidance"]

#: Speeds below this (units/s) count as standing still: no obstacle coupling.
_MIN_SPEED = 1e-12


class ObstacleAvoidance:
    """Point obstacles repel a moving DMP.

    ``kind="park"`` (Park et al. 2008, any dimension): the dynamic potential
    ``U = lam (-cos theta)^beta |v| / p`` for ``cos theta < 0`` (moving towards the obstacle),
    ``p = |x - o|``, ``cos theta = <v, x - o> / (|v| p)``; the coupling is ``-grad_x U``. It acts
    only while approaching, grows as ``1/p^2`` near the obstacle, and vanishes at rest.

    ``kind="hoffmann"`` (Hoffmann et al. 2009, D = 2 or 3): ``a = gamma (r x v) phi exp(-beta phi)``,
    ``r`` the unit normal of the plane of ``o - x`` and ``v``, ``phi`` the angle between them:
    the velocity is rotated away from the obstacle, most strongly when heading at it.

    Args:
        points: ``(N, D)`` obstacle positions (or ``(B, N, D)``, one set per batch row), in the
            DMP's units; may be reassigned between steps (moving obstacles).
        kind: ``"park"`` or ``"hoffmann"``.
        gain: ``lam`` (units^2/s, Park; default 1, for metre-scale motions over about a
            second: scale it with the square of the motion's size, e.g. 0.05 for 10 cm) or
            ``gamma`` (1/s, Hoffmann; default 1000).
        beta: exponent (Park, default 2) or angular decay (Hoffmann, default ``20 / pi``).
        dims: indices of the DoF the obstacles live in (default all), e.g. ``[0, 1, 2]`` for
            the position of a ``[x, y, z, ...]`` DMP.

    Example:
        >>> import numpy as np
        >>> from lfd.dmp import ObstacleAvoidance
        >>> term = ObstacleAvoidance([[0.5, 0.0]])
        >>> a = term(np.array([0.4, 0.0]), np.array([1.0, 0.0]))  # heading at it: pushed back
        >>> bool(a[0] < 0)
        True
    """

    KINDS = ("park", "hoffmann")

    def __init__(
        self, points, kind: str = "park", gain: float | None = None, beta: float | None = None, dims=None
    ):
        self.kind = checks.check_choice(kind, "kind", self.KINDS)
        self.points = points
        default_gain, default_beta = (1.0, 2.0) if kind == "park" else (1000.0, 20.0 / np.pi)
        self.gain = checks.positive_float(default_gain if gain is None else gain, "gain")
        self.beta = checks.positive_float(default_beta if beta is None else beta, "beta")
        self.dims = None if dims is None else np.asarray(dims, dtype=int)
        if kind == "hoffmann" and self.points.shape[-1] not in (2, 3):
            raise ValueError(
                f"kind='hoffmann' needs 2-D or 3-D obstacles, got points of shape {self.points.shape}"
            )

    @property
    def points(self) -> np.ndarray:
        """``(N, D)`` or ``(B, N, D)`` obstacle positions."""
        return self._points

    @points.setter
    def points(self, value) -> None:
        points = checks.finite_array(value, "points", ndim=(2, 3))
        if getattr(self, "_points", None) is not None and points.shape[-1] != self._points.shape[-1]:
            raise ValueError(f"points must keep {self._points.shape[-1]} coordinates, got {points.shape}")
        self._points = points

    def __call__(self, y: np.ndarray, yd: np.ndarray) -> np.ndarray:
        """Acceleration ``(..., D)`` in units/s^2 for positions ``y`` and velocities ``yd`` ``(..., D)``."""
        x, v = (y, yd) if self.dims is None else (y[..., self.dims], yd[..., self.dims])
        if x.shape[-1] != self.points.shape[-1]:
            raise ValueError(
                f"obstacles have {self.points.shape[-1]} coordinates, the DMP {x.shape[-1]} (see dims)"
            )
        offset = x[..., None, :] - self.points  # (..., N, d): from obstacle to x
        velocity = np.broadcast_to(v[..., None, :], offset.shape)
        acc = (self._park if self.kind == "park" else self._hoffmann)(offset, velocity).sum(axis=-2)
        if self.dims is None:
            return acc
        full = np.zeros(np.broadcast_shapes(y.shape, yd.shape))
        full[..., self.dims] = acc
        return full

    def _park(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        p = np.maximum(np.linalg.norm(r, axis=-1, keepdims=True), 1e-12)
        speed = np.linalg.norm(v, axis=-1, keepdims=True)
        moving = speed > _MIN_SPEED
        speed_safe = np.where(moving, speed, 1.0)
        dot = np.sum(v * r, axis=-1, keepdims=True)
        cos = dot / (speed_safe * p)
        grad_cos = v / (speed_safe * p) - dot * r / (speed_safe * p**3)
        active = moving & (cos < 0)
        neg = np.where(active, -cos, 0.0)
        # grad U = lam (-c)^(beta-1) |v| / p (-beta grad c + c r / p^2)
        grad = self.gain * neg ** (self.beta - 1.0) * speed / p * (-self.beta * grad_cos + cos * r / p**2)
        return np.where(active, -grad, 0.0)

    def _hoffmann(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        planar = r.shape[-1] == 2
        if planar:  # embed in 3-D, rotate about z
            r, v = (np.concatenate([a, np.zeros_like(a[..., :1])], axis=-1) for a in (r, v))
        to_obstacle = -r
        axis = np.cross(to_obstacle, v)
        axis_norm = np.linalg.norm(axis, axis=-1, keepdims=True)
        speed = np.linalg.norm(v, axis=-1, keepdims=True)
        distance = np.linalg.norm(to_obstacle, axis=-1, keepdims=True)
        ok = (axis_norm > 1e-12) & (speed > _MIN_SPEED) & (distance > 1e-12)
        unit_axis = axis / np.where(ok, axis_norm, 1.0)
        cos = np.sum(to_obstacle * v, axis=-1, keepdims=True) / np.where(ok, speed * distance, 1.0)
        phi = np.arccos(np.clip(cos, -1.0, 1.0))
        acc = np.where(ok, self.gain * np.cross(unit_axis, v) * phi * np.exp(-self.beta * phi), 0.0)
        return acc[..., :2] if planar else acc


class JointLimits:
    """Keep every DoF inside ``[lower, upper]``: a repulsion inside a margin plus a hard stop.

    Within ``margin`` of a limit (distance ``d``) the DoF is pushed back with
    ``a = gain * margin * (1 - d / margin)^2`` (units/s^2: zero at the margin, ``gain * margin``
    at the limit; bounded, so the explicit hold of a step stays stable) and the velocity
    towards the limit is damped by ``damping``. Outside the margins the term is zero, so a
    motion that keeps clear of the limits is unchanged. Because a repulsion alone can be
    overpowered by the DMP's spring (a goal beyond a limit), step-wise integration also
    calls :meth:`project` after every sub-step, which clips the position into the limits and
    removes the velocity that points out of them: the limits hold exactly.

    Args:
        lower, upper: ``(D,)`` limits in the DMP's units (``lower < upper``).
        margin: width of the active band (units), scalar or ``(D,)``; default 10 % of the range.
        gain: repulsion strength in 1/s^2 (default 500).
        damping: velocity damping inside the band in 1/s (default 30).

    Example:
        >>> import numpy as np
        >>> from lfd.dmp import JointLimits
        >>> limits = JointLimits(lower=[-1.0], upper=[1.0])
        >>> bool(limits(np.array([0.95]), np.array([0.0]))[0] < 0)   # near the upper limit: pushed down
        True
    """

    def __init__(self, lower, upper, margin=None, gain: float = 500.0, damping: float = 30.0):
        self.lower = checks.finite_array(lower, "lower", ndim=(1,))
        self.upper = checks.finite_array(upper, "upper", ndim=(1,))
        if self.lower.shape != self.upper.shape or np.any(self.lower >= self.upper):
            raise ValueError("lower and upper must have the same shape (D,) with lower < upper")
        span = self.upper - self.lower
        self.margin = (
            0.1 * span
            if margin is None
            else np.broadcast_to(checks.finite_array(margin, "margin", ndim=(0, 1)), span.shape).copy()
        )
        if np.any(self.margin <= 0) or np.any(2 * self.margin > span):
            raise ValueError("margin must be > 0 and at most half of upper - lower")
        self.gain = checks.positive_float(gain, "gain")
        self.damping = checks.positive_float(damping, "damping")

    def _check(self, y: np.ndarray) -> None:
        if y.shape[-1] != self.lower.shape[0]:
            raise ValueError(f"JointLimits has {self.lower.shape[0]} DoF, got positions of shape {y.shape}")

    def __call__(self, y: np.ndarray, yd: np.ndarray) -> np.ndarray:
        """Acceleration ``(..., D)`` in units/s^2."""
        self._check(y)
        acc = np.zeros(np.broadcast_shapes(y.shape, yd.shape))
        for sign, distance in ((1.0, y - self.lower), (-1.0, self.upper - y)):
            depth = np.clip(1.0 - distance / self.margin, 0.0, 1.0)  # 0 outside the band, 1 at the limit
            towards = np.minimum(sign * yd, 0.0)  # velocity component towards this limit (<= 0)
            acc = acc + np.where(
                depth > 0, sign * (self.gain * self.margin * depth**2 - self.damping * towards), 0.0
            )
        return acc

    def project(self, y: np.ndarray, yd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Clip ``y`` into ``[lower, upper]`` and drop velocity that points out of the limits."""
        self._check(y)
        below, above = y < self.lower, y > self.upper
        y = np.clip(y, self.lower, self.upper)
        yd = np.where((y <= self.lower) & (yd < 0) | (y >= self.upper) & (yd > 0) | below | above, 0.0, yd)
        return y, yd
