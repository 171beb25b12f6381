"""The documented examples of lfd.teach run."""

from __future__ import annotations

import doctest
import os
import textwrap

import pytest
from teach_helpers import ROOT

import lfd.teach
from lfd.teach import drag_ik, scene, session, settings


@pytest.mark.parametrize("module", [drag_ik, scene, session, settings], ids=lambda m: m.__name__)
def test_doctests(module):
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


def test_package_example_runs(monkeypatch):
    monkeypatch.chdir(ROOT)
    code = lfd.teach.__doc__.split("Example (runnable)::")[1]
    exec(compile(textwrap.dedent(code), "lfd.teach example", "exec"), {})
    assert os.getcwd() == str(ROOT)


def test_teach_guide_images_exist_and_are_small():
    """docs/teach.md's screenshots (taken by docs/images/teach/take_screenshots.py) are committed, small."""
    import re

    guide = (ROOT / "docs" / "teach.md").read_text()
    images = re.findall(r"!\[[^\]]*\]\((images/teach/[^)]+\.png)\)", guide)
    assert len(images) >= 4
    for name in images:
        path = ROOT / "docs" / name
        assert path.is_file() and path.stat().st_size < 100_000, name
    assert "Close gripper at t" in guide and "take_screenshots.py" in guide
