"""Fixtures for the lfd.human tests: the small recordings in tests/fixtures/human. The real test videos
(``sports2d_video``, ``pose2sim_demo``) and ``mediapipe_ok`` are suite-wide fixtures of tests/conftest.py."""

from __future__ import annotations

from pathlib import Path

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "human"


@pytest.fixture(scope="session")
def fixtures() -> Path:
    return FIXTURES
