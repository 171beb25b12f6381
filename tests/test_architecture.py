"""The written architecture is the real one: import-linter's contracts (pyproject.toml), ruff, the
PyBullet boundary at run time, the module size limit and tests/ mirroring src/."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "lfd"

#: Packages that must import without loading PyBullet (everything that does not drive a simulator).
WITHOUT_SIMULATOR = (
    "lfd.dmp",
    "lfd.robots",
    "lfd.rl",
    "lfd.io",
    "lfd.io.video",
    "lfd.training",
    "lfd.sim",
    "lfd.visuomotor",
    "lfd.visuomotor.data",
    "lfd.visuomotor.policies",
    "lfd.model_reaching",
    "lfd.human",
    "lfd.interop",
)


def _tool(name: str) -> str:
    path = shutil.which(name) or str(Path(sys.executable).with_name(name))
    if not Path(path).exists():
        pytest.fail(f"{name} is not installed: pip install -e '.[test]'")
    return path


def test_import_contracts_hold():
    """Layer order, PyBullet only in lfd.sim, no Hydra under src/lfd, plain numeric cores."""
    run = subprocess.run([_tool("lint-imports"), "--no-cache"], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-4000:] + run.stderr[-2000:]
    assert " 0 broken" in run.stdout, run.stdout[-2000:]


def test_ruff_lint_and_format_are_clean():
    lint = subprocess.run([_tool("ruff"), "check", "."], cwd=ROOT, capture_output=True, text=True)
    assert lint.returncode == 0, lint.stdout[-4000:]
    fmt = subprocess.run([_tool("ruff"), "format", "--check", "."], cwd=ROOT, capture_output=True, text=True)
    assert fmt.returncode == 0, fmt.stdout[-4000:]


@pytest.mark.parametrize("package", WITHOUT_SIMULATOR)
def test_package_imports_without_pybullet(package):
    code = f"import sys, {package}; print('pybullet' in sys.modules)"
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip() == "False", f"import {package} loads PyBullet"


def test_no_module_over_450_lines():
    long = {
        str(p.relative_to(ROOT)): n for p in SRC.rglob("*.py") if (n := len(p.read_text().splitlines())) > 450
    }
    assert not long, f"split these modules (one concept each): {long}"


def test_tests_mirror_src():
    """Every test folder names a package of src/lfd (tests/<pkg>/<subpkg>/ <-> src/lfd/<pkg>/<subpkg>/)."""
    packages = {p.parent.relative_to(SRC) for p in SRC.rglob("__init__.py")}
    modules = {p.relative_to(SRC).with_suffix("") for p in SRC.rglob("*.py")}
    tests = ROOT / "tests"
    stray = [
        str(d.relative_to(tests))
        for d in tests.rglob("*")
        if d.is_dir()
        and d.name not in {"__pycache__", "fixtures"}
        and "fixtures" not in d.relative_to(tests).parts
        and d.relative_to(tests) not in packages | modules
    ]
    assert not stray, f"test folders without a matching src/lfd package or module: {stray}"
