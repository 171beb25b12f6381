"""The suite's requirements outside pip (tests/conftest.py): absent -> skipped with a one-line reason, or
failed under LFD_REQUIRE_ALL_TESTS=1 (``.ci/run``); Chromium found through LFD_CHROMIUM or the PATH."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import REQUIRE_ALL, find_chromium, require

ROOT = Path(__file__).resolve().parents[1]


def test_absent_requirement_skips_with_one_line_or_fails_when_required(monkeypatch):
    monkeypatch.delenv(REQUIRE_ALL, raising=False)
    require(True, "npm", "apt-get install -y npm")  # present: nothing happens
    with pytest.raises(pytest.skip.Exception, match=r"^npm is missing: apt-get install -y npm$"):
        require(False, "npm", "apt-get install -y npm")
    monkeypatch.setenv(REQUIRE_ALL, "0")
    with pytest.raises(pytest.skip.Exception):
        require(False, "npm", "apt-get install -y npm")
    monkeypatch.setenv(REQUIRE_ALL, "1")
    with pytest.raises(
        pytest.fail.Exception, match=r"npm is missing: .* \(LFD_REQUIRE_ALL_TESTS=1: required here\)"
    ):
        require(False, "npm", "apt-get install -y npm")


def test_chromium_is_found_by_environment_variable_or_path(tmp_path, monkeypatch):
    fake = tmp_path / "bin" / "chromium-browser"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", str(fake.parent))
    monkeypatch.delenv("LFD_CHROMIUM", raising=False)
    assert find_chromium() == str(fake)  # chromium-browser when there is no chromium
    monkeypatch.setenv("PATH", str(tmp_path))
    assert find_chromium() is None
    monkeypatch.setenv("LFD_CHROMIUM", str(fake))
    assert find_chromium() == str(fake)
    monkeypatch.setenv("LFD_CHROMIUM", str(tmp_path / "nonexistent"))
    monkeypatch.setenv("PATH", str(fake.parent))
    assert find_chromium() is None  # a given path that is not there is not replaced by the PATH's
    monkeypatch.delenv("LFD_CHROMIUM")
    for name in ("chromium", "chromium-headless-shell"):  # the headless shell first, then chromium
        (fake.parent / name).write_text("#!/bin/sh\n")
        (fake.parent / name).chmod(0o755)
        assert find_chromium() == str(fake.parent / name)


def test_ci_makes_every_requirement_mandatory():
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    assert any(line.split("#")[0].strip() == f"export {REQUIRE_ALL}=1" for line in lines)


def test_no_test_hard_codes_a_browser_path():
    files = [p for p in (ROOT / "tests").rglob("*.py") if p != Path(__file__)]
    offenders = [
        str(p.relative_to(ROOT)) for p in files if "/usr/bin/chromium" in p.read_text(encoding="utf-8")
    ]
    assert len(files) > 100 and not offenders, offenders
