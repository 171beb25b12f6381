"""The thesis' 3-D vs 2-D comparison, with scripted users on seeded task layouts (lfd.teach).

Every user gets the same layouts (WAM, a wall between start and goal region) and the
same first clearance misjudgment per task (``lfd.teach.scripted_users``): the 3-D drag
user, the 2-D panel user with the x/y/z entry, and the 2-D panel user with the joint
sliders. Reported per user: success rate, collisions per task, recorded tool path
length, and user actions per task (drag segments, slider moves, clicks, keystrokes).
"KLM time" is a keystroke-level model estimate (``klm_seconds``), a model and not a
measurement; the wall-clock time of scripted runs measures the machine, not the
interface, and is not reported. Seeds 0-9 were used while writing the users; the
default report uses seeds 100-129.

    python benchmarks/teach_users.py [--tasks 30] [--first-seed 100]
"""

from __future__ import annotations

import argparse

import numpy as np
from tqdm import tqdm

from lfd.teach.scripted_users import klm_seconds, make_task, run_drag_user, run_slider_user, run_xyz_user

USERS = (run_drag_user, run_xyz_user, run_slider_user)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=100)
    args = parser.parse_args()
    runs: dict[str, list] = {}
    for seed in tqdm(range(args.first_seed, args.first_seed + args.tasks), desc="tasks"):
        task = make_task(seed)
        for user in USERS:
            r = user(task)
            runs.setdefault(r.user, []).append(r)
    print(
        f"{args.tasks} tasks (seeds {args.first_seed}..{args.first_seed + args.tasks - 1}), WAM, "
        "one wall between start and goal"
    )
    print()
    print(
        "| interface (scripted user) | success | collisions / task | tool path (m) | drag segments | slider moves "
        "| clicks | keystrokes | actions / task | KLM time / task (model) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, rs in runs.items():
        ok = [r for r in rs if r.success]
        mean = {
            key: np.mean([r.actions[key] for r in rs])
            for key in ("drag_segments", "slider_moves", "clicks", "keystrokes")
        }
        path = np.mean([r.path_length for r in ok]) if ok else float("nan")
        print(
            f"| {name} | {len(ok)}/{len(rs)} | {np.mean([r.collisions for r in rs]):.2f} | {path:.2f} "
            f"| {mean['drag_segments']:.1f} | {mean['slider_moves']:.1f} | {mean['clicks']:.1f} "
            f"| {mean['keystrokes']:.1f} | {np.mean([r.n_actions for r in rs]):.1f} "
            f"| {np.mean([klm_seconds(r) for r in rs]):.1f} s |"
        )


if __name__ == "__main__":
    main()
