"""The policy grid (issue 35): job folders collected into tables and a plot, and a tiny grid run as
one Hydra multirun through the submitit launcher's local executor (and joblib), each job training
then scoring its policy, collected by scripts/collect_grid.py."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from lfd.visuomotor.eval.grid import collect, markdown_table, plot_data_efficiency, summarise

ROOT = Path(__file__).resolve().parents[3]


def _job(root: Path, n: int, policy: str, objects: int, seed: int, success: float | None, fit_s=60.0) -> None:
    job = root / str(n)
    (job / ".hydra").mkdir(parents=True)
    overrides = [f"model={policy}", f"data.train_objects={objects}", f"seed={seed}"]
    (job / ".hydra" / "overrides.yaml").write_text(yaml.safe_dump(overrides))
    (job / "timing.json").write_text(
        json.dumps({"fit_s": fit_s, "global_step": 10, "train_episodes": 2 * objects})
    )
    if success is None:
        return  # a job that did not finish
    entry = {
        "episodes": 24,
        "final_distance_m": {"mean": 0.1 * (1 - success)},
        "success_5cm": success,
        "success_2cm": success / 2,
        "approach_correct": success,
        "jerk_ratio": 1.5,
        "latency_ms": {"median": 3.0},
    }
    (job / "evaluate").mkdir()
    (job / "evaluate" / "metrics.json").write_text(json.dumps({policy: entry}))


def test_collect_summarise_table_and_plot(tmp_path):
    grid = [("cnn_dmp", 50, 0, 0.8), ("cnn_dmp", 50, 1, 0.6), ("cnn_dmp", 150, 0, 0.9), ("act", 50, 0, 0.5)]
    for n, (policy, objects, seed, success) in enumerate(grid):
        _job(tmp_path, n, policy, objects, seed, success)
    _job(tmp_path, len(grid), "act", 150, 0, None)
    rows = collect(tmp_path)
    assert len(rows) == 5 and sum(bool(r.get("missing")) for r in rows) == 1
    summaries = {(s["policy"], s["train_objects"]): s for s in summarise(rows)}
    small = summaries[("cnn_dmp", 50)]
    assert small["seeds"] == 2 and small["success_5cm"] == pytest.approx(0.7)
    assert small["success_5cm_std"] == pytest.approx(statistics.stdev([0.8, 0.6]))
    assert small["distance_cm"] == pytest.approx(100 * 0.1 * 0.3) and small["train_episodes"] == 100
    assert summaries[("act", 150)]["seeds"] == 0 and summaries[("act", 150)]["missing"] == 1
    assert summaries[("act", 50)]["success_5cm_std"] == 0.0  # one seed
    # the policies in their fixed order, sizes ascending; an unfinished job is shown, not hidden
    order = [(s["policy"], s["train_objects"]) for s in summarise(rows)]
    assert order == [("cnn_dmp", 50), ("cnn_dmp", 150), ("act", 50), ("act", 150)]
    table = markdown_table(summarise(rows))
    assert "| cnn_dmp | 50 (100) | 2 | 3.00 ± 1.41 | 70 ± 14 |" in table
    assert "| act | 150 (300) | 0 (+1 unfinished) | — |" in table
    png = plot_data_efficiency(summarise(rows), tmp_path / "plot.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(FileNotFoundError, match="no multirun job folders"):
        collect(tmp_path / "plot.png.d")


def _metaworld_job(root: Path, n: int, task: str, policy: str, demos: int, seed: int, successes: int | None):
    job = root / str(n)
    (job / ".hydra").mkdir(parents=True)
    overrides = [
        "experiment=metaworld",
        f"task={task}",
        f"model={policy}",
        f"data.train_episodes={demos}",
        f"seed={seed}",
    ]
    (job / ".hydra" / "overrides.yaml").write_text(yaml.safe_dump(overrides))
    (job / "timing.json").write_text(
        json.dumps({"fit_s": 120.0, "global_step": 3000, "train_episodes": demos})
    )
    if successes is None:
        return
    entry = {
        "task": task,
        "episodes": 50,
        "successes": successes,
        "success_rate": successes / 50,
        "mean_time_to_success_s": 1.0 + seed,
        "latency_ms": 2.0,
    }
    (job / "evaluate").mkdir()
    (job / "evaluate" / "metrics.json").write_text(json.dumps({policy: entry}))


def test_metaworld_grid_is_summarised_per_task_policy_and_demonstrations(tmp_path):
    grid = [
        ("push-v3", "cnn_dmp", 10, 0, 10),
        ("push-v3", "cnn_dmp", 10, 1, 20),
        ("push-v3", "cnn_dmp", 50, 0, 30),
        ("push-v3", "act", 10, 0, 5),
        ("reach-v3", "cnn_dmp", 10, 0, 40),
        ("reach-v3", "cnn_dmp", 50, 0, None),
    ]
    for n, job in enumerate(grid):
        _metaworld_job(tmp_path, n, *job)
    rows = collect(tmp_path)
    assert {r["task"] for r in rows} == {"push-v3", "reach-v3"}
    assert sum(bool(r.get("missing")) for r in rows) == 1
    summaries = summarise(rows)
    keyed = {(s["task"], s["policy"], s["demonstrations"]): s for s in summaries}
    ten = keyed[("push-v3", "cnn_dmp", 10)]
    assert ten["seeds"] == 2 and ten["success_rate"] == pytest.approx(0.3)
    assert ten["success_rate_std"] == pytest.approx(statistics.stdev([0.2, 0.4]))
    assert ten["time_to_success_s"] == pytest.approx(1.5) and ten["train_objects"] is None
    assert keyed[("reach-v3", "cnn_dmp", 50)]["missing"] == 1
    # tasks in order, then the registry's policy order, then sizes ascending
    assert [(s["task"], s["policy"], s["demonstrations"]) for s in summaries] == [
        ("push-v3", "cnn_dmp", 10), ("push-v3", "cnn_dmp", 50), ("push-v3", "act", 10),
        ("reach-v3", "cnn_dmp", 10), ("reach-v3", "cnn_dmp", 50),
    ]  # fmt: skip
    table = markdown_table(summaries)
    assert "| push-v3 | cnn_dmp | 10 | 2 | 30 ± 14 | 1.50 ± 0.71 | 2.0 | 2.0 |" in table
    assert "| reach-v3 | cnn_dmp | 50 | 0 (+1 unfinished) | — |" in table
    png = plot_data_efficiency(summaries, tmp_path / "plot.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


TINY = [
    "data.n_train_objects=2",
    "data.n_train_placements=3",
    "data.val_fraction=0.34",
    "data.n_test_objects=0",
    "data.n_test_placements=0",
    "data.n_val_objects=1",
    "data.n_val_object_placements=2",
    "data.image_size=32",
    "data.n_steps=30",
    "data.n_basis=8",
    "data.batch_size=2",
    "data.progress=false",
    "data.num_gen_workers=1",
    "data.name=grid",
    "data.seed=42",  # one dataset for every job; seed varies the training (as configs/grid/policies.yaml)
    "model.channels=[4,4,4,8]",
]


def _run(args: list[str], tmp_path: Path, timeout: int = 600) -> subprocess.CompletedProcess:
    # One torch thread per process: the launchers run jobs side by side on CI's 2 cores, and two
    # jobs with two intra-op threads each once stalled in a backward pass for minutes there.
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, cwd=ROOT, timeout=timeout, env=env
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-4000:]
    return done


def _grid(tmp_path: Path, launcher: str | None, models: str, sizes: str) -> Path:
    """A tiny grid through ``launcher`` (None: Hydra's basic launcher, jobs one after another)."""
    common = [f"paths.root_dir={tmp_path}", *TINY]
    # the dataset first, so that parallel jobs only read it (configs/grid/policies.yaml says so)
    _run([str(ROOT / "scripts" / "generate_data.py"), *common], tmp_path)
    sweep = tmp_path / "sweep"
    _run(
        [
            str(ROOT / "train.py"),
            "-m",
            *([] if launcher is None else [f"hydra/launcher={launcher}"]),
            f"hydra.sweep.dir={sweep}",
            f"model={models}",
            f"data.train_objects={sizes}",
            "seed=0",
            "evaluate=true",
            "eval.split=val",
            "eval.n_gifs=0",
            "++trainer.max_steps=4",
            "++trainer.limit_val_batches=1",
            "++trainer.log_every_n_steps=1",
            *common,
        ],
        tmp_path,
    )
    return sweep


@pytest.mark.parametrize("launcher", [None, pytest.param("joblib", marks=pytest.mark.slow)])
def test_tiny_grid_as_one_multirun(tmp_path, launcher):
    sweep = _grid(tmp_path, launcher, "cnn_dmp,velocity", "1,2")
    out = _run([str(ROOT / "scripts" / "collect_grid.py"), str(sweep)], tmp_path).stdout
    rows = json.loads((sweep / "grid.json").read_text())["jobs"]
    assert sorted((r["policy"], r["train_objects"]) for r in rows) == [
        ("cnn_dmp", 1), ("cnn_dmp", 2), ("velocity", 1), ("velocity", 2)
    ]  # fmt: skip
    for row in rows:  # every job trained, then scored its own checkpoint on the 2 validation episodes
        assert not row.get("missing") and row["episodes"] == 2 and row["steps"] == 4
        metrics = json.loads((Path(row["job"]) / "evaluate" / "metrics.json").read_text())
        assert list(metrics) == [row["policy"]]
    # train_objects=1 trained on that object's 2 training placements, 2 on all 4
    assert {r["train_objects"]: r["train_episodes"] for r in rows if r["policy"] == "velocity"} == {
        1: 2,
        2: 4,
    }
    assert "| velocity | 2 (4) | 1 |" in out and (sweep / "data_efficiency.png").is_file()


def test_submitit_local_executor_runs_a_grid_job(tmp_path):
    # The SLURM launcher's code path with submitit's local executor, one job (several jobs side by
    # side in one CI run: one never started, another stalled; the grid's parallel path is joblib's).
    sweep = _grid(tmp_path, "submitit_local", "velocity", "2")
    (row,) = collect(sweep)
    assert row["policy"] == "velocity" and row["train_episodes"] == 4 and not row.get("missing")
    assert (sweep / ".submitit").is_dir()  # it went through submitit


@pytest.mark.parametrize("grid", [[], ["+grid=policies"]], ids=["experiment=quick", "+grid=policies"])
def test_every_policy_gets_the_same_budget(grid):
    # Issue 35's fairness: the same optimiser steps x batch size for all four kinds, both in the
    # main job's experiment=quick and in the comparison grid (whose documented tables were run at
    # 4000 steps of batch 32; experiment=quick runs 3200 since 2026-12-05, docs/evaluation.md).
    from hydra import compose, initialize_config_dir

    budgets = {}
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        for kind in ("cnn_dmp", "velocity", "act", "diffusion"):
            cfg = compose("train", overrides=["experiment=quick", f"model={kind}", *grid])
            budgets[kind] = (cfg.trainer.max_steps, cfg.data.batch_size)
    assert len(set(budgets.values())) == 1, budgets
    assert budgets["act"] == ((4000, 32) if grid else (3200, 32))


def test_the_grid_keeps_its_documented_dataset():
    """+grid=policies generates the dataset its documented tables were made on (classic sizes,
    300 objects, inside-size validation), whatever experiment=quick trains on."""
    from hydra import compose, initialize_config_dir

    from lfd.visuomotor.data import GeneratorConfig

    keys = ("sizes", "n_train_objects", "val_sizes", "lighting", "name")
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        grid = compose("train", overrides=["experiment=quick", "+grid=policies"]).data
        quick = compose("train", overrides=["experiment=quick"]).data
    assert [grid[k] for k in keys] == ["classic", 300, "inside", "fixed", "quick96o300d_s42"]
    assert [quick[k] for k in keys[:4]] == ["wide_edges", 600, "outside", "random"]
    assert "sizes" not in GeneratorConfig(sizes=grid.sizes).to_dict()  # the old datasets' hash
