"""The imitation pipeline on real skeleton recordings and its policy-search refinement, measured.

Part 1 (``--skeletons DIR``): every UI-PRMD Kinect file of subjects s06-s10 (e01, movements m07-m10) and the
KIMORE exercises found under ``DIR`` (e.g. ``../shared/data/human``), each to the WAM and to the Sawyer
through :func:`lfd.imitation.run`; per robot: files, limit violations, DMP vs reference RMSE and executed vs
DMP RMSE (rad), worst and median.

Part 2: refinement of a scripted WAM reach (the demonstration the tests use) to targets 10 cm from its end
point in 10 seeded random directions, and through via points 5 cm off its middle, with each policy search;
the median rollouts to 1 cm, successes, and the median shape RMSE.

    python benchmarks/imitation_sources.py --skeletons ../shared/data/human
    python benchmarks/imitation_sources.py --skeletons ../shared/data/human --split validation --no-refinement \\
        [--override dmp.n_basis=30] [--choices]   # the files the defaults were chosen on, and the choices
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]


def _cfg(overrides):
    from hydra import compose, initialize_config_dir

    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="imitate", overrides=overrides)


def skeleton_files(root: Path, split: str = "report") -> list[Path]:
    """``report``: UI-PRMD subjects s06-s10 (e01, m07-m10) and every KIMORE recording; ``validation`` (where
    the defaults were chosen): UI-PRMD subjects s02-s05 and KIMORE exercise 1."""
    uiprmd = root / "ui_prmd" / "Kinect" / "Positions"
    subjects = range(6, 11) if split == "report" else range(2, 6)
    files = [uiprmd / f"m{m:02d}_s{s:02d}_e01_positions.txt.gz" for m in (7, 8, 9, 10) for s in subjects]
    kimore = "JointPositionExercise*.csv" if split == "report" else "JointPositionExercise1.csv"
    files += sorted((root / "kimore").glob(kimore))
    return [f for f in files if f.is_file()]


def part_skeletons(root: Path, split: str = "report", overrides: tuple[str, ...] = ()) -> None:
    import lfd.imitation

    files = skeleton_files(root, split)
    print(
        f"## Real skeleton recordings -> robots ({split} split, {len(files)} files) {' '.join(overrides)}\n"
    )
    print("| robot | files | with limit violations | DMP vs reference RMSE median / max (rad) | within 0.05 rad | "
          "executed vs DMP median / max (rad) | time scale median / max |")  # fmt: skip
    print("|---|---:|---:|---|---:|---|---|")
    for robot in ("wam4", "sawyer"):
        rows = []
        for path in files:
            with tempfile.TemporaryDirectory() as out:
                base = [f"source={path}", f"robot={robot}", "side=right", "outputs.video=false"]
                cfg = _cfg([*base, "outputs.gif=false", "outputs.bag=null", *overrides])
                with contextlib.redirect_stdout(sys.stderr):  # the run's one-line report, off the table
                    summary = lfd.imitation.run(cfg, out)
            rows.append(summary)
            print(f"  {robot} {path.name}: {summary['limit_violations']} violations, "
                  f"DMP {summary['dmp_vs_reference_rmse_rad']:.4f}, "
                  f"executed {summary['executed_vs_dmp_rmse_rad']:.4f}, "
                  f"x{summary['time_scale']:.2f}, {summary['dmp_n_basis']} bases", file=sys.stderr)  # fmt: skip
        dmp = [r["dmp_vs_reference_rmse_rad"] for r in rows]
        exe = [r["executed_vs_dmp_rmse_rad"] for r in rows]
        print(
            f"| {robot} | {len(rows)} | {sum(r['limit_violations'] > 0 for r in rows)} | "
            f"{statistics.median(dmp):.4f} / {max(dmp):.4f} | {sum(d <= 0.05 for d in dmp)}/{len(dmp)} | "
            f"{statistics.median(exe):.4f} / {max(exe):.4f} | "
            f"{statistics.median(r['time_scale'] for r in rows):.2f} / {max(r['time_scale'] for r in rows):.2f} |"
        )
        for r in rows:
            if r["dmp_vs_reference_rmse_rad"] > 0.05:
                print(
                    f"  miss: {Path(r['source']).name} -> {robot}: {r['dmp_vs_reference_rmse_rad']:.3f} rad"
                )


def _retargeted(path: Path, robot: str, **wrist_options):
    """(t, retargeting result) of ``path``'s right arm for ``robot``, the pipeline's stages with default settings."""
    import lfd.imitation
    from lfd.human.retarget import retarget_wrist_path
    from lfd.imitation.pipeline import fill_missing

    cfg = _cfg([f"source={path}", f"robot={robot}", "side=right"])
    with tempfile.TemporaryDirectory() as out:
        analysis = lfd.imitation.analyse_skeleton(cfg, str(path), Path(out))
    t, pos = fill_missing(analysis.t, analysis.positions)
    if robot == "wam4" or not wrist_options:
        return lfd.imitation.retarget(cfg, analysis)
    return t, retarget_wrist_path(pos[:, 0], pos[:, 1], pos[:, 2], robot=robot, **wrist_options)


def part_choices(root: Path, split: str) -> None:
    """How the defaults were chosen: the Sawyer's tool error by reach fraction, and the DMP vs reference and
    time scale by basis functions per second on the KIMORE recordings of the split."""
    from lfd.dmp import DMP
    from lfd.human.retarget import time_scale
    from lfd.robots import load_robot

    files = skeleton_files(root, split)
    print(f"\n## Sawyer: max tool error (m) / scale by reach_fraction ({split} split, m07 and KIMORE)\n")
    fractions = (None, 0.9, 0.8, 0.7)
    print("| file | " + " | ".join("unbounded" if f is None else str(f) for f in fractions) + " |")
    print("|---|" + "---:|" * len(fractions))
    for path in (f for f in files if f.name.startswith("m07") or "Exercise" in f.name):
        cells = []
        for f in fractions:
            options = {"within_reach": False} if f is None else {"reach_fraction": f}
            _, rt = _retargeted(path, "sawyer", **options)
            cells.append(f"{rt.error.max():.2f} / {rt.scale:.2f}")
        print(f"| {path.name} | " + " | ".join(cells) + " |")
    print(f"\n## DMP vs reference (rad) / time scale by basis functions per second ({split} split, KIMORE)\n")
    rates = (2, 6, 8, 10, 15)
    print("| file | robot | " + " | ".join(f"{r}/s" for r in rates) + " |")
    print("|---|---|" + "---:|" * len(rates))
    for path in (f for f in files if "Exercise" in f.name):
        for name in ("wam4", "sawyer"):
            robot = load_robot(name)
            lo, hi, vmax = robot.lower.numpy(), robot.upper.numpy(), robot.velocity_limits.numpy()
            t, rt = _retargeted(path, name)
            cells = []
            for rate in rates:
                n = max(30, int(np.ceil(rate * (t[-1] - t[0]))))
                q_dmp = np.clip(np.asarray(DMP(n_basis=n).fit(t, rt.q).rollout(t)), lo, hi)
                rmse = float(np.sqrt(np.mean((q_dmp - rt.q) ** 2)))
                cells.append(f"{rmse:.3f} / x{time_scale(t, q_dmp, vmax)[1]:.1f}")
            print(f"| {path.name} | {name} | " + " | ".join(cells) + " |")


def _demo():
    from lfd.dmp import DMP
    from lfd.robots import load_robot

    robot = load_robot("wam4")
    t = np.linspace(0.0, 2.0, 200)
    s = t / t[-1]
    q = robot.home.numpy() + np.outer(10 * s**3 - 15 * s**4 + 6 * s**5, [0.4, 0.3, 0.2, 0.8])
    return robot, DMP(n_basis=20).fit(t, q), q


def part_refinement(seeds: int) -> None:
    from lfd.imitation.refine import refine_skill

    robot, dmp, q = _demo()
    tool = robot.fk(torch.from_numpy(q))[:, :3, 3].numpy()
    print(
        f"\n## Refinement of a WAM reach, {seeds} seeds (targets 10 cm from the end, via points 5 cm off the middle)\n"
    )
    print("| task | method | start | converged | median rollouts | max rollouts | median shape RMSE (rad) |")
    print("|---|---|---|---:|---:|---:|---:|")
    for task in ("reach", "via_point"):
        for method in ("power", "pibb", "cmaes"):
            for init in ("demo", "ik") if task == "reach" else ("demo",):
                results = []
                for seed in range(seeds):
                    rng = np.random.default_rng(100 + seed)
                    direction = rng.normal(size=3)
                    direction /= np.linalg.norm(direction)
                    if task == "reach":
                        target, t_via = tool[-1] + 0.1 * direction, None
                    else:
                        target, t_via = tool[100] + 0.05 * direction, float(np.linspace(0, 2, 200)[100])
                    try:
                        options = dict(goal_init=init, t_via=t_via, seed=seed, max_rollouts=1000)
                        results.append(
                            refine_skill(robot, dmp, task=task, target=target, method=method, **options)
                        )
                    except ValueError as e:  # out of reach
                        print(f"  seed {seed}: {e}", file=sys.stderr)
                ok = [r for r in results if r.converged]
                rollouts = [r.rollouts for r in ok]
                print(
                    f"| {task} | {method} | {init} | {len(ok)}/{len(results)} | "
                    f"{statistics.median(rollouts) if rollouts else float('nan'):.0f} | "
                    f"{max(rollouts) if rollouts else float('nan'):.0f} | "
                    f"{statistics.median(r.shape_rmse_rad for r in ok) if ok else float('nan'):.3f} |"
                )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--skeletons", type=Path, help="folder with ui_prmd/ and kimore/ (../shared/data/human)"
    )
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--split", choices=("report", "validation"), default="report", help="skeleton files")
    parser.add_argument("--override", action="append", default=[], help="a configs/imitate.yaml override")
    parser.add_argument("--no-refinement", action="store_true", help="skip part 2")
    parser.add_argument(
        "--choices", action="store_true", help="with --skeletons: reach fraction and bases/s tables"
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    if args.skeletons:
        part_skeletons(args.skeletons, args.split, tuple(args.override))
        if args.choices:
            part_choices(args.skeletons, args.split)
    if not args.no_refinement:
        part_refinement(args.seeds)


if __name__ == "__main__":
    main()
