"""Report of the Sawyer protocol (:mod:`lfd.model_reaching.protocol`): Markdown tables, CSV files, plots.

Pure functions of the protocol's metrics dictionary (:meth:`SawyerProtocol.evaluate`), so a
saved ``metrics.json`` plus the private traces can be re-tabulated without re-running it.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from lfd.io.files import json_bytes, write_bytes_atomic
from lfd.model_reaching.forward import format_error_table

__all__ = ["ORIGINAL_EPISODES", "SCENARIOS", "protocol_tables", "reach_table", "write_report"]

SCENARIOS = ("models", "demo")
SCENARIO_LABELS = {"models": "models", "demo": "demo only"}
#: Original episodes to convergence per goal (thesis ch. 5): models vs demonstration only.
ORIGINAL_EPISODES = {
    "cube": {"models": (18, 17, 14, 6, 6), "demo": (29, 12, 19, 13, 9)},
    "cup": {"models": (14, 18, 17, 8, 8), "demo": (17, 6, 15, 12, 13)},
}


def protocol_tables(metrics: Mapping[str, Any], goals: np.ndarray) -> str:
    """The Markdown tables of ``protocol.md``: forward-model error, PoWER episodes per goal
    (``goals`` (G, 3) m), the models' closed-loop reaches and the original's episodes."""
    settings = metrics["settings"]
    tasks = list(metrics["tasks"])
    parts = []
    if "forward_error_mm" in metrics:
        parts.append("## Forward model\n\n" + format_error_table(metrics["forward_error_mm"]))
    head = (
        "| goal | position (m) | reach test | "
        + " | ".join(f"{t}: {SCENARIO_LABELS[s]}" for t in tasks for s in SCENARIOS)
        + " |"
    )
    lines = [head, "|" + "---|" * (3 + 2 * len(tasks))]
    for i, goal in enumerate(goals):
        cells = []
        for task in tasks:
            entry = metrics["tasks"][task]["goals"][i]
            for s in SCENARIOS:
                cells.append(episodes_cell(entry["power"][s]) if "power" in entry else "-")
        reasons = {t: metrics["tasks"][t]["goals"][i]["reach_test"]["reason"] for t in tasks}
        reason = (
            reasons[tasks[0]]
            if len(set(reasons.values())) == 1
            else "; ".join(f"{t}: {r}" for t, r in reasons.items())
        )
        lines.append(
            f"| {i + 1} | ({goal[0]:.3f}, {goal[1]:.3f}, {goal[2]:.3f}) | {reason} | "
            + " | ".join(cells)
            + " |"
        )
    total_cells = [
        f"{metrics['totals'][t][s]['episodes']:.1f} "
        f"({metrics['totals'][t][s]['converged']}/{metrics['totals'][t][s]['runs']})"
        for t in tasks
        for s in SCENARIOS
    ]
    lines.append("| total | | reachable goals | " + " | ".join(total_cells) + " |")
    parts.append(
        f"## Episodes (PoWER iterations) to convergence (end effector within {settings['power']['tol'] * 100:.0f} cm), "
        f"mean over {settings['n_seeds']} seeds (converged runs / runs)\n\n" + "\n".join(lines)
    )
    parts.append(reach_table(metrics, tasks))
    parts.append(original_table())
    return "\n\n".join(parts) + "\n"


def reach_table(metrics: Mapping[str, Any], tasks: Sequence[str]) -> str:
    """The closed-loop reaches with the models, one row per task x reachable goal."""
    settings = metrics["settings"]
    lines = [
        "| task | goal | steps | reached | true final error (cm) | estimated error (cm) | orientation error (deg) "
        "| PoWER start error, models / demo (cm) |",
        "|---|---|---:|---|---:|---:|---:|---|",
    ]
    for task in tasks:
        for i, entry in enumerate(metrics["tasks"][task]["goals"]):
            if "reach" not in entry:
                continue
            r, p = entry["reach"], entry["power"]
            lines.append(
                f"| {task} | {i + 1} | {r['steps']} | {'yes' if r['reached'] else 'no'} | "
                f"{100 * r['final_error_m']:.2f} | "
                f"{100 * r['estimated_error_m']:.2f} | {r['orientation_error_deg']:.1f} | "
                f"{100 * p['models']['initial_error_m']:.2f} / {100 * p['demo']['initial_error_m']:.2f} |"
            )
    return (
        f"## Closed-loop reaches with the models ({settings['simulator']}, dt {settings['dt']} s, stop at "
        "an estimated error "
        f"< {settings['threshold_m'] * 100:.1f} cm or {settings['max_steps']} steps)\n\n" + "\n".join(lines)
    )


def write_report(out_dir: Path, metrics: dict[str, Any], goals: np.ndarray) -> None:
    """``protocol.md``, ``protocol.csv``, ``reach.csv``, the plots and ``metrics.json`` in ``out_dir``."""
    write_bytes_atomic(
        out_dir / "protocol.md",
        ("# Sawyer forward/inverse models + DMP + PoWER\n\n" + metrics["tables"]).encode(),
    )
    write_bytes_atomic(out_dir / "protocol.csv", protocol_csv(metrics).encode())
    write_bytes_atomic(out_dir / "reach.csv", reach_csv(metrics).encode())
    for task, data in metrics["tasks"].items():
        plot_paths(out_dir / f"paths_{task}.png", task, goals, data)
        plot_power(out_dir / f"power_{task}.png", task, data)
    write_bytes_atomic(out_dir / "metrics.json", json_bytes(public(metrics)))


def episodes_cell(runs: Mapping[str, Any]) -> str:
    return f"{runs['mean_iterations']:.1f} ({sum(runs['converged'])}/{len(runs['converged'])})"


def original_table() -> str:
    lines = [
        "| goal | "
        + " | ".join(f"{t}: {SCENARIO_LABELS[s]}" for t in ORIGINAL_EPISODES for s in SCENARIOS)
        + " |",
        "|---|" + "---:|" * 4,
    ]
    for i in range(len(next(iter(ORIGINAL_EPISODES.values()))["models"])):
        lines.append(
            f"| {i + 1} | "
            + " | ".join(str(ORIGINAL_EPISODES[t][s][i]) for t in ORIGINAL_EPISODES for s in SCENARIOS)
            + " |"
        )
    lines.append(
        "| total | "
        + " | ".join(str(sum(ORIGINAL_EPISODES[t][s])) for t in ORIGINAL_EPISODES for s in SCENARIOS)
        + " |"
    )
    return "## Original (thesis ch. 5), episodes to convergence\n\n" + "\n".join(lines)


def public(value: Any) -> Any:
    """``value`` without keys starting with ``_`` and with numpy values as JSON types."""
    if isinstance(value, Mapping):
        return {k: public(v) for k, v in value.items() if not str(k).startswith("_")}
    if isinstance(value, (list, tuple)):
        return [public(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    return value


def _csv(rows: list[list[Any]]) -> str:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerows(rows)
    return buffer.getvalue()


def protocol_csv(metrics: Mapping[str, Any]) -> str:
    rows: list[list[Any]] = [
        [
            "task",
            "goal",
            "x",
            "y",
            "z",
            "reach_test",
            "scenario",
            "seed",
            "iterations",
            "rollouts",
            "converged",
            "final_error_m",
            "pybullet_final_error_m",
        ]
    ]
    for task, data in metrics["tasks"].items():
        for i, entry in enumerate(data["goals"]):
            base = [task, i + 1, *entry["goal"], entry["reach_test"]["reason"]]
            if "power" not in entry:
                rows.append(base + ["", "", "", "", "", "", ""])
                continue
            for s in SCENARIOS:
                runs = entry["power"][s]
                for seed, (it, ro, ok, err) in enumerate(
                    zip(runs["iterations"], runs["rollouts"], runs["converged"], runs["final_error_m"])
                ):
                    replay = runs.get("pybullet_final_error_m", "") if seed == 0 else ""
                    rows.append(
                        base
                        + [s, seed, it, ro, ok, f"{err:.6f}", replay if replay == "" else f"{replay:.6f}"]
                    )
    return _csv(rows)


def reach_csv(metrics: Mapping[str, Any]) -> str:
    keys = ["steps", "reached", "final_error_m", "estimated_error_m", "orientation_error_deg"]
    rows: list[list[Any]] = [["task", "goal", *keys]]
    for task, data in metrics["tasks"].items():
        rows += [
            [task, i + 1, *(e["reach"][k] for k in keys)] for i, e in enumerate(data["goals"]) if "reach" in e
        ]
    return _csv(rows)


def plot_paths(path: Path, task: str, goals: np.ndarray, data: Mapping[str, Any]) -> None:
    """Top (x-y) and side (x-z) views of the demonstration, the models' reaches and the
    refined trajectories (seed 0) of one task."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.8))
    demo_x = data["_demo_path"]
    colours = plt.get_cmap("tab10")
    for ax, (a, b) in zip(axes, ((0, 1), (0, 2))):
        ax.plot(demo_x[:, a], demo_x[:, b], "k-", lw=2, label="demonstration")
        for i, entry in enumerate(data["goals"]):
            c = colours(i)
            if "reach" in entry:
                trace = data["_traces"][i]
                ax.plot(
                    trace.x[:, a],
                    trace.x[:, b],
                    "-",
                    color=c,
                    lw=1.5,
                    label=f"goal {i + 1}: models" if a == 0 and b == 1 else None,
                )
                for s, style in (("models", "--"), ("demo", ":")):
                    x = entry["power"][s]["_path"]
                    ax.plot(x[:, a], x[:, b], style, color=c, lw=1.2)
                ax.plot(goals[i, a], goals[i, b], "o", color=c, ms=8, mfc="none")
            else:
                ax.plot(
                    goals[i, a],
                    goals[i, b],
                    "x",
                    color="r",
                    ms=10,
                    mew=2,
                    label=f"goal {i + 1}: unreachable" if b == 1 else None,
                )
        ax.set_xlabel(f"{'xyz'[a]} (m)")
        ax.set_ylabel(f"{'xyz'[b]} (m)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].set_title(
        "top view: solid models' reach, dashed PoWER from it, dotted PoWER from the demo", fontsize=8
    )
    axes[1].set_title("side view", fontsize=9)
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(f"Sawyer, task '{task}': end-effector paths", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_power(path: Path, task: str, data: Mapping[str, Any]) -> None:
    """PoWER policy error (cm) per iteration (seed 0), models vs demonstration only."""
    fig, ax = plt.subplots(figsize=(7, 4))
    colours = plt.get_cmap("tab10")
    for i, entry in enumerate(data["goals"]):
        if "power" not in entry:
            continue
        for s, style in (("models", "-"), ("demo", ":")):
            curve = 100 * np.asarray(entry["power"][s]["_error_curve"])
            ax.plot(
                np.arange(len(curve)),
                curve,
                style,
                color=colours(i),
                label=f"goal {i + 1}, {SCENARIO_LABELS[s]}",
            )
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_yscale("log")
    ax.set_xlabel("PoWER iteration (episode)")
    ax.set_ylabel("end-effector distance to goal (cm)")
    ax.set_title(f"Sawyer, task '{task}': PoWER refinement (seed 0)", fontsize=10)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
