"""The third-party checker lerobot-doctor (pyarrow/av only) finds no failure in our export
(nor in the lerobot-written reference, as a control that it runs)."""

from __future__ import annotations

from pathlib import Path

import pytest

REFERENCE = Path(__file__).resolve().parents[2] / "fixtures" / "lerobot_v3_reference"


def _report(path):
    pytest.importorskip("lerobot_doctor", reason="lerobot-doctor is a [test] dependency")
    from lerobot_doctor.dataset_loader import load_dataset
    from lerobot_doctor.runner import Severity, run_checks

    report = run_checks(load_dataset(str(path)))
    return {
        r.name: [(m.severity, m.message) for m in r.messages if m.severity == Severity.FAIL]
        for r in report.results
    }, report


@pytest.mark.parametrize("which", ["ours", "reference"])
def test_lerobot_doctor_passes(tiny_lerobot, which):
    if which == "ours":  # lfd's export marker inside does not disturb the checker
        assert (tiny_lerobot / ".lfd-export.json").is_file()
    failures, report = _report(tiny_lerobot if which == "ours" else REFERENCE)
    assert len(report.results) == 11  # every check ran
    assert not any(failures.values()), failures
