"""The Hydra entry point scripts/analyze_arm.py: one file and batch mode over a folder."""

from __future__ import annotations

import csv
import importlib.util
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir

ROOT = Path(__file__).resolve().parents[2]


#: tests/fixtures/human (the human conftest's FIXTURES; conftest modules are not importable by name).
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "human"


def _script():
    spec = importlib.util.spec_from_file_location("analyze_arm_script", ROOT / "scripts" / "analyze_arm.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _cfg(overrides):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="analyze_arm", overrides=overrides)


def test_config_overrides_reach_analyze_arm():
    cfg = _cfg(
        [
            "file=x.csv",
            "subject.body_mass=80",
            "subject.sex=female",
            "side=left",
            "filter=median",
            "fit.method=spline",
            "subject.hand_load=2",
        ]
    )
    options = _script().analysis_options(cfg)
    assert options["body_mass"] == 80.0 and options["sex"] == "female" and options["side"] == "left"
    assert options["filter"] == "median" and options["median_kernel"] == 5 and options["fit"] == "spline"
    assert options["hand_load"] == 2.0


def test_batch_mode_writes_summary(tmp_path):
    folder = tmp_path / "recordings"
    folder.mkdir()
    shutil.copy(FIXTURES / "synthetic_wide.csv", folder / "a.csv")
    shutil.copy(FIXTURES / "synthetic.trc", folder / "b.trc")
    (folder / "broken.csv").write_text("t,wrist_x\n0,1\n")  # no arm joints: reported, not fatal
    cfg = _cfg([f"file={folder}", "outputs.plots=false"])
    out = _script().run(cfg, tmp_path / "out")
    with open(out / "summary.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["file"] for r in rows] == ["a.csv", "b.trc", "broken.csv"]
    assert rows[0]["status"] == rows[1]["status"] == "ok"
    assert rows[2]["status"].startswith("error:") and "missing" in rows[2]["status"]
    assert 0 < float(rows[0]["abduction_rom_deg"]) < 180 and float(rows[0]["elevation_peak_torque_Nm"]) > 0
    assert (out / "a" / "arm.csv").exists() and (out / "b" / "arm.mot").exists()


@pytest.mark.slow
def test_command_line_single_file(tmp_path):
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "scripts" / "analyze_arm.py"),
            f"file={FIXTURES / 'kimore_ex1_excerpt.csv.gz'}",
            "subject.body_mass=80",
            "subject.sex=female",
            "side=left",
            "filter=butterworth",
            "outputs.gif_frames=8",
            f"paths.root_dir={tmp_path}",
        ],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    )
    out = Path(proc.stdout.strip().splitlines()[-1].split("outputs in ")[1])
    doc = json.loads((out / "arm.json").read_text())
    assert doc["subject"]["sex"] == "female" and doc["summary"]["side"] == "left"
    for name in ("arm.csv", "arm.mot", "angles.png", "torques.png", "stick_figure.gif"):
        assert (out / name).exists()
