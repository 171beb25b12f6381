"""The docstring examples of lfd.human run."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["skeleton", "arm_ik", "thesis_angles", "synthetic", "analysis", "readers", "readers.vicon"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(f"lfd.human.{name}")
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert failures == 0
    assert tried > 0 or name == "readers"


def test_package_example():
    import lfd.human

    code = lfd.human.__doc__.split("Example (runnable)::")[1]
    exec(compile("\n".join(line[4:] for line in code.splitlines()), "lfd.human example", "exec"), {})
