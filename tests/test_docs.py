"""The user documentation speaks to users and agrees with itself.

* No issue numbers, work-log phrases (plans for the next round of work, which machine was
  borrowed, "the main job") or commit hashes in README.md, docs/, benchmarks/README.md and
  data/README.md: history belongs in CHANGELOG.md.
* Every row of the README's headline table links the page its numbers come from, and every
  number of its result column is in that page; the numbers of the README's other tables are in
  the pages their sections link.
* docs/index.md links every page; the getting-started page's Python runs as written; each API
  page names every public name of its package; the site builds with ``mkdocs build --strict``.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import require

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
USER_DOCS = [
    ROOT / "README.md",
    *sorted(DOCS.glob("*.md")),
    *sorted((DOCS / "api").glob("*.md")),
    ROOT / "benchmarks" / "README.md",
    ROOT / "data" / "README.md",
]

#: Words of a work log rather than of a manual, each with a pattern (case-insensitive).
WORK_LOG = {
    "an issue number": r"\bissues?\s*#?\s*\d+|\bthis issue\b|\bthe issue's\b|\bthe issue measured\b|"
    r"(?<![\w&/#])#\d+\b|\bPR ?#\d+|\bPR \d+|pull request",
    "the main job": r"\bmain job",
    "the work's time budget": r"\b(?:15|fifteen)[- ]minute budget|\bover (?:its|the) budget|"
    r"\b(?:device|session|GPU|machine) (?:time )?budget",
    "a work session": r"\b(?:this|first|next|previous|earlier|later|last|a|one|the GPU) session\b|"
    r"\bsession's (?:loans|machine|GPU)",
    "a borrowed machine": r"\blent\b|\bborrow|\bloans?\b|\bGPU machine\b|\bwhich machine\b",
    "planned work": r"\bpending\b|\bnext round\b|\bplanned work\b|\bTODO\b|\bFIXME\b|\bwork ?log\b|"
    r"\bfollow-up\b|\bqueued\b|\bbefore the deadline\b|\bnext step(?:s)? (?:is|are|would)\b|"
    r"\bnot (?:measured|done|run) yet\b",
    "an internal role": r"\bthe lead engineer\b|\bthe lead's\b",
}
#: A commit hash: 7-40 hexadecimal characters with both a digit and a letter.
HEX = re.compile(r"(?<![\w-])(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}(?![\w-])")
#: Hexadecimal strings users need: revisions and checksums of other projects' files.
ALLOWED_HEX = {
    "0164e5f387b6",  # docs/power.md: the pyrdmp revision whose update rule is reproduced
    "3ce7d4e015f2",  # docs/power.md: the other pyrdmp revision
    "59e42d71",  # docs/video.md: start of the sha256 of MediaPipe's heavy pose model
}


def page_text(page: Path) -> str:
    """The page without its URLs (links name anchors and paths, not prose)."""
    return re.sub(r"https?://\S+", "", page.read_text())


def rel(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.mark.parametrize("page", USER_DOCS, ids=rel)
def test_user_docs_hold_no_work_log(page):
    found = []
    for line_no, line in enumerate(page_text(page).splitlines(), 1):
        for what, pattern in WORK_LOG.items():
            for m in re.finditer(pattern, line, flags=re.I):
                found.append(f"{rel(page)}:{line_no}: {what}: {m.group(0)!r}")
        for m in HEX.finditer(line):
            if m.group(0) not in ALLOWED_HEX:
                found.append(f"{rel(page)}:{line_no}: a commit hash: {m.group(0)!r}")
    assert not found, "history belongs in CHANGELOG.md:\n" + "\n".join(found)


def test_the_work_log_patterns_catch_what_they_should():
    caught = [
        "fixed in issue 35",
        "see #12",
        "within the issue's 15 min",
        "the main job took 13 min",
        "fits the 15-minute budget",
        "the device budget is spent",
        "the first session with a GPU lent",
        "## Pending",
        "in the next round",
        "measured at e169cd1",
        "queued but not run before the deadline",
    ]
    passed = [
        "TeachSession owns the session logic",
        "ik.time_budget=0.02",
        "budget 3000 rollouts",
        "a fixed step budget of 4000 steps",
        "colour #ff0000",
        "the sha256 of the file",
        "12345678 frames",
        "[results](results.md#results)",
    ]

    def flagged(text: str) -> bool:
        return any(re.search(p, text, flags=re.I) for p in WORK_LOG.values()) or any(
            h not in ALLOWED_HEX for h in HEX.findall(text)
        )

    assert [t for t in caught if not flagged(t)] == []
    assert [t for t in passed if flagged(t)] == []


# ---------------------------------------------------------------------------- README figures
def table_rows(markdown: str, heading: str) -> list[list[str]]:
    """The rows of the first table under ``## heading``: its cells, header and separator dropped."""
    section = markdown.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    rest = section.partition("\n|")[2]
    lines = ("|" + rest).splitlines()
    rows = [
        [c.strip() for c in line.strip().strip("|").split(" | ")]
        for line in lines
        if line.startswith("|") and not line.startswith("|---")
    ]
    return [r for r in rows[1:] if not set("".join(r)) <= set("-: ")]


def linked_pages(text: str) -> list[Path]:
    return [ROOT / link for link in re.findall(r"\]\(([\w/.-]+\.md)(?:#[\w-]+)?\)", text)]


def numbers(text: str) -> list[str]:
    """The measured numbers of a cell (not the digits of names such as ``s02``, ``7-DoF``)."""
    text = re.sub(r"`[^`]*`", "", text)  # commands and keys
    text = re.sub(r"(\d) (\d{3})\b", r"\1\2", text)  # 100 000
    return re.findall(r"(?<![\w.])(?<!e-)\d+(?:[.,]\d+)?(?!\d|[.,]\d|[.-]?[A-Za-wyz])", text)


def contains_number(text: str, number: str) -> bool:
    text = re.sub(r"(\d) (\d{3})\b", r"\1\2", text)
    variants = {number, number.replace(",", "")}
    return any(re.search(rf"(?<![\d.]){re.escape(v)}(?![\d])", text) for v in variants)


def test_readme_headline_numbers_are_in_the_pages_they_link():
    readme = (ROOT / "README.md").read_text()
    rows = table_rows(readme, "Headline results")
    assert len(rows) >= 8
    missing = []
    for row in rows:
        what, result, command = row[0], row[1], " | ".join(row[2:])
        pages = linked_pages(what + result + command)
        if not pages:
            missing.append(f"{what[:50]!r}: links no page for its numbers")
        texts = [p.read_text() for p in pages]
        for number in numbers(result):
            if not any(contains_number(t, number) for t in texts):
                missing.append(f"{what[:50]!r}: {number} (not in {[rel(p) for p in pages]})")
    assert not missing, "README headline numbers the linked pages do not hold:\n" + "\n".join(missing)


def test_readme_tables_are_in_the_pages_their_sections_link():
    """The other README tables (a person's arm, imitation, formats, teach): every number is in a page
    that its section links."""
    readme = (ROOT / "README.md").read_text()
    missing, tables = [], 0
    for section in readme.split("\n## ")[1:]:
        title = section.splitlines()[0]
        rows = [line for line in section.splitlines() if line.startswith("|") and not line.startswith("|---")]
        if title.startswith("Headline") or not rows:
            continue
        tables += 1
        pages = linked_pages(section)
        texts = [p.read_text() for p in pages]
        if not pages:
            missing.append(f"{title!r}: links no page")
        for row in rows[1:]:
            cells = [c.strip() for c in row.strip().strip("|").split(" | ")]
            for number in (n for cell in cells[1:] for n in numbers(cell)):
                if not any(contains_number(t, number) for t in texts):
                    missing.append(f"{title[:40]!r}, {cells[0][:40]!r}: {number}")
    assert tables >= 4
    assert not missing, "README numbers the section's pages do not hold:\n" + "\n".join(missing)


# ---------------------------------------------------------------------------- the site
def test_index_links_every_page():
    index = (DOCS / "index.md").read_text()
    linked = set(re.findall(r"\]\(([\w/.-]+\.md)", index))
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")} - {"index.md"}
    assert pages - linked == set()


GETTING_STARTED = (DOCS / "getting-started.md").read_text()


def getting_started_commands() -> list[str]:
    """The shell commands of the getting-started page, in order (installs left out)."""
    blocks = re.findall(r"```bash\n(.*?)```", GETTING_STARTED, flags=re.S)
    return [line for b in blocks for line in b.strip().splitlines() if not line.startswith("pip ")]


def run_documented(command: str, root: Path) -> subprocess.CompletedProcess:
    """``command`` from the repository root, with ``samples/`` and the outputs under ``root``."""
    env = {**os.environ, "LFD_ROOT": str(root), "OMP_NUM_THREADS": "1"}
    args = shlex.split(command.replace("samples/", f"{root}/samples/"))
    if args[0] == "python":
        args[0] = sys.executable
    return subprocess.run(args, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def samples_root(tmp_path_factory) -> Path:
    """A folder holding ``samples/``, made by the page's own command."""
    root = tmp_path_factory.mktemp("getting-started")
    command = next(c for c in getting_started_commands() if "lfd.samples" in c)
    proc = run_documented(command, root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return root


def test_getting_started_python_runs(samples_root, monkeypatch):
    monkeypatch.chdir(samples_root)
    blocks = re.findall(r"```python\n(.*?)```", GETTING_STARTED, flags=re.S)
    assert blocks
    for i, block in enumerate(blocks):
        exec(compile(block, f"getting-started.md[python block {i}]", "exec"), {})


def test_getting_started_imitates_the_joint_csv(samples_root):
    command = next(c for c in getting_started_commands() if "source=samples/arm.csv" in c)
    proc = run_documented(command, samples_root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "0 limit violations" in proc.stdout + proc.stderr


def test_getting_started_names_installed_commands():
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from Python 3.11")
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    named = set(re.findall(r"`(lfd-[\w-]+)", GETTING_STARTED))
    assert named and named <= set(scripts), named - set(scripts)


def test_readme_lists_every_installed_command():
    """The README's Commands table has one row per console command of pyproject.toml, and no other."""
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from Python 3.11")
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    readme = (ROOT / "README.md").read_text()
    rows = {row[0].strip("`").split()[0] for row in table_rows(readme, "Commands")}
    assert rows == set(scripts), (sorted(set(scripts) - rows), sorted(rows - set(scripts)))


@pytest.mark.slow
def test_getting_started_commands_run_in_order(tmp_path):
    """Every command of the page, as written (about a minute and a half on 2 cores)."""
    commands = getting_started_commands()
    assert any(c.startswith("python train.py") for c in commands)
    for command in commands:
        proc = run_documented(command, tmp_path)
        assert proc.returncode == 0, f"{command}\n{proc.stderr[-2000:]}"
    assert list((tmp_path / "outputs" / "evaluate").glob("*/metrics.json"))


@pytest.mark.parametrize("page", sorted((DOCS / "api").glob("*.md")), ids=lambda p: p.name)
def test_api_page_covers_the_package(page):
    text = page.read_text()
    directives = re.findall(r"^::: ([\w.]+)", text, flags=re.M)
    assert directives, page
    package = importlib.import_module(directives[0])
    public = getattr(package, "__all__", None)
    if public is None:
        return
    explicit = re.findall(r"^\s+- (\w+)$", text, flags=re.M)
    assert not explicit or set(public) <= set(explicit), set(public) - set(explicit)


def test_site_builds_strict(tmp_path):
    require(
        all(importlib.util.find_spec(m) for m in ("mkdocs", "mkdocstrings_handlers.python")),
        "mkdocs or mkdocstrings-python",
        'pip install -e ".[docs]" (the test extra includes it)',
    )
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert (tmp_path / "site" / "api" / "dmp" / "index.html").exists()
