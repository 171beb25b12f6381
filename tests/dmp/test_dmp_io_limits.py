"""DMP files past the documented bounds (lfd.dmp._io: MAX_FILE_BYTES, MAX_DEPTH) are refused in one line naming
the file, before or instead of a RecursionError; every kind of primitive reads through the same reader."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lfd.dmp import DMP, ProMP, _io


def _saved(path):
    t = np.linspace(0.0, 1.0, 20)
    DMP(4).fit(t, np.stack([t**2, np.sin(t)], axis=1)).save(path)
    return path


@pytest.mark.parametrize("depth", [100_000, _io.MAX_DEPTH + 1])
def test_deeply_nested_dmp_json_is_one_line(tmp_path, depth):
    """100k nested arrays once gave a RecursionError; just past the limit is refused the same way."""
    path = tmp_path / "deep.json"
    path.write_text(
        '{"type": "lfd.dmp.DMP", "version": 1, "params": {"x": ' + "[" * depth + "]" * depth + "}}"
    )
    for load in (DMP.load, ProMP.load):
        with pytest.raises(ValueError) as info:
            load(path)
        message = str(info.value)
        assert (
            message
            == f"{path} is not a DMP file (JSON nested deeper than the {_io.MAX_DEPTH} levels a DMP file may have)"
        )


def test_nesting_up_to_the_limit_and_a_saved_dmp_read(tmp_path):
    path = _saved(tmp_path / "skill.dmp.json")
    assert DMP.load(path).is_fitted
    ok = tmp_path / "ok.json"
    nested = "[" * (_io.MAX_DEPTH - 2) + "]" * (_io.MAX_DEPTH - 2)
    ok.write_text('{"type": "k", "version": 1, "params": {"x": ' + nested + '}, "fitted": null}')
    assert _io.read_json(ok, "k") == ({"x": json.loads(nested)}, None)


def test_a_dmp_file_past_the_size_limit_is_refused_unread(tmp_path, monkeypatch):
    path = _saved(tmp_path / "skill.dmp.json")
    monkeypatch.setattr(_io, "MAX_FILE_BYTES", path.stat().st_size - 1)
    with pytest.raises(ValueError) as info:
        DMP.load(path)
    assert str(info.value).startswith(f"{path} is not a DMP file (more than the ")
    monkeypatch.setattr(_io, "MAX_FILE_BYTES", path.stat().st_size)
    assert DMP.load(path).is_fitted


def test_a_parameter_the_dmp_refuses_is_one_line_naming_the_file(tmp_path):
    """A saved DMP whose ``n_basis`` became NaN: the constructor's refusal, prefixed with the file."""
    path = _saved(tmp_path / "skill.dmp.json")
    payload = json.loads(path.read_text())
    payload["params"]["n_basis"] = float("nan")
    path.write_text(json.dumps(payload))
    with pytest.raises(ValueError) as info:
        DMP.load(path)
    assert str(info.value) == f"{path}: bad DMP parameters: n_basis must be an integer >= 1, got nan"


def test_a_null_formulation_is_refused_naming_the_file(tmp_path):
    """``"formulation": null`` built a DMP without a formulation, which failed later with an
    AttributeError in its rollout (found by the fuzz harness)."""
    path = _saved(tmp_path / "skill.dmp.json")
    payload = json.loads(path.read_text())
    payload["params"]["formulation"] = None
    path.write_text(json.dumps(payload))
    with pytest.raises(ValueError, match=rf"^{path}: bad DMP parameters: formulation") as info:
        DMP.load(path)
    assert "\n" not in str(info.value)
