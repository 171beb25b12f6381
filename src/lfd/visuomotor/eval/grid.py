"""Results of a policy grid (``python train.py -m experiment=quick +grid=policies``), collected.

Each multirun job trains one policy kind on ``data.train_objects`` training objects with one
``seed`` and, with ``evaluate=true``, scores it right after training into
``<job>/evaluate/metrics.json`` (and ``<job>/timing.json``: training wall time). This module
reads those folders, wherever the launcher ran them (sequentially, joblib, SLURM), and makes
the tables and the data-efficiency plot::

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

    A row: ``policy``, ``train_objects`` (int or None = all), ``train_episodes`` (the
    training split's size, from ``timing.json``, or None), ``seed``, the job folder, and
    per policy entry of ``evaluate/metrics.json``: ``distance_cm`` (mean final distance),
    ``success_5cm``, ``success_2cm``, ``approach_correct``, ``jerk_ratio``, ``latency_ms``
    (median per policy call), ``train_s`` (training wall time) and ``steps``.
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
        }
        timing = job / "timing.json"
        if timing.is_file():
            t = json.loads(timing.read_text(encoding="utf-8"))
            row.update(
                train_s=t.get("fit_s"), steps=t.get("global_step"), train_episodes=t.get("train_episodes")
            )
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
)


def summarise(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean and sample standard deviation over seeds per (policy, train_objects): keys
    ``policy``, ``train_objects``, ``train_episodes``, ``seeds`` (finished jobs), ``missing``
    (unfinished jobs), and ``<metric>`` / ``<metric>_std`` (std 0 for one seed)."""
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        groups[(row["policy"], row["train_objects"])].append(row)
    order = {kind: i for i, kind in enumerate(POLICIES)}  # the registry's order
    out = []
    for (policy, objects), group in sorted(
        groups.items(), key=lambda kv: (order.get(kv[0][0], 9), kv[0][0], kv[0][1] or math.inf)
    ):
        done = [r for r in group if not r.get("missing")]
        summary: dict[str, Any] = {
            "policy": policy,
            "train_objects": objects,
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
    """The grid as a Markdown table (mean ± std over seeds)."""
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
        seeds = str(s["seeds"]) + (f" (+{s['missing']} unfinished)" if s["missing"] else "")
        lines.append(
            f"| {s['policy']} | {size} | {seeds} | {_cell(s, 'distance_cm', '.2f')} | "
            f"{_cell(s, 'success_5cm', '.0f', 100)} | {_cell(s, 'success_2cm', '.0f', 100)} | "
            f"{_cell(s, 'approach_correct', '.0f', 100)} | {_cell(s, 'jerk_ratio', '.2f')} | "
            f"{_cell(s, 'latency_ms', '.1f')} | {_cell(s, 'train_s', '.1f', 1 / 60)} |"
        )
    return "\n".join(lines) + "\n"


def plot_data_efficiency(
    summaries: Sequence[dict[str, Any]], path: str | Path, metric: str = "success_5cm"
) -> Path:
    """Success (or ``metric``) against the number of training objects, one line per policy with
    the seeds' standard deviation as error bars; written atomically to ``path`` (PNG)."""
    import io

    from lfd.io.files import write_bytes_atomic

    from .plots import plt, policy_colour, policy_label

    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    policies = list(dict.fromkeys(s["policy"] for s in summaries))
    scale = 100.0 if metric.startswith(("success", "approach")) else 1.0
    for policy in policies:
        points = sorted(
            (
                s
                for s in summaries
                if s["policy"] == policy and s.get(metric) is not None and s["train_objects"]
            ),
            key=lambda s: s["train_objects"],
        )
        if not points:
            continue
        ax.errorbar(
            [s["train_objects"] for s in points],
            [scale * s[metric] for s in points],
            yerr=[scale * (s[f"{metric}_std"] or 0.0) for s in points],
            marker="o",
            capsize=3,
            color=policy_colour(policy),
            label=policy_label(policy),
        )
    ax.set_xlabel("training objects (2 demonstrations each)")
    ax.set_ylabel(metric.replace("_", " ") + (" (%)" if scale == 100.0 else ""))
    seeds = [s["seeds"] for s in summaries if s["seeds"]]
    if max(seeds, default=0) <= 1:
        ax.set_title("data efficiency (one seed per point, no error bars)")
    else:
        count = str(max(seeds)) if min(seeds) == max(seeds) else f"{min(seeds)}-{max(seeds)}"
        ax.set_title(f"data efficiency (mean ± std over {count} seeds per point)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120)
    plt.close(fig)
    write_bytes_atomic(Path(path), buffer.getvalue())
    return Path(path)
