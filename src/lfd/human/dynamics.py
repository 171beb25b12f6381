"""Joint torques of the human arm by recursive Newton-Euler (``lfd.robots`` batched RNE).

The model is ``load_robot("human_arm", ...)`` (the 4-DoF human-arm model, docs/human.md):
segment masses are de Leva (1996) fractions of the body mass for the given sex (upper arm
2.71/2.55 %, forearm 1.62/1.38 %, hand 0.61/0.56 %, male/female), centres of mass at 57.7 % (upper arm) and 45.7 %
(forearm) of the segment from the proximal joint, the hand's at half its length beyond
the wrist. An optional load held in the hand (kg) is a point mass at the hand's centre of
mass, added to the forearm link.

Gravity is given per frame in the trunk frame (the person may lean), so the torque is
split into the part without gravity plus the gravity part, which is linear in the
gravity vector: ``tau = ID(q, qd, qdd, 0) + sum_k g_k ID(q, 0, 0, e_k)``. The trunk is
treated as an inertial (non-accelerating) base.
"""

from __future__ import annotations

import contextlib
import dataclasses

import numpy as np
import torch

from lfd.robots import Robot, load_robot
from lfd.robots.spec import composite_inertial

__all__ = ["arm_model", "arm_torques"]


def arm_model(
    upper_arm_length: float = 0.30,
    forearm_length: float = 0.27,
    hand_length: float = 0.19,
    body_mass: float = 75.0,
    sex: str = "male",
    hand_load: float = 0.0,
) -> Robot:
    """The right human-arm robot with a load of ``hand_load`` kg held at the hand's centre of mass.

    Lengths in m, masses in kg. Raises ``ValueError`` on non-positive lengths/mass, a
    negative load or an unknown sex.
    """
    if not (np.isfinite(hand_load) and hand_load >= 0):
        raise ValueError(f"hand_load must be a non-negative mass in kg, got {hand_load!r}")
    robot = load_robot(
        "human_arm",
        upper_arm_length=float(upper_arm_length),
        forearm_length=float(forearm_length),
        hand_length=float(hand_length),
        body_mass=float(body_mass),
        sex=sex,
    )
    if hand_load == 0:
        return robot
    spec = robot.spec
    load_point = np.array([0.0, 0.0, -(forearm_length + 0.5 * hand_length)])  # forearm link frame
    mass, com, inertia = composite_inertial(
        [
            (spec.link_masses[3], spec.link_coms[3], spec.link_inertias[3]),
            (hand_load, load_point, np.zeros((3, 3))),
        ]
    )
    masses, coms, inertias = spec.link_masses.copy(), spec.link_coms.copy(), spec.link_inertias.copy()
    masses[3], coms[3], inertias[3] = mass, com, inertia
    return Robot(dataclasses.replace(spec, link_masses=masses, link_coms=coms, link_inertias=inertias))


@contextlib.contextmanager
def _single_thread():
    """Run small batched torch ops on one thread: on a busy 2-core machine the thread pool's
    hand-offs cost more than the work; the previous thread count is restored after."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


def arm_torques(
    robot: Robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, gravity: np.ndarray
) -> np.ndarray:
    """Joint torques (T, 4) N m for per-frame gravity.

    Args:
        robot: from :func:`arm_model`. q, qd, qdd: (T, 4) rad, rad/s, rad/s^2 (right-arm model).
        gravity: (T, 3) m/s^2 in the model's base (trunk) frame, or (3,) for all frames.

    Rows with any NaN input give NaN torques.
    """
    q, qd, qdd = (np.asarray(x, dtype=float) for x in (q, qd, qdd))
    g = np.broadcast_to(np.asarray(gravity, dtype=float), (len(q), 3))
    ok = np.isfinite(q).all(1) & np.isfinite(qd).all(1) & np.isfinite(qdd).all(1) & np.isfinite(g).all(1)
    tau = np.full((len(q), robot.n_dof), np.nan)
    if not ok.any():
        return tau
    qt = torch.from_numpy(np.ascontiguousarray(q[ok]))
    zero = torch.zeros_like(qt)
    with _single_thread():
        total = robot.inverse_dynamics(
            qt,
            torch.from_numpy(np.ascontiguousarray(qd[ok])),
            torch.from_numpy(np.ascontiguousarray(qdd[ok])),
            gravity=(0.0, 0.0, 0.0),
        ).numpy()
        for k in range(3):
            unit = np.zeros(3)
            unit[k] = 1.0
            total = (
                total + g[ok, k : k + 1] * robot.inverse_dynamics(qt, zero, zero, gravity=tuple(unit)).numpy()
            )
    tau[ok] = total
    return tau
