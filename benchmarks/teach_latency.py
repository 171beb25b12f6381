"""Server-side latency of one drag update of the teach interface (lfd.teach).

For each robot a scripted drag (a 12 cm circle in a vertical plane in front of the
start pose, then a 25 cm lift; one update per cm) goes through ``TeachServer.handle_drag``,
which is what the server's worker runs for each gizmo update: IK + collision sweep
(the session) + scene update (arm nodes, gizmo colour, ghost, sliders, status text).
No browser is connected (viser queues the messages), so network and rendering are
not included. The reference in the same process is the same update with the
project's general batched IK (``Robot.ik``, torch Levenberg-Marquardt, warm-started,
no restarts) in place of the drag IK.

    python benchmarks/teach_latency.py [--updates 300]

Prints a markdown table (milliseconds).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from lfd.teach import TeachSession
from lfd.teach.server import TeachServer

CASES = [
    ("wam4", "configs/teach/boxes.yaml", "fixed", "closed form, joint 3 fixed"),
    ("wam4", "configs/teach/boxes.yaml", "free", "LM, joint 3 free"),
    ("pr2_right_arm", "configs/teach/pr2_table.yaml", "fixed", "LM, 7 DoF"),
]


def path(start: np.ndarray, n: int) -> np.ndarray:
    """(n, 3) targets: a circle of radius 6 cm in the x-z plane, then a lift."""
    k = n * 2 // 3
    a = np.linspace(0.0, 2 * np.pi, k)
    circle = start + np.stack([0.06 * np.sin(a), np.zeros(k), 0.06 * (1 - np.cos(a))], axis=1)
    lift = start + np.linspace(0.0, 0.25, n - k)[:, None] * np.array([0.0, 0.0, 1.0])
    return np.vstack([circle, lift])


def measure(robot: str, scene: str, q3: str, n: int, reference: bool) -> dict:
    session = TeachSession(robot=robot, scene=scene, wam_q3=q3)
    server = TeachServer(session, port=0)
    if reference:
        ik = session.robot.ik

        class _Ref:
            def solve(self, q, target, orientation=None):
                res = ik(
                    np.asarray(target)[None],
                    np.asarray(q)[None],
                    position_only=True,
                    restarts=0,
                    tol_pos=1e-3,
                )
                from lfd.teach.drag_ik import IKStep

                qq = res.q[0].numpy()
                return IKStep(
                    qq,
                    bool(res.success[0]),
                    float(res.pos_error[0]),
                    float(np.max(np.abs(qq - q))),
                    0,
                    False,
                    "ref",
                )

        session.ik.solve = _Ref().solve  # same session, same sweep and scene update
    targets = path(session.tool_position, n)
    total, core = [], []
    accepted = 0
    for t in targets:
        tic = time.perf_counter()
        r = server.handle_drag(t)
        total.append(time.perf_counter() - tic)
        core.append(r.latency)
        accepted += r.accepted
    server.close()
    session.close()
    ms = lambda x, q: float(np.percentile(np.array(x) * 1e3, q))  # noqa: E731
    return {
        "core_med": ms(core, 50),
        "core_p95": ms(core, 95),
        "tot_med": ms(total, 50),
        "tot_p95": ms(total, 95),
        "tot_max": ms(total, 100),
        "accepted": accepted,
        "n": n,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--updates", type=int, default=300)
    args = parser.parse_args()
    print(
        "| robot | drag IK | updates accepted | IK + collision: median / p95 | whole update: median / p95 / max "
        "| reference (Robot.ik) whole update: median / p95 | reference / ours (median) |"
    )
    print("|---|---|---:|---:|---:|---:|---:|")
    for robot, scene, q3, label in CASES:
        ours = measure(robot, scene, q3, args.updates, reference=False)
        ref = measure(robot, scene, q3, args.updates, reference=True)
        print(
            f"| {robot} | {label} | {ours['accepted']}/{ours['n']} "
            f"| {ours['core_med']:.2f} / {ours['core_p95']:.2f} ms "
            f"| {ours['tot_med']:.2f} / {ours['tot_p95']:.2f} / {ours['tot_max']:.1f} ms "
            f"| {ref['tot_med']:.2f} / {ref['tot_p95']:.2f} ms | {ref['tot_med'] / ours['tot_med']:.1f}x |"
        )


if __name__ == "__main__":
    main()
