"""lfd.cli: the configs the commands find, the short ``--help`` of each command, the experiment removal
of lfd-train, the results table of lfd-evaluate, Lightning's tips filtered, the declared console scripts."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest

import lfd.cli
from lfd.cli import config_file, configs_dir, quiet
from lfd.cli.evaluate import results_table
from lfd.cli.train import without_experiment_removal

ROOT = Path(__file__).resolve().parents[2]
#: Console command -> its module's cli function, as pyproject.toml declares them.
COMMANDS = {
    "lfd-train": "lfd.cli.train:cli",
    "lfd-evaluate": "lfd.cli.evaluate:cli",
    "lfd-imitate": "lfd.cli.imitate:cli",
    "lfd-teach": "lfd.cli.teach:cli",
    "lfd-analyze-arm": "lfd.cli.analyze_arm:cli",
    "lfd-export": "lfd.cli.export_dataset:cli",
    "lfd-samples": "lfd.samples:main",
    "lfd-install-mediapipe": "lfd.cli.install_mediapipe:cli",
}
#: The repository's wrappers of the commands.
WRAPPERS = {
    "lfd-train": "train.py",
    "lfd-evaluate": "evaluate.py",
    "lfd-imitate": "scripts/imitate.py",
    "lfd-teach": "scripts/teach.py",
    "lfd-analyze-arm": "scripts/analyze_arm.py",
    "lfd-export": "scripts/export_dataset.py",
}


def test_pyproject_declares_every_command():
    tomllib = pytest.importorskip("tomllib", reason="tomllib: Python 3.11+")
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts == COMMANDS


def test_a_checkout_uses_its_own_configs():
    assert configs_dir() == ROOT / "configs"


def test_outside_a_checkout_the_packaged_configs_are_used(tmp_path, monkeypatch):
    package = tmp_path / "site-packages" / "lfd"
    (package / "configs").mkdir(parents=True)
    monkeypatch.setattr(lfd.cli, "PACKAGE", package)
    with pytest.raises(FileNotFoundError, match="no train.yaml in .*configs"):
        configs_dir()
    (package / "configs" / "train.yaml").write_text("seed: 1\n")
    assert configs_dir() == package / "configs"


def test_config_file_falls_back_to_the_configs_only_for_missing_configs_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert config_file("configs/teach/boxes.yaml") == ROOT / "configs" / "teach" / "boxes.yaml"
    assert config_file("configs/teach/none.yaml") == Path("configs/teach/none.yaml")  # the error names it
    assert config_file("scene.yaml") == Path("scene.yaml")
    (tmp_path / "configs" / "teach").mkdir(parents=True)
    (tmp_path / "configs" / "teach" / "boxes.yaml").write_text("objects: []\n")
    assert config_file("configs/teach/boxes.yaml") == Path("configs/teach/boxes.yaml")  # the user's own


@pytest.mark.parametrize("command", sorted(WRAPPERS))
def test_help_is_short_and_names_the_command(command):
    run = subprocess.run(
        [sys.executable, str(ROOT / WRAPPERS[command]), "--help"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr[-2000:]
    lines = run.stdout.strip().splitlines()
    assert lines[0].startswith(f"{command} (python {WRAPPERS[command]}): "), lines[0]
    assert 3 <= len(lines) <= 10, run.stdout
    assert all(len(line) <= 120 for line in lines), run.stdout
    assert "Powered by Hydra" not in run.stdout


@pytest.mark.parametrize(
    ("argv", "kept"),
    [
        (["~experiment", "model=velocity"], ["model=velocity"]),
        (["~experiment=quick"], []),
        (["experiment=null", "seed=1"], ["seed=1"]),
        (["experiment=quick", "data.experiment=x"], ["experiment=quick", "data.experiment=x"]),
    ],
)
def test_train_drops_only_the_removal_of_the_experiment(argv, kept):
    assert without_experiment_removal(argv) == kept


def test_results_table_one_row_per_kind_with_its_main_metrics():
    metrics = {
        "cnn_dmp": {
            "final_distance_m": {"mean": 0.0178},
            "success_5cm": 0.9583,
            "approach_correct": 1.0,
            "episodes": 24,
        },
        "velocity": {"final_distance_m": 0.1, "episodes": 24},
        "notes": "not a kind",
    }
    header, rule, *rows = results_table(metrics)
    assert header.split() == ["policy", "episodes", "final", "distance", "success", "correct", "approach"]
    assert set(rule.replace(" ", "")) == {"-"}
    assert rows[0].split() == ["cnn_dmp", "24", "1.78", "cm", "96", "%", "100", "%"]
    assert rows[1].split() == ["velocity", "24", "10.00", "cm", "-", "-"]
    assert results_table({"notes": "x"}) == []


def test_results_table_of_success_rate_metrics():
    metrics = {"act": {"success_rate": 0.84, "success_ci95": [0.71, 0.92], "episodes": 50, "task": "push-v3"}}
    header, _, row = results_table(metrics)
    assert "95 % CI" in header and "time to success" in header
    assert row.split() == ["act", "50", "42/50", "84", "%", "71-92", "%", "-", "push-v3"]


def test_lightning_tips_are_dropped_and_other_messages_kept(caplog):
    quiet()
    quiet()  # twice: one filter
    logger = logging.getLogger("lightning.pytorch.utilities.rank_zero")
    assert len(logger.filters) == 1
    with caplog.at_level(logging.INFO, logger=logger.name):
        logger.info("💡 Tip: For seamless cloud logging, try installing [litlogger]")
        logger.info("GPU available: False")
    assert [r.getMessage() for r in caplog.records] == ["GPU available: False"]


def test_lightnings_internal_deprecation_warning_is_ignored_and_others_kept():
    import warnings

    from torch.utils._pytree import LeafSpec

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        quiet()
        LeafSpec()  # what lightning.pytorch.utilities._pytree does (torch warns on construction)
        warnings.warn("a user's warning", FutureWarning, stacklevel=1)
    assert [str(w.message) for w in caught] == ["a user's warning"]
