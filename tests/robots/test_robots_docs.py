"""The documented examples run."""

from __future__ import annotations

import doctest
import textwrap

import lfd.robots
import lfd.robots.robot


def test_package_example_runs():
    code = lfd.robots.__doc__.split("Example (runnable)::")[1]
    exec(compile(textwrap.dedent(code), "lfd.robots example", "exec"), {})


def test_robot_doctest():
    result = doctest.testmod(lfd.robots.robot)
    assert result.attempted > 0 and result.failed == 0
