"""Careless input to the human-arm analysis (scripts/analyze_arm.py, lfd.human): a file in the
wrong length unit, a time column in the wrong unit, a body mass in grams. Each is refused with one
line that names the file or option and suggests the unit; no result is written for it; the batch
summary marks such a file failed with that line and still analyses the others."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from time_limits import deadline

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


# --- second round: mixed units, spikes, short recordings, pipes, gzip bombs, name collisions, options ----


def _edited(dst: Path, rows: range | list[int], factor: float) -> Path:
    """``GOOD`` with the coordinates of the given data rows (0-based frames) times ``factor``."""
    lines = GOOD.read_text().splitlines()
    out = [lines[0]]
    for i, line in enumerate(lines[1:]):
        t, *xyz = line.split(",")
        k = factor if i in rows else 1.0
        out.append(",".join([t] + [repr(float(v) * k) if v else "" for v in xyz]))
    dst.write_text("\n".join(out) + "\n")
    return dst


def _peak(path: Path, **options) -> float:
    return analyze_arm(read_skeleton(path), **options).summary()["elevation_peak_torque_Nm"]


def test_rows_in_millimetres_are_refused_naming_the_frames_and_repair_drops_them(tmp_path, caplog):
    from lfd.human.plausibility import ImplausibleFrames

    path = _edited(tmp_path / "mixed.csv", range(54, 90), 1000.0)  # the last 40 % of the rows in mm
    with pytest.raises(ImplausibleFrames) as info:
        analyze_file(path, tmp_path / "out", plots=False, gif=False)
    message = str(info.value)
    assert message.startswith(
        f"{path} (csv wide): 36 frame(s) 54-89 (t 1.8-2.97 s) cannot be a person's motion: 36 with an upper arm "
        "over 8x longer or shorter than the median (another length unit?)"
    )
    assert "repair_frames=true" in message and "\n" not in message and len(message) - len(str(path)) < 400
    assert not (tmp_path / "out").exists()
    with caplog.at_level("WARNING", logger="lfd.human.analysis"):
        result = analyze_arm(read_skeleton(path), repair_frames=True)
    assert (
        result.quality["repaired_frames"] == 36
        and "dropped 36 frame(s) (36 in another length unit" in caplog.text
    )
    clean = _peak(GOOD)
    assert abs(result.summary()["elevation_peak_torque_Nm"] - clean) < 0.2 * clean


def test_a_single_frame_spike_is_refused_and_repair_interpolates_it(tmp_path):
    path = _edited(tmp_path / "spike.csv", [45], 1e6)
    with pytest.raises(
        ValueError,
        match=r"spike\.csv \(csv wide\): 1 frame\(s\) 45 \(t 1\.5 s\) cannot be a person's motion: 1 with an upper arm",
    ) as info:
        analyze_arm(read_skeleton(path))
    assert "1 jumping away and back faster than 50 m/s (spikes?)" in str(info.value)
    clean = _peak(GOOD)
    repaired = analyze_arm(read_skeleton(path), repair_frames=True)
    assert repaired.quality["repaired_frames"] == 1 and repaired.quality["gaps_left"] == []
    assert abs(repaired.summary()["elevation_peak_torque_Nm"] - clean) < 0.05 * clean


def test_the_entry_point_refuses_mixed_units_in_one_line_and_repairs_on_request(tmp_path):
    path = _edited(tmp_path / "mixed.csv", range(54, 90), 1000.0)
    proc = _script(tmp_path / "run", f"file={path}", "outputs.gif=false")
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert proc.stderr.startswith(f"analyze_arm: {path} (csv wide): 36 frame(s) 54-89")
    proc = _script(tmp_path / "run2", f"file={path}", "outputs.gif=false", "gaps.repair_frames=true")
    assert proc.returncode == 0, proc.stderr
    assert "repair_frames: dropped 36 frame(s)" in proc.stdout + proc.stderr


@pytest.mark.parametrize("frames", [2, 3, 7])
def test_too_short_recordings_are_refused_with_the_minimum(tmp_path, frames):
    from lfd.human.analysis import MIN_FRAMES

    path = tmp_path / "short.csv"
    path.write_text("\n".join(GOOD.read_text().splitlines()[: frames + 1]) + "\n")
    with pytest.raises(
        ValueError,
        match=rf"short\.csv \(csv wide\): {frames} frame\(s\); the analysis needs at least {MIN_FRAMES}",
    ):
        analyze_file(path, tmp_path / "out", plots=False, gif=False)
    assert not (tmp_path / "out").exists()
    path.write_text("\n".join(GOOD.read_text().splitlines()[: MIN_FRAMES + 1]) + "\n")
    assert np.isfinite(analyze_arm(read_skeleton(path)).tau).all()


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_pipe_named_like_a_recording_is_skipped_with_a_line(tmp_path, capsys):
    folder = tmp_path / "recordings"
    folder.mkdir()
    os.mkfifo(folder / "a.csv")
    (folder / "b.csv").write_bytes(GOOD.read_bytes())
    with deadline(60):
        with pytest.raises(ValueError, match=r"a\.csv, field file: not a regular file"):
            read_skeleton(folder / "a.csv")
        rows = analyze_folder(folder, tmp_path / "out", progress=False, plots=False, gif=False)
    assert [(r["file"], r["status"]) for r in rows] == [
        ("a.csv", "skipped: not a regular file"),
        ("b.csv", "ok"),
    ]
    assert f"{folder / 'a.csv'}: not a regular file (a pipe or device?); skipped" in capsys.readouterr().err
    with deadline(60):
        proc = _script(tmp_path / "run", f"file={folder / 'a.csv'}")
    assert proc.returncode == 2 and proc.stderr.startswith(
        f"analyze_arm: file={folder / 'a.csv'}: not a regular file"
    )


def test_gzip_content_over_the_cap_is_refused_without_inflating_it(tmp_path, monkeypatch):
    import gzip

    from lfd.human.readers import common

    assert common.MAX_SKELETON_BYTES == 256 << 20  # the documented cap
    monkeypatch.setattr(common, "MAX_SKELETON_BYTES", 1 << 20)
    path = tmp_path / "bomb.csv.gz"
    path.write_bytes(gzip.compress(GOOD.read_bytes() + b"0" * (40 << 20)))  # inflates to 40 MiB
    assert path.stat().st_size < 100_000
    tracemalloc.start()
    try:
        with pytest.raises(
            ValueError, match=r"bomb\.csv\.gz, field gzip: decompresses to more than 1048576 bytes"
        ) as info:
            read_skeleton(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20  # never inflated past the cap
    assert "\n" not in str(info.value)
    big = tmp_path / "big.csv"
    big.write_bytes(GOOD.read_bytes() + b"\n" * (2 << 20))
    with pytest.raises(
        ValueError, match=r"big\.csv, field size: \d+ bytes; a skeleton file has at most 1048576"
    ):
        read_skeleton(big)
    small = tmp_path / "ok.csv.gz"
    small.write_bytes(gzip.compress(GOOD.read_bytes()))
    assert read_skeleton(small).n_frames == 90


def test_batch_outputs_never_collide_and_the_summary_counts_what_was_written(tmp_path):
    import gzip

    folder = tmp_path / "recordings"
    (folder / "sub").mkdir(parents=True)
    (folder / "rec.csv").write_bytes(GOOD.read_bytes())
    (folder / "rec.csv.gz").write_bytes(gzip.compress(_rescaled(tmp_path / "x", length=1.1).read_bytes()))
    (folder / "sub" / "x.csv").write_bytes(GOOD.read_bytes())
    (folder / "sub__x.csv").write_bytes(_rescaled(tmp_path / "y", length=0.9).read_bytes())
    (folder / "Summary.csv").write_bytes(GOOD.read_bytes())
    out = tmp_path / "out"
    rows = analyze_folder(folder, out, progress=False, plots=False, gif=False)
    assert all(r["status"] == "ok" for r in rows) and len(rows) == 5
    outputs = [r["output"] for r in rows]
    assert len({o.lower() for o in outputs}) == 5 and "summary.csv" not in {o.lower() for o in outputs}
    written = sorted(p.parent.name for p in out.glob("*/arm.json"))
    assert written == sorted(outputs)
    for row in rows:  # each folder holds its own file's result
        saved = json.loads((out / row["output"] / "arm.json").read_text())
        assert saved["summary"]["source"].startswith(str(folder / row["file"]))
    with open(out / "summary.csv") as f:
        assert [r["output"] for r in csv.DictReader(f)] == outputs


@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("subject.body_mass=abc", "subject.body_mass must be a finite number, got 'abc'"),
        ("filter.cutoff=nan", "filter.cutoff must be a finite number, got nan"),
        ("filter.order=2.5", "filter.order must be a whole number, got 2.5"),
        ("hampel.enabled=maybe", "hampel.enabled must be true or false, got 'maybe'"),
        ("subject.hand_length=long", "subject.hand_length must be a finite number or null, got 'long'"),
        ("outputs.gif_frames=[1,2]", "outputs.gif_frames must be a whole number, got [1, 2]"),
    ],
)
def test_bad_option_values_name_the_option(override, expected):
    from lfd.cli.analyze_arm import save_options

    with pytest.raises(ValueError) as info:
        save_options(_cfg(f"file={GOOD}", override))
    assert str(info.value) == expected


def test_bad_option_value_is_one_line_and_exit_2(tmp_path):
    proc = _script(tmp_path, f"file={GOOD}", "subject.body_mass=heavy")
    assert proc.returncode == 2
    assert proc.stderr == "analyze_arm: subject.body_mass must be a finite number, got 'heavy'\n"


def test_a_long_header_is_quoted_in_a_bounded_line(tmp_path):
    """A CSV header without a time column is quoted in the refusal: cut to a short line however wide the
    file (found by the fuzz harness: a 1184-character message for a Kinect CSV with one flipped byte)."""
    from lfd.human import read_skeleton
    from lfd.human.readers.common import MAX_PROBLEM_CHARS

    path = tmp_path / "wide.csv"
    path.write_text(",".join(f"joint_{k}_x" for k in range(2000)) + "\n" + ",".join("0" * 2000) + "\n")
    with pytest.raises(ValueError) as info:
        read_skeleton(path, format="csv")
    message = str(info.value)
    assert message.startswith(f"{path}, line 1, field t: header needs a time column") and "\n" not in message
    assert len(message) <= len(f"{path}, line 1, field t: ") + MAX_PROBLEM_CHARS
