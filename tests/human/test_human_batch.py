"""lfd.human.batch: a folder of recordings -> one analysis per file and a summary table."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

from lfd.human.batch import analyze_folder, skeleton_files, write_summary

#: tests/fixtures/human (the human conftest's FIXTURES; conftest modules are not importable by name).
FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "human"


def test_folder_analysis_reports_bad_files_and_keeps_going(tmp_path):
    folder = tmp_path / "rec"
    (folder / "sub").mkdir(parents=True)
    shutil.copy(FIXTURES / "synthetic_wide.csv", folder / "sub" / "a.csv")
    (folder / "broken.csv").write_text("t,wrist_x\n0,1\n")
    rows = analyze_folder(folder, tmp_path / "out", progress=False, plots=False, analysis={"side": "left"})
    assert [r["file"] for r in rows] == ["broken.csv", "sub/a.csv"]
    assert rows[0]["status"].startswith("error:") and rows[1]["status"] == "ok"
    assert (tmp_path / "out" / "sub__a" / "arm.json").exists()
    with open(tmp_path / "out" / "summary.csv") as f:
        table = list(csv.DictReader(f))
    assert table[1]["file"] == "sub/a.csv" and float(table[1]["abduction_rom_deg"]) > 0


def test_pattern_and_empty_folder(tmp_path):
    (tmp_path / "a.csv").write_text("x")
    (tmp_path / "b.trc").write_text("x")
    assert [p.name for p in skeleton_files(tmp_path, "*.trc")] == ["b.trc"]
    with pytest.raises(FileNotFoundError, match="no skeleton files found"):
        analyze_folder(tmp_path, tmp_path / "out", pattern="*.none")


def test_summary_columns_are_the_union_of_the_rows(tmp_path):
    path = write_summary(
        [{"file": "a", "x": 1.23456}, {"file": "b", "status": "error: bad"}], tmp_path / "s.csv"
    )
    assert path.read_text().splitlines() == ["file,x,status", "a,1.235,", "b,,error: bad"]
