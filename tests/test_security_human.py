"""Careless input to the human-arm analysis (scripts/analyze_arm.py, lfd.human): a file in the
wrong length unit, a time column in the wrong unit, a body mass in grams. Each is refused with one
line that names the file or option and suggests the unit; no result is written for it; the batch
summary marks such a file failed with that line and still analyses the others."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

from lfd.human import analyze_arm, read_skeleton
from lfd.human.batch import analyze_file, analyze_folder

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "analyze_arm.py"
GOOD = ROOT / "tests" / "fixtures" / "human" / "synthetic_wide.csv"  # metres, seconds, 30 Hz


def _rescaled(dst: Path, length: float = 1.0, time: float = 1.0) -> Path:
    """``GOOD`` with every coordinate times ``length`` and the time column times ``time``."""
    lines = GOOD.read_text().splitlines()
    out = [lines[0]]
    for line in lines[1:]:
        t, *xyz = line.split(",")
        out.append(",".join([repr(float(t) * time)] + [repr(float(v) * length) if v else "" for v in xyz]))
    dst.write_text("\n".join(out) + "\n")
    return dst


def _script(tmp_path: Path, *overrides: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *overrides, "outputs.plots=false", f"paths.root_dir={tmp_path}"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )


def _cfg(*overrides: str):
    with initialize_config_dir(config_dir=str(ROOT / "configs"), version_base="1.3"):
        return compose(config_name="analyze_arm", overrides=[*overrides, "outputs.plots=false"])


def _run_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("analyze_arm_security", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.run


def test_file_in_millimetres_is_refused_by_the_entry_point_and_units_mm_reads_it(tmp_path):
    mm = _rescaled(tmp_path / "arm_in_mm.csv", length=1000.0)
    proc = _script(tmp_path / "run", f"file={mm}")
    assert proc.returncode == 2, proc.stderr
    message = proc.stderr.strip()
    assert "\n" not in message and "Traceback" not in proc.stderr
    assert message.startswith(f"analyze_arm: {mm}: upper arm 300")
    assert "outside 0.15-0.6 m; is the file in millimetres? pass units=mm" in message
    assert not list((tmp_path / "run").rglob("arm.*"))  # no 300 m results written
    assert "[lfd]" not in proc.stdout

    original = analyze_arm(read_skeleton(GOOD))
    again = analyze_arm(read_skeleton(mm, units="mm"))
    np.testing.assert_allclose(again.q, original.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(again.tau, original.tau, rtol=1e-9, atol=1e-9)
    assert again.segment_lengths["upper_arm"] == pytest.approx(0.3006, abs=1e-3)

    # the same through the script's config (units=mm), in process
    out = _run_module()(_cfg(f"file={mm}", "units=mm"), tmp_path / "cfg")
    assert (out / "arm.json").exists()
    with pytest.raises(ValueError, match=r"units must be one of m, cm, mm, auto .*got 'yards'"):
        _run_module()(_cfg(f"file={mm}", "units=yards"), tmp_path / "bad")
    assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize(
    ("time", "expected"),
    [
        (1e-7, r"time column gives 3e\+08 frames/s .*outside 1-1000 Hz; the time column must be in seconds"),
        (
            1e7,
            r"time column gives 3e-06 frames/s .*100 ns ticks \(30 Hz\)\? the time column must be in seconds",
        ),
    ],
)
def test_time_column_in_the_wrong_unit_is_refused(tmp_path, time, expected):
    bad = _rescaled(tmp_path / "fast.csv", time=time)
    with pytest.raises(ValueError, match=rf"^{tmp_path / 'fast.csv'}: {expected}$"):
        analyze_file(bad, tmp_path / "out", plots=False)
    assert not (tmp_path / "out").exists()


def test_rate_option_out_of_range_is_refused():
    kimore = ROOT / "tests" / "fixtures" / "human" / "kimore_ex1_excerpt.csv.gz"
    for rate in (3e8, 0.5):
        with pytest.raises(
            ValueError, match=r"kimore_ex1_excerpt\.csv\.gz: rate=.*outside 1-1000 Hz; pass rate= in Hz"
        ):
            read_skeleton(kimore, rate=rate)


def test_body_mass_in_grams_is_refused(tmp_path):
    with pytest.raises(
        ValueError, match=r"^body_mass 75000 is outside 20-250 kg; give body_mass in kg .*75 kg"
    ):
        analyze_arm(read_skeleton(GOOD), body_mass=75000.0)
    run = _run_module()
    with pytest.raises(ValueError, match=r"body_mass 75000 is outside 20-250 kg"):
        run(_cfg(f"file={GOOD}", "subject.body_mass=75000"), tmp_path / "one")
    assert not list(tmp_path.rglob("arm.*"))
    folder = tmp_path / "rec"
    folder.mkdir()
    (folder / "a.csv").write_bytes(GOOD.read_bytes())
    with pytest.raises(ValueError, match=r"body_mass 75000"):  # wrong for every file: before any is read
        analyze_folder(
            folder, tmp_path / "batch", progress=False, plots=False, analysis={"body_mass": 75000.0}
        )
    assert not (tmp_path / "batch").exists()


def test_batch_marks_the_implausible_file_failed_and_analyses_the_good_one(tmp_path):
    folder = tmp_path / "recordings"
    folder.mkdir()
    (folder / "good.csv").write_bytes(GOOD.read_bytes())
    _rescaled(folder / "in_mm.csv", length=1000.0)
    _rescaled(folder / "ticks.csv", time=1e7)
    proc = _script(tmp_path / "run", f"file={folder}")
    assert proc.returncode == 0, proc.stderr
    assert "1/3 files analysed" in proc.stdout
    summary = next((tmp_path / "run").rglob("summary.csv"))
    with open(summary) as f:
        rows = {row["file"]: row for row in csv.DictReader(f)}
    assert rows["good.csv"]["status"] == "ok" and 0 < float(rows["good.csv"]["abduction_rom_deg"]) < 180
    assert rows["in_mm.csv"]["status"] == (
        f"error: {folder / 'in_mm.csv'}: upper arm 300 m: outside 0.15-0.6 m; is the file in millimetres? pass units=mm"
    )
    assert rows["ticks.csv"]["status"].startswith(
        f"error: {folder / 'ticks.csv'}: time column gives 3e-06 frames/s"
    )
    assert rows["in_mm.csv"]["abduction_rom_deg"] == rows["ticks.csv"]["elevation_peak_torque_Nm"] == ""
    outputs = summary.parent
    assert (outputs / "good" / "arm.json").exists()
    assert not (outputs / "in_mm").exists() and not (outputs / "ticks").exists()
