"""Every ``python train.py ...`` and ``python evaluate.py ...`` command written in the README and
docs/ composes: its overrides name keys and config files that exist (placeholders such as
``<last.ckpt>``, ``S`` or ``...`` are filled with a stand-in value first)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: A command in a code span or block: up to the end of the span, line or a shell operator.
COMMAND = re.compile(r"python (train|evaluate)\.py((?:[^`\n&|;#]|\\\n)*)")
#: Placeholder values -> stand-ins.
PLACEHOLDERS = [
    (re.compile(r"<[^<>]*>"), "X"),
    (re.compile(r"=\.\.\.(?=\s|$|,|\])"), "=X"),
    (re.compile(r"\$\w+|\"\$\w+\""), ""),
]
#: Whole-word placeholders of a value (``seed=S``, ``model=K``), by key.
WORD_VALUES = {"seed": "1", "model": "cnn_dmp", "data.n_train_objects": "10", "data.image_size": "64"}


def documented_commands() -> list[tuple[str, str, list[str]]]:
    """``(where, script, overrides)`` of every command on the pages."""
    found = []
    for page in PAGES:
        text = page.read_text()
        for m in COMMAND.finditer(text):
            line = text[: m.start()].count("\n") + 1
            args = m.group(2).replace("\\\n", " ")
            args = re.sub(r"\[(?:[\w./+=-]+(?:=\.\.\.|=FILE|=PATH)?)\]", "", args)  # optional [key=...] parts
            for pattern, value in PLACEHOLDERS:
                args = pattern.sub(value, args)
            try:
                words = shlex.split(args)
            except ValueError:
                continue  # an unbalanced quote: the command runs on into prose
            overrides = []
            for w in words:
                if "=" not in w or w.startswith("-"):
                    continue
                key, value = w.split("=", 1)
                overrides.append(
                    f"{key}={WORD_VALUES.get(key.lstrip('+~'), value) if len(value) == 1 else value}"
                )
            found.append((f"{page.name}:{line}", m.group(1), overrides))
    return found


COMMANDS = documented_commands()


def test_the_pages_hold_commands():
    assert len(COMMANDS) > 40 and {s for _, s, _ in COMMANDS} == {"train", "evaluate"}


@pytest.mark.parametrize(("where", "script", "overrides"), COMMANDS, ids=[c[0] for c in COMMANDS])
def test_documented_command_composes(compose, where, script, overrides):
    sweeps = [
        o for o in overrides if "," in o.split("=", 1)[1] and not o.split("=", 1)[1].startswith(("[", "{"))
    ]
    single = [
        o if o not in sweeps else f"{o.split('=', 1)[0]}={o.split('=', 1)[1].split(',')[0]}"
        for o in overrides
    ]
    singles = [o for o in single if not o.startswith(("hydra/", "hydra.", "-"))]
    cfg = compose(script, *singles)
    assert cfg is not None, where
    if script == "train":
        assert "_target_" in cfg.model and "_target_" in cfg.data, where
