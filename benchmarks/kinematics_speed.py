"""Speed of lfd.robots against Pinocchio on the Sawyer, in one process.

Measures forward kinematics (1 and 100 000 configurations), the Jacobian (1000),
inverse dynamics (1000) and batched IK (1000 reachable poses), prints a markdown
table with ratios and checks the project's targets:

* FK of 100 000 configurations under 50 ms, and at least 6x Pinocchio's Python loop
  (float64: measured as alternating pairs, so both see the same load; median and range of the
  per-pair ratios; float32, the precision of the README's headline row: against the same loop);
* inverse dynamics of 1000 rows within 3x Pinocchio's ``rneaInParallel``;
* batched IK under 1 ms per target (median over repeats).

Pinocchio is driven the way a Python user would: a loop of ``forwardKinematics`` +
``updateFramePlacements``, ``computeFrameJacobian``, ``rnea``; ``rneaInParallel`` on
all torch threads; and a per-target damped-least-squares loop for IK (from the home
pose, no restarts) since Pinocchio has no batched IK.

Times are medians of wall-clock time, with process CPU time beside them: on a shared,
busy machine the CPU time is the better estimate of what a quiet machine would show,
and ``--threads 1`` avoids torch's intra-op threads spinning against other processes.

Usage::

    PYTHONPATH=src python benchmarks/kinematics_speed.py [--quick] [--threads N]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import pinocchio as pin
import torch

from lfd.robots import load_robot


class Timing(NamedTuple):
    wall: float  # s, median over repeats
    cpu: float  # s, median process CPU time (all threads) over repeats

    def scaled(self, factor: float) -> Timing:
        return Timing(self.wall * factor, self.cpu * factor)

    def __str__(self) -> str:
        return f"{self.wall * 1e3:.3f} ({self.cpu * 1e3:.3f})"


def timed(fn: Callable[[], object], repeats: int, inner: int = 1) -> Timing:
    """Median wall and CPU time of one call of ``fn`` (s) over ``repeats`` runs of ``inner`` calls, after a warm-up."""
    fn()
    walls, cpus = [], []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        for _ in range(inner):
            fn()
        walls.append((time.perf_counter() - wall) / inner)
        cpus.append((time.process_time() - cpu) / inner)
    return Timing(statistics.median(walls), statistics.median(cpus))


def paired_ratio(ours: Callable[[], object], theirs: Callable[[], object], repeats: int, scale: float = 1.0):
    """Run ``ours`` and ``theirs`` alternately ``repeats`` times (both see the same load).

    Returns the median wall times (s) of both, the sorted per-pair wall ratios
    ``theirs * scale / ours`` and the sorted per-pair process-CPU-time ratios.
    """
    ours(), theirs()
    pairs = []
    for _ in range(repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        ours()
        wall_mid, cpu_mid = time.perf_counter(), time.process_time()
        theirs()
        pairs.append(
            (
                wall_mid - wall,
                (time.perf_counter() - wall_mid) * scale,
                cpu_mid - cpu,
                (time.process_time() - cpu_mid) * scale,
            )
        )
    ratios = sorted(p[1] / p[0] for p in pairs)
    cpu_ratios = sorted(p[3] / p[2] for p in pairs)
    return statistics.median(p[0] for p in pairs), statistics.median(p[1] for p in pairs), ratios, cpu_ratios


def pin_fk_loop(model, data, frame: int, qs: np.ndarray) -> None:
    for q in qs:
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacement(model, data, frame)


def pin_jacobian_loop(model, data, frame: int, qs: np.ndarray) -> None:
    for q in qs:
        pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)


def pin_rnea_loop(model, data, qs: np.ndarray, vs: np.ndarray, accs: np.ndarray) -> None:
    for q, v, a in zip(qs, vs, accs):
        pin.rnea(model, data, q, v, a)


def pin_dls_ik(model, data, frame: int, targets: list, q0: np.ndarray, max_iters: int = 200) -> np.ndarray:
    """Per-target damped least squares with clamping; returns success flags."""
    success = np.zeros(len(targets), bool)
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    for k, target in enumerate(targets):
        q = q0.copy()
        for _ in range(max_iters):
            pin.forwardKinematics(model, data, q)
            current = pin.updateFramePlacement(model, data, frame)
            rotation_error = pin.log3(target.rotation @ current.rotation.T)
            err = np.concatenate([target.translation - current.translation, rotation_error])
            if np.linalg.norm(err[:3]) < 1e-4 and np.linalg.norm(err[3:]) < 1e-3:
                success[k] = True
                break
            jac = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL_WORLD_ALIGNED)
            q = np.clip(q + jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), err), lower, upper)
    return success


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--quick", action="store_true", help="fewer repeats; Pinocchio loops on 10x fewer rows"
    )
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: torch's choice)")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    threads = torch.get_num_threads()
    repeats = 3 if args.quick else 7
    pin_rows = 10 if args.quick else 1  # divisor of the Pinocchio loop lengths (results rescaled)

    robot = load_robot("sawyer")
    model = pin.buildModelFromXML(robot.to_urdf())
    data = model.createData()
    frame = model.getFrameId("tool_link")
    gen = torch.Generator().manual_seed(0)
    q_big = robot.sample_q(100_000, gen)
    q_big32 = q_big.float()
    q1000, qd1000, qdd1000 = (robot.sample_q(1000, gen) for _ in range(3))
    np_big, np1000, npd, npdd = q_big.numpy(), q1000.numpy(), qd1000.numpy(), qdd1000.numpy()

    # Agreement first: a benchmark of wrong numbers is worthless.
    pin.forwardKinematics(model, data, np1000[0])
    assert np.allclose(
        pin.updateFramePlacement(model, data, frame).homogeneous, robot.fk(q1000[:1])[0].numpy()
    )
    pool = pin.ModelPool(model, threads)
    qT, vT, aT = np1000.T.copy(), npd.T.copy(), npdd.T.copy()  # Pinocchio's batch layout: (nq, batch)
    tau_pin = pin.rneaInParallel(threads, pool, qT, vT, aT)
    assert np.allclose(tau_pin.T, robot.inverse_dynamics(q1000, qd1000, qdd1000).numpy(), atol=1e-8)

    single = q1000[:1]
    n_pin = 100_000 // pin_rows
    fk64 = timed(lambda: robot.fk(q_big), repeats)
    fk32 = timed(lambda: robot.fk(q_big32), repeats)
    pin_big = timed(lambda: pin_fk_loop(model, data, frame, np_big[:n_pin]), repeats).scaled(pin_rows)
    rne = timed(lambda: robot.inverse_dynamics(q1000, qd1000, qdd1000), repeats, 5)
    rnea_par = timed(lambda: pin.rneaInParallel(threads, pool, qT, vT, aT), repeats, 5)
    rows = [
        ("FK, 1 config (f64)", 1, timed(lambda: robot.fk(single), repeats, 200),
         timed(lambda: pin_fk_loop(model, data, frame, np1000[:1]), repeats, 200), ""),
        ("FK, 100k configs (f64)", 100_000, fk64, pin_big, "pin: Python loop"),
        ("FK, 100k configs (f32)", 100_000, fk32, pin_big, "pin: Python loop (f64)"),
        ("Jacobian, 1000 configs (f64)", 1000, timed(lambda: robot.jacobian(q1000), repeats, 5),
         timed(lambda: pin_jacobian_loop(model, data, frame, np1000), repeats), "pin: Python loop"),
        ("Inverse dynamics, 1000 rows (f64)", 1000, rne,
         timed(lambda: pin_rnea_loop(model, data, np1000, npd, npdd), repeats), "pin: Python loop of rnea"),
        ("Inverse dynamics, 1000 rows (f64)", 1000, rne, rnea_par, f"pin: rneaInParallel, {threads} threads"),
    ]  # fmt: skip

    targets = robot.fk(robot.sample_q(1000, gen))
    ik_success = []
    ik = timed(
        lambda: ik_success.append(robot.ik(targets).success.float().mean().item()), max(repeats // 2, 2)
    )
    pin_targets = [pin.SE3(t[:3, :3], t[:3, 3]) for t in targets.numpy()[: 1000 // pin_rows]]
    pin_success = []
    pin_ik = timed(
        lambda: pin_success.append(pin_dls_ik(model, data, frame, pin_targets, robot.home.numpy())), 1
    )
    note = f"success lfd {min(ik_success):.1%}, pin {pin_success[0].mean():.1%} (DLS loop from home, no restarts)"
    rows.append(("IK, 1000 poses (f64)", 1000, ik, pin_ik.scaled(pin_rows), note))
    fk_ours, fk_pin, fk_ratios, fk_cpu_ratios = paired_ratio(
        lambda: robot.fk(q_big),
        lambda: pin_fk_loop(model, data, frame, np_big[:n_pin]),
        2 * repeats + 1,
        pin_rows,
    )

    quick = ", quick: Pinocchio loops on 1/10 of the rows, rescaled" if args.quick else ""
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"\nlfd.robots vs Pinocchio {pin.__version__} on the Sawyer; torch {torch.__version__}, {threads} torch "
          f"threads, {os.cpu_count()} CPUs, load average {load}{quick}\n")  # fmt: skip
    print("Times are medians per call in ms: wall clock (process CPU time, all threads).\n")
    print("| operation | batch | lfd | Pinocchio | Pinocchio / lfd (wall) | note |")
    print("|---|---:|---:|---:|---:|---|")
    for op, batch, ours, theirs, note in rows:
        print(f"| {op} | {batch} | {ours} | {theirs} | {theirs.wall / ours.wall:.2f}x | {note} |")
    verdict = {True: "met", False: "NOT met"}
    per_target = ik.wall / len(targets)
    print("\nTargets (wall-clock medians):")
    print(f"- FK of 100k configurations < 50 ms: f64 {fk64.wall * 1e3:.1f} ms ({verdict[fk64.wall < 0.05]}), "
          f"f32 {fk32.wall * 1e3:.1f} ms ({verdict[fk32.wall < 0.05]})")  # fmt: skip
    fk_ratio = statistics.median(fk_ratios)
    print(f"- FK of 100k configurations >= 6x Pinocchio's loop (f64, {len(fk_ratios)} alternating pairs): "
          f"lfd {fk_ours * 1e3:.1f} ms, Pinocchio {fk_pin * 1e3:.1f} ms, ratio median {fk_ratio:.2f}x "
          f"(range {fk_ratios[0]:.2f}-{fk_ratios[-1]:.2f}x, {verdict[fk_ratio >= 6]}); process CPU time "
          f"ratio median {statistics.median(fk_cpu_ratios):.2f}x "
          f"(range {fk_cpu_ratios[0]:.2f}-{fk_cpu_ratios[-1]:.2f}x)")  # fmt: skip
    f32_ratio = fk_pin / fk32.wall
    print(f"- FK of 100k configurations >= 6x Pinocchio's loop (f32, the README's headline precision; "
          f"Pinocchio is f64): {f32_ratio:.2f}x ({verdict[f32_ratio >= 6]})")  # fmt: skip
    ratio = rne.wall / rnea_par.wall
    print(f"- inverse dynamics within 3x rneaInParallel: {ratio:.2f}x ({verdict[ratio <= 3]})")
    print(
        f"- batched IK < 1 ms per target: {per_target * 1e3:.3f} ms per target ({verdict[per_target < 1e-3]})"
    )


if __name__ == "__main__":
    main()
