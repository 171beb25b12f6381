"""Results of a policy grid, collected: the reaching grid (``python train.py -m experiment=quick
+grid=policies``) and the Meta-World one (``python train.py -m experiment=metaworld +grid=mt10``).

Each multirun job trains one policy kind (on ``data.train_objects`` training objects, or on a
Meta-World task's first ``data.train_episodes`` demonstrations) with one ``seed`` and, with
``evaluate=true``, scores it right after training into ``<job>/evaluate/metrics.json`` (and
``<job>/timing.json``: training wall time and training-set size). This module reads those
folders, wherever the launcher ran them (sequentially, joblib, SLURM), and makes the tables and
the data-efficiency plot::

    >>> rows = collect("outputs/train/multirun/2026-12-05_10-00-00")   # doctest: +SKIP
    >>> print(markdown_table(summarise(rows)))                        # doctest: +SKIP
    >>> plot_data_efficiency(summarise(rows), "data_efficiency.png")   # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
import statistics
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from lfd.io.files import YamlError, read_yaml
from lfd.visuomotor.policies import POLICIES

__all__ = ["collect", "markdown_table", "plot_data_efficiency", "summarise"]


def _overrides(job: Path) -> dict[str, str]:
    """``key -> value`` of the job's Hydra overrides (``.hydra/overrides.yaml``)."""
    items = read_yaml(job / ".hydra" / "overrides.yaml", what="a Hydra overrides file") or []
    if not isinstance(items, list):
        where = job / ".hydra" / "overrides.yaml"
        raise YamlError(f"{where}: expected a list of overrides, got {type(items).__name__}")
    out = {}
    for item in items:
        key, _, value = str(item).lstrip("+~").partition("=")
        out[key] = value
    return out


def collect(sweep_dir: str | Path) -> list[dict[str, Any]]:
    """One row per finished job under ``sweep_dir`` (folders holding ``.hydra/overrides.yaml``).

    A row: ``policy``, ``task`` (a Meta-World job's task, None for reaching),
    ``train_objects`` (int or None = all), ``train_episodes`` (the training split's size in
    demonstrations, from ``timing.json``, or None), ``demonstrations`` (``data.train_episodes``,
    else ``train_episodes``: a Meta-World job's size), ``seed``, the job folder, ``train_s``
    (training wall time), ``steps``, and the policy's entry of ``evaluate/metrics.json``:
    for reaching ``distance_cm`` (mean final distance), ``success_5cm``, ``success_2cm``,
    ``approach_correct``, ``jerk_ratio`` and ``latency_ms`` (median per policy call); for
    Meta-World ``success_rate``, ``successes``, ``time_to_success_s`` (mean over the solved
    episodes) and ``latency_ms``; ``episodes`` for both.
    Jobs without ``evaluate/metrics.json`` (failed, still running) are listed with
    ``missing`` set and no metrics.

    Raises:
        FileNotFoundError: ``sweep_dir`` holds no job folder.
        lfd.io.files.YamlError: an ``overrides.yaml`` that is not a list, too big, or uses
            aliases or duplicate keys (one line naming the file).
    """
    sweep_dir = Path(sweep_dir)
    jobs = sorted(p.parent.parent for p in sweep_dir.glob("**/.hydra/overrides.yaml"))
    if not jobs:
        raise FileNotFoundError(f"{sweep_dir}: no multirun job folders (with .hydra/overrides.yaml) under it")
    rows = []
    for job in jobs:
        o = _overrides(job)
        policy = o.get("model", "cnn_dmp")
        row: dict[str, Any] = {
            "job": str(job),
            "policy": policy,
            "train_objects": None
            if o.get("data.train_objects") in (None, "null")
            else int(o["data.train_objects"]),
            "seed": int(o["seed"]) if "seed" in o else None,
            "task": o.get("task"),
        }
        timing = job / "timing.json"
        if timing.is_file():
            t = json.loads(timing.read_text(encoding="utf-8"))
            row.update(
                train_s=t.get("fit_s"), steps=t.get("global_step"), train_episodes=t.get("train_episodes")
            )
        # a Meta-World job's size (its task may come from metrics.json below, when not overridden)
        cap = o.get("data.train_episodes")
        row["demonstrations"] = int(cap) if cap not in (None, "null") else row.get("train_episodes")
        metrics = job / "evaluate" / "metrics.json"
        if not metrics.is_file():
            row["missing"] = True
            rows.append(row)
            continue
        entry = json.loads(metrics.read_text(encoding="utf-8")).get(policy)
        if entry is None:
            row["missing"] = True
            rows.append(row)
            continue
        if "success_rate" in entry:  # a Meta-World job
            row.update(
                task=entry.get("task", row["task"]),
                success_rate=entry["success_rate"],
                successes=entry["successes"],
                time_to_success_s=entry.get("mean_time_to_success_s"),
                latency_ms=entry.get("latency_ms"),
                episodes=entry["episodes"],
            )
        else:
            row.update(
                distance_cm=100.0 * entry["final_distance_m"]["mean"],
                success_5cm=entry["success_5cm"],
                success_2cm=entry["success_2cm"],
                approach_correct=entry["approach_correct"],
                jerk_ratio=entry.get("jerk_ratio"),
                latency_ms=entry["latency_ms"]["median"],
                episodes=entry["episodes"],
            )
        rows.append(row)
    return rows


_METRICS = (
    "distance_cm",
    "success_5cm",
    "success_2cm",
    "approach_correct",
    "jerk_ratio",
    "latency_ms",
    "train_s",
    "success_rate",
    "time_to_success_s",
)


def _size(row: dict[str, Any]) -> int | None:
    """A row's training-set size: demonstrations for Meta-World, training objects for reaching."""
    return row.get("demonstrations") if row.get("task") is not None else row.get("train_objects")


def summarise(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean and sample standard deviation over seeds per (task, policy, size), the size being
    ``train_objects`` for reaching and ``demonstrations`` for Meta-World: keys ``task``,
    ``policy``, ``train_objects``, ``demonstrations``, ``train_episodes``, ``seeds`` (finished
    jobs), ``missing`` (unfinished jobs), and ``<metric>`` / ``<metric>_std`` (std 0 for one
    seed)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        groups[(row.get("task"), row["policy"], _size(row))].append(row)
    order = {kind: i for i, kind in enumerate(POLICIES)}  # the registry's order
    out = []
    for (task, policy, size), group in sorted(
        groups.items(),
        key=lambda kv: (kv[0][0] or "", order.get(kv[0][1], 9), kv[0][1], kv[0][2] or math.inf),
    ):
        done = [r for r in group if not r.get("missing")]
        summary: dict[str, Any] = {
            "task": task,
            "policy": policy,
            "train_objects": None if task is not None else size,
            "demonstrations": size if task is not None else None,
            "train_episodes": next((r.get("train_episodes") for r in group if r.get("train_episodes")), None),
            "seeds": len(done),
            "missing": len(group) - len(done),
        }
        for key in _METRICS:
            values = [float(r[key]) for r in done if r.get(key) is not None]
            summary[key] = statistics.fmean(values) if values else None
            summary[f"{key}_std"] = statistics.stdev(values) if len(values) > 1 else (0.0 if values else None)
        out.append(summary)
    return out


def _cell(summary: dict, key: str, fmt: str, scale: float = 1.0) -> str:
    mean, std = summary.get(key), summary.get(f"{key}_std")
    if mean is None:
        return "—"
    text = format(scale * mean, fmt)
    return text if not std else f"{text} ± {format(scale * std, fmt)}"


def markdown_table(summaries: Sequence[dict[str, Any]]) -> str:
    """The grid as a Markdown table (mean ± std over seeds): the reaching columns, or the
    Meta-World ones when the summaries have a task."""
    if any(s.get("task") is not None for s in summaries):
        return _metaworld_table(summaries)
    lines = [
        "| policy | training objects (episodes) | seeds | mean distance (cm) | success < 5 cm (%) | "
        "success < 2 cm (%) | correct approach (%) | jerk / demonstration | inference per call (ms) | "
        "training (min) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in summaries:
        size = "all" if s["train_objects"] is None else str(s["train_objects"])
        if s.get("train_episodes"):
            size += f" ({s['train_episodes']})"
        lines.append(
            f"| {s['policy']} | {size} | {_seeds(s)} | {_cell(s, 'distance_cm', '.2f')} | "
            f"{_cell(s, 'success_5cm', '.0f', 100)} | {_cell(s, 'success_2cm', '.0f', 100)} | "
            f"{_cell(s, 'approach_correct', '.0f', 100)} | {_cell(s, 'jerk_ratio', '.2f')} | "
            f"{_cell(s, 'latency_ms', '.1f')} | {_cell(s, 'train_s', '.1f', 1 / 60)} |"
        )
    return "\n".join(lines) + "\n"


def _seeds(s: dict[str, Any]) -> str:
    return str(s["seeds"]) + (f" (+{s['missing']} unfinished)" if s["missing"] else "")


def _metaworld_table(summaries: Sequence[dict[str, Any]]) -> str:
    lines = [
        "| task | policy | demonstrations | seeds | success (%) | time to success (s) | "
        "inference per call (ms) | training (min) |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s in summaries:
        size = "—" if s["demonstrations"] is None else str(s["demonstrations"])
        lines.append(
            f"| {s['task']} | {s['policy']} | {size} | {_seeds(s)} | {_cell(s, 'success_rate', '.0f', 100)} | "
            f"{_cell(s, 'time_to_success_s', '.2f')} | {_cell(s, 'latency_ms', '.1f')} | "
            f"{_cell(s, 'train_s', '.1f', 1 / 60)} |"
        )
    return "\n".join(lines) + "\n"


def plot_data_efficiency(
    summaries: Sequence[dict[str, Any]], path: str | Path, metric: str | None = None
) -> Path:
    """Success (or ``metric``; default ``success_rate`` for Meta-World, ``success_5cm`` for
    reaching) against the training-set size (demonstrations, or training objects), one line per
    policy with the seeds' standard deviation as error bars, one panel per Meta-World task (and
    one for their mean where there are several); written atomically to ``path`` (PNG)."""
    import io

    from lfd.io.files import write_bytes_atomic

    from .plots import plt, policy_colour, policy_label

    metaworld = any(s.get("task") is not None for s in summaries)
    metric = metric or ("success_rate" if metaworld else "success_5cm")
    size_key = "demonstrations" if metaworld else "train_objects"
    panels: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for s in summaries:
        panels[s.get("task") or ""].append(s)
    if len(panels) > 1:
        panels["mean over tasks"] = _task_means(summaries, metric, size_key, len(panels))
    cols = min(len(panels), 4)
    rows = math.ceil(len(panels) / cols)
    width = 4.2 if cols > 1 else 5.5
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, 3.6 * rows), squeeze=False)
    scale = 100.0 if metric.startswith(("success", "approach")) else 1.0
    for ax, (title, group) in zip(axes.flat, panels.items(), strict=False):
        for policy in dict.fromkeys(s["policy"] for s in group):
            points = sorted(
                (s for s in group if s["policy"] == policy and s.get(metric) is not None and s[size_key]),
                key=lambda s: s[size_key],
            )
            if not points:
                continue
            ax.errorbar(
                [s[size_key] for s in points],
                [scale * s[metric] for s in points],
                yerr=[scale * (s.get(f"{metric}_std") or 0.0) for s in points],
                marker="o",
                capsize=3,
                color=policy_colour(policy),
                label=policy_label(policy),
            )
        ax.set_xlabel("demonstrations" if metaworld else "training objects (2 demonstrations each)")
        ax.set_ylabel(metric.replace("_", " ") + (" (%)" if scale == 100.0 else ""))
        if scale == 100.0:
            ax.set_ylim(-3, 103)
        if title:
            ax.set_title(title, fontsize=9)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(panels) :]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=8)
    seeds = [s["seeds"] for s in summaries if s["seeds"]]
    if max(seeds, default=0) <= 1:
        what = "data efficiency (one seed per point, no error bars)"
    else:
        count = str(max(seeds)) if min(seeds) == max(seeds) else f"{min(seeds)}-{max(seeds)}"
        what = f"data efficiency (mean ± std over {count} seeds per point)"
    if len(panels) > 1:
        fig.suptitle(what, fontsize=10)
    else:
        axes.flat[0].set_title(" ".join(filter(None, [next(iter(panels)), what])), fontsize=9)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120)
    plt.close(fig)
    write_bytes_atomic(Path(path), buffer.getvalue())
    return Path(path)


def _task_means(
    summaries: Sequence[dict[str, Any]], metric: str, size_key: str, n_tasks: int
) -> list[dict[str, Any]]:
    """Per (policy, size), the mean of ``metric`` over the tasks, where every one of the
    ``n_tasks`` tasks has it (a partial mean would mix tasks of different difficulty)."""
    groups: dict[tuple, list[float]] = defaultdict(list)
    for s in summaries:
        if s.get(metric) is not None:
            groups[(s["policy"], s[size_key])].append(float(s[metric]))
    return [
        {"policy": policy, size_key: size, metric: statistics.fmean(values), "seeds": 1}
        for (policy, size), values in groups.items()
        if len(values) == n_tasks
    ]
