"""FinalVelocityDMP and DualCartesianDMP against movement_primitives 0.9.1, same settings.

Prints, for each, movement_primitives' error to ours as its Euler step ``int_dt`` shrinks
(first order towards ours when ours is the continuous solution), the Richardson
extrapolation of its two finest runs, and for the hitting DMP the reproduction error and the
estimated final velocity of a demonstration whose final velocity is known. For the dual-arm
DMP it also shows movement_primitives' velocity coupling (``c1``) changing with ``int_dt``.

Usage::

    PYTHONPATH=src python benchmarks/dmp_hitting_bimanual.py
"""

from __future__ import annotations

import time

import numpy as np
from movement_primitives.dmp import CouplingTermDualCartesianPose, DMPWithFinalVelocity
from movement_primitives.dmp import DualCartesianDMP as ReferenceDual

from lfd.dmp import DualCartesianDMP, FinalVelocityDMP, RelativePoseCoupling
from lfd.dmp.quaternion import exp

K = 25.0 * 6.25
T = np.linspace(0.0, 1.0, 101)


def hitting() -> None:
    demo = np.stack([T**2, np.sin(2 * T), 0.3 * np.cos(3 * T)], -1)
    true_velocity = np.array([2.0, 2 * np.cos(2.0), -0.9 * np.sin(3.0)])
    dmp = FinalVelocityDMP(n_basis=10, alpha_s=np.log(100.0)).fit(T, demo)
    print("## FinalVelocityDMP vs DMPWithFinalVelocity (10 bases, same weights and boundary conditions)\n")
    print("| int_dt [s] | max abs error to ours | time [s] |")
    print("|---|---|---|")
    runs = {}
    for int_dt in (1e-3, 2e-4, 1e-4):
        mp = DMPWithFinalVelocity(n_dims=3, execution_time=1.0, dt=0.01, n_weights_per_dim=10, int_dt=int_dt)
        mp.set_weights((K * dmp.weights_).ravel())
        mp.configure(
            start_y=dmp.y0_,
            start_yd=dmp.yd0_,
            start_ydd=dmp.ydd0_,
            goal_y=dmp.goal_,
            goal_yd=dmp.goal_velocity_,
            goal_ydd=dmp.goal_acceleration_,
        )
        start = time.perf_counter()
        times, runs[int_dt] = mp.open_loop()
        elapsed = time.perf_counter() - start
        print(f"| {int_dt:g} | {np.abs(runs[int_dt] - dmp.rollout(t=times)).max():.2e} | {elapsed:.2f} |")
    richardson = np.abs(2 * runs[1e-4] - runs[2e-4] - dmp.rollout(t=times)).max()
    start = time.perf_counter()
    dmp.rollout(t=times)
    print(
        f"\nRichardson (2 x 1e-4 run - 2e-4 run) to ours: {richardson:.2e}; ours {time.perf_counter() - start:.4f} s"
    )
    mp = DMPWithFinalVelocity(n_dims=3, execution_time=1.0, dt=0.01, n_weights_per_dim=10)
    mp.imitate(T, demo)
    _, theirs = mp.open_loop()
    print(
        f"Fit of the demonstration (101 samples): max error ours {np.abs(dmp.rollout() - demo).max():.2e}, "
        f"movement_primitives {np.abs(theirs - demo).max():.2e}; final-velocity estimate error ours "
        f"{np.abs(dmp.goal_velocity_ - true_velocity).max():.2e}, theirs {np.abs(mp.goal_yd - true_velocity).max():.2e}"
    )
    _, velocity, _ = dmp.rollout(goal_velocity=[3.0, 0.0, -1.0], return_derivatives=True)
    print(f"New final velocity [3, 0, -1]: reached {np.round(velocity[-1], 4).tolist()}\n")


def bimanual() -> None:
    left = np.stack([0.3 * T, 0.5 + 0.1 * np.sin(np.pi * T), 0.2 + 0 * T], -1)
    right = left + [0.0, -0.3, 0.0] + np.stack([0 * T, 0 * T, 0.05 * np.sin(np.pi * T)], -1)
    demo = np.concatenate([left, exp(np.outer(T, [0, 0, 0.8])), right, exp(np.outer(T, [0.3, 0, 0.5]))], -1)
    dmp = DualCartesianDMP(n_basis=10, alpha_s=np.log(100.0)).fit(T, demo)
    coupling = RelativePoseCoupling(desired=[0.0, -0.2, 0.0, 1.0, 0.0, 0.0, 0.0], k=1.0, c1=0.0, c2=30.0)
    start = time.perf_counter()
    ours = dmp.rollout(coupling=coupling)
    ours_time = time.perf_counter() - start
    print("## DualCartesianDMP + RelativePoseCoupling vs DualCartesianDMP + CouplingTermDualCartesianPose\n")
    print(
        "(10 bases, smooth_scaling=True = our 'pastor', desired right-in-left offset [0, -0.2, 0], k = 1, c2 = 30)\n"
    )
    print(
        "| int_dt [s] | c1 = 0: max abs error to ours | c1 = 1: change from the previous int_dt | time [s] |"
    )
    print("|---|---|---|---|")
    runs, previous = {}, None
    for int_dt in (1e-3, 5e-4, 2.5e-4):
        results = []
        for c1 in (0.0, 1.0):
            ref = ReferenceDual(
                execution_time=1.0, dt=0.01, n_weights_per_dim=10, int_dt=int_dt, smooth_scaling=True
            )
            ref.set_weights((K * dmp.weights_).ravel())
            ref.configure(start_y=dmp.start_, goal_y=dmp.goal_)
            desired = np.eye(4)
            desired[:3, 3] = [0.0, -0.2, 0.0]
            term = CouplingTermDualCartesianPose(
                desired_distance=desired, lf=(1.0, 1.0), k=1.0, c1=c1, c2=30.0
            )
            start = time.perf_counter()
            _, poses = ref.open_loop(coupling_term=term)
            results.append((poses, time.perf_counter() - start))
        (plain, elapsed), (with_c1, _) = results
        for s in (slice(3, 7), slice(10, 14)):
            plain[np.sum(plain[:, s] * ours[:, s], -1) < 0, s] *= -1
        runs[int_dt] = plain
        change = "" if previous is None else f"{np.abs(with_c1 - previous).max():.2e}"
        previous = with_c1
        print(f"| {int_dt:g} | {np.abs(plain - ours).max():.2e} | {change} | {elapsed:.2f} |")
    richardson = np.abs(2 * runs[2.5e-4] - runs[5e-4] - ours).max()
    print(
        f"\nRichardson (c1 = 0, two finest runs) to ours: {richardson:.2e}; ours {ours_time:.2f} s (1000 sub-steps)"
    )
    gap = np.linalg.norm(ours[-1, 7:10] - ours[-1, :3])
    print(f"Arms' distance at tau: coupled {gap:.3f} m, uncoupled 0.300 m (demonstrated), desired 0.200 m")


if __name__ == "__main__":
    hitting()
    bimanual()
