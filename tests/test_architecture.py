"""The written architecture is the real one: import-linter's contracts (pyproject.toml), ruff, the
PyBullet boundary at run time, no import cycles inside lfd, the module size guideline and tests/
mirroring src/."""

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


#: Review guideline for the size of a module (one concept per module), as movement_primitives
#: and LeRobot run: a longer module is a sign that it holds two concepts.
MODULE_LINES_GUIDELINE = 800


def test_modules_stay_within_the_review_guideline():
    long = {
        str(p.relative_to(ROOT)): n
        for p in SRC.rglob("*.py")
        if (n := len(p.read_text().splitlines())) > MODULE_LINES_GUIDELINE
    }
    assert not long, (
        f"modules over the review guideline of {MODULE_LINES_GUIDELINE} lines (one concept per module; "
        f"split them or justify the length in review): {long}"
    )


def _import_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    for root in sorted(edges):
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        work = [(root, iter(sorted(edges[root])))]
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    cycles.append(sorted(component))
    return cycles


def test_no_import_cycles_inside_lfd():
    """No two modules of lfd import each other, directly or through others.

    The rule, exactly: build grimp's graph of ``lfd`` (every ``import`` and ``from ... import``
    between lfd's modules, at module level, inside functions and under ``TYPE_CHECKING`` alike)
    and require that it has no strongly connected component of more than one module. A package's
    ``__init__`` counts as the module named by the package and its re-exports of its own
    submodules are ordinary edges: they form no cycle as long as none of those submodules imports
    the package (or an ancestor that reaches it) back, which is then reported like any cycle.
    Break a cycle by moving the piece both sides need down into a module both import, never by
    hiding an import inside a function.
    """
    grimp = pytest.importorskip("grimp")
    graph = grimp.build_graph("lfd", cache_dir=None)
    modules = {m for m in graph.modules if m == "lfd" or m.startswith("lfd.")}
    edges = {m: {i for i in graph.find_modules_directly_imported_by(m) if i in modules} for m in modules}
    cycles = _import_cycles(edges)
    report = [
        f"cycle of {len(cycle)} modules: "
        + "; ".join(f"{m} -> {', '.join(sorted(edges[m] & set(cycle)))}" for m in cycle)
        for cycle in cycles
    ]
    for line in report:
        print(line)
    assert not cycles, (
        "import cycles inside lfd (module -> the modules of its cycle it imports):\n" + "\n".join(report)
    )


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


def test_architecture_page_lists_the_layers_of_the_contract():
    """docs/architecture.md names the layers in the order pyproject.toml's layer contract checks them."""
    tomllib = pytest.importorskip("tomllib", reason="tomllib: Python 3.11+")
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    (layers,) = [c["layers"] for c in contracts if c["type"] == "layers"]
    written = " > ".join(f"`{layer}`" for layer in layers)
    page = " ".join((ROOT / "docs" / "architecture.md").read_text().split())
    assert written in page, f"docs/architecture.md should list the layers as {written}"
