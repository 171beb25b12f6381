"""lfd.checks: the ground-floor argument checks return the value converted or raise one line
``"<name> must be <expectation>, got <what came>"``; ``optional=True`` lets None through and says so."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from lfd.checks import (
    ENTRY_POINT_KEYS,
    check_choice,
    check_flag,
    check_float,
    check_int,
    check_keys,
    check_text,
    check_vector,
)


def _one_line(error: pytest.ExceptionInfo) -> str:
    message = str(error.value)
    assert "\n" not in message
    return message


def test_check_choice_lists_the_choices_and_takes_none_when_optional():
    assert check_choice("ik", "goal_init", ("demo", "ik")) == "ik"
    assert check_choice(None, "bag", ("ros1", "ros2"), optional=True) is None
    with pytest.raises(ValueError) as error:
        check_choice("top", "mount", ("auto", "side"))
    assert _one_line(error) == "mount must be one of auto, side, got 'top'"
    with pytest.raises(ValueError, match=r"^bag must be one of ros1, ros2 \(or None\), got 'ros3'$"):
        check_choice("ros3", "bag", ("ros1", "ros2"), optional=True)
    with pytest.raises(ValueError, match="mode must be one of"):
        check_choice(None, "mode", ("3d", "2d"))


def test_check_text_is_a_non_empty_string_or_a_path():
    assert check_text("arm.bag", "source") == "arm.bag"
    assert check_text(Path("a") / "b.mp4", "video") == str(Path("a") / "b.mp4")
    assert check_text(None, "topic", optional=True) is None
    for bad in ("", 3, None, ["a"]):
        with pytest.raises(ValueError, match=r"^host must be a non-empty string, got ") as error:
            check_text(bad, "host")
        _one_line(error)
    with pytest.raises(ValueError, match=r"^topic must be a non-empty string \(or None\), got ''$"):
        check_text("", "topic", optional=True)


def test_check_flag_takes_only_bools():
    assert check_flag(True, "gif") is True and check_flag(False, "gif") is False
    for bad in (1, 0, "yes", None):
        with pytest.raises(ValueError, match=r"^outputs.gif must be true or false, got "):
            check_flag(bad, "outputs.gif")


def test_numbers_take_none_when_optional_and_say_so():
    assert check_int(None, "max_frames", minimum=1, optional=True) is None
    assert check_int(5, "max_frames", minimum=1, optional=True) == 5
    with pytest.raises(ValueError, match=r"^max_frames must be an integer >= 1 \(or None\), got 0$"):
        check_int(0, "max_frames", minimum=1, optional=True)
    with pytest.raises(ValueError, match=r"^stride must be an integer >= 1, got None$"):
        check_int(None, "stride", minimum=1)
    assert check_float(None, "duration_s", low=0.0, optional=True) is None
    assert check_float(2, "duration_s", low=0.0, optional=True) == 2.0
    with pytest.raises(ValueError, match=r"^duration_s must be a finite number >= 0 \(or None\), got -1$"):
        check_float(-1, "duration_s", low=0.0, optional=True)
    with pytest.raises(ValueError, match=r"^margin must be a finite number >= 0, got None$"):
        check_float(None, "margin", low=0.0)


def test_check_vector_states_what_a_vector_must_be():
    point = check_vector((0.4, 0.2, 0.1), 3, "target", what="a tool position [x, y, z] in metres")
    assert point.dtype == np.float64 and point.tolist() == [0.4, 0.2, 0.1]
    assert check_vector(None, 3, "goal", optional=True) is None
    what = "a tool position [x, y, z] in metres"
    for bad, shown in (((1, 2), r"\[1, 2\]"), ("abc", "'abc'"), ([[1, 2, 3]], r"\[\[1, 2, 3\]\]")):
        with pytest.raises(ValueError, match=rf"^goal must be {re.escape(what)}, got {shown}$"):
            check_vector(bad, 3, "goal", what=what)
    with pytest.raises(ValueError, match=r"^goal must be 3 numbers \(or None\), got 'abc'$"):
        check_vector("abc", 3, "goal", optional=True)
    with pytest.raises(ValueError, match=r"goal must have shape \(3,\), got \(2,\)"):
        check_vector([1, 2], 3, "goal")  # without ``what``: the shape, as before
    with pytest.raises(ValueError, match="goal contains NaN or inf"):
        check_vector([1, np.nan, 2], 3, "goal", what=what)


def test_check_keys_names_the_unknown_keys_and_the_allowed_ones():
    section = {"tol": 0.01, "seed": 1}
    assert check_keys(section, "refine", ("tol", "seed", "task")) is section
    assert check_keys({}, "refine", ()) == {}
    with pytest.raises(ValueError) as error:
        check_keys({"tol": 1, "speed": 2, "Alpha": 3}, "refine", ("tol", "seed", "task"))
    assert _one_line(error) == "refine must have keys among seed, task, tol, got unknown Alpha, speed"
    with pytest.raises(ValueError, match="got unknown 3$"):
        check_keys({3: "x"}, "section", ("a",))  # a YAML key that is no string


def test_entry_point_keys_are_hydras_and_the_shared_configs():
    assert set(ENTRY_POINT_KEYS) == {"hydra", "paths", "task_name"}


def test_one_line_folds_and_cuts_another_librarys_message():
    from lfd.checks import one_line

    assert one_line(KeyError("k")) == "KeyError: 'k'"
    assert (
        one_line(ValueError("could not parse:\n  float-1[] x\n"))
        == "ValueError: could not parse: float-1[] x"
    )
    assert one_line(RuntimeError()) == "RuntimeError"
    long = one_line("x" * 1000, limit=50)
    assert len(long) == 50 and long.endswith("...")
    assert one_line("a\x00b\x1bc") == "a b c"
