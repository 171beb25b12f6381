"""Fixtures for the lfd.human tests: paths of the small recordings in tests/fixtures/human."""

from __future__ import annotations

from pathlib import Path

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "human"


@pytest.fixture(scope="session")
def fixtures() -> Path:
    return FIXTURES


REAL_FILES = {
    "kinect_csv": "kimore_ex1_excerpt.csv.gz",
    "ntu": "ntu_S001C001P001R001A001_excerpt.skeleton.gz",
    "uiprmd": "ui_prmd/Kinect/Positions/m10_s05_e02_positions.txt.gz",
}
