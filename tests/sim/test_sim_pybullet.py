"""PyBullet is imported once, in lfd.sim._pybullet, without its build-time banner."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2] / "src" / "lfd"
BANNER = "pybullet build time"


def _run(code: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_plain_pybullet_prints_the_banner():
    """The check below can fail: PyBullet itself prints the line on import."""
    run = _run("import pybullet")
    assert run.returncode == 0, run.stderr
    assert BANNER in run.stdout + run.stderr


@pytest.mark.parametrize("module", ["lfd.sim._pybullet", "lfd.sim.scene", "lfd.sim.tracking"])
def test_lfd_imports_pybullet_without_the_banner_and_keeps_its_streams(module):
    code = (
        "import sys; print('before'); print('before', file=sys.stderr); "
        f"import {module}; print('after'); print('after', file=sys.stderr)"
    )
    run = _run(code)
    assert run.returncode == 0, run.stderr
    assert BANNER not in run.stdout + run.stderr
    assert run.stdout.split() == ["before", "after"] and run.stderr.split() == ["before", "after"], run


def test_the_command_help_has_no_banner():
    run = _run("import sys; from lfd.cli.teach import cli; sys.argv = ['lfd-teach', '--help']; cli()")
    assert BANNER not in run.stdout + run.stderr and "lfd-teach" in run.stdout, run


def test_pybullet_is_imported_in_one_module():
    importing = sorted(
        str(path.relative_to(SRC))
        for path in SRC.rglob("*.py")
        if any(
            line.strip().startswith(("import pybullet", "from pybullet"))
            for line in path.read_text().splitlines()
        )
    )
    assert importing == ["sim/_pybullet.py"], importing
