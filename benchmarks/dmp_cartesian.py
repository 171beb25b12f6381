"""Cartesian DMP reproduction against movement_primitives 0.9.1's CartesianDMP (docs/dmp.md, "Cartesian DMP").

Same demonstrations (the ones of tests/dmp/test_dmp_cartesian.py: three synthetic pose
trajectories whose rotation axis changes, six LASA shapes lifted to 3-D with an orientation
that turns with the position, one fixed-axis rotation), n_basis = 20, both libraries
fitting and reproducing on the demonstration's grid. Reports position RMSE (units of the
demonstration) and orientation RMSE (rad, angle of q_out * conj(q_demo)), and the time of
one fit + rollout.

Run: ``PYTHONPATH=src python benchmarks/dmp_cartesian.py``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "dmp"))

from movement_primitives.dmp import CartesianDMP as ReferenceCartesianDMP
from test_dmp_cartesian import fixed_axis_demo, free_demos, orientation_rmse, position_rmse

from lfd.dmp import CartesianDMP


def main():
    print(
        "| demonstration | lfd 'log': pos / rot RMSE | lfd 'ude': pos / rot RMSE | movement_primitives: pos / rot RMSE "
        "| time fit+rollout lfd 'log' / 'ude' / mp (s) |"
    )
    print("|---|---|---|---|---|")
    for name, t, pose in free_demos() + [("fixed axis", *fixed_axis_demo()[:2])]:
        cells, times = [], []
        for orientation in ("log", "ude"):
            start = time.perf_counter()
            ours = CartesianDMP(n_basis=20, orientation=orientation).fit(t, pose).rollout(t=t)
            times.append(time.perf_counter() - start)
            cells.append(
                f"{position_rmse(ours[:, :3], pose[:, :3]):.2e} / {orientation_rmse(ours[:, 3:], pose[:, 3:]):.2e}"
            )
        start = time.perf_counter()
        reference = ReferenceCartesianDMP(execution_time=t[-1] - t[0], dt=t[1] - t[0], n_weights_per_dim=20)
        reference.imitate(t - t[0], pose)
        reference.configure(start_y=pose[0], goal_y=pose[-1])
        theirs = reference.open_loop()[1][: len(t)]
        times.append(time.perf_counter() - start)
        cells.append(
            f"{position_rmse(theirs[:, :3], pose[:, :3]):.2e} / {orientation_rmse(theirs[:, 3:], pose[:, 3:]):.2e}"
        )
        print(f"| {name} | " + " | ".join(cells) + " | " + " / ".join(f"{x:.2f}" for x in times) + " |")


if __name__ == "__main__":
    main()
