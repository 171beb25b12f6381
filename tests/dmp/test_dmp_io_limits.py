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


def _edited(tmp_path, section, key, value, index=None):
    path = _saved(tmp_path / "skill.dmp.json")
    data = json.loads(path.read_text())
    if index is None:
        data[section][key] = value
    else:
        data[section][key][index] = (
            value
            if not isinstance(data[section][key][index], list)
            else [value] * len(data[section][key][index])
        )
    out = tmp_path / "edited.dmp.json"
    out.write_text(json.dumps(data))
    return out


@pytest.mark.parametrize(
    ("section", "key", "value", "index", "expected"),
    [
        # alpha_z = 1e308 once overflowed inside the rollout operator (alpha_z**2): found by the fuzz harness
        ("params", "alpha_z", 1e308, None, "alpha_z must be a finite number in [1e-06, 10000], got 1e+308"),
        ("params", "beta_z", 1e-308, None, "beta_z must be a finite number in [1e-06, 10000], got 1e-308"),
        # alpha_s = 1000 made the last basis activations vanish: NaN trajectory
        ("params", "alpha_s", 1000.0, None, "alpha_s must be a finite number in [1e-06, 100], got 1000.0"),
        ("fitted", "goal", 1e308, 0, "goal must have every |value| <= 1e+06, got 1e+308"),
        ("fitted", "y0", -1e300, 1, "y0 must have every |value| <= 1e+06, got 1e+300"),
        ("fitted", "weights", 1e308, 0, "weights must have every |value| <= 1e+12, got 1e+308"),
    ],
)
def test_values_whose_rollout_cannot_be_finite_are_refused_on_load(
    tmp_path, section, key, value, index, expected
):
    path = _edited(tmp_path, section, key, value, index)
    with pytest.raises(ValueError) as info:
        DMP.load(path).rollout()
    message = str(info.value)
    assert message.startswith(str(path)) and message.endswith(expected) and "\n" not in message


@pytest.mark.parametrize(
    ("section", "key", "value", "index"),
    [
        ("params", "alpha_z", 1e4, None),  # the widest accepted values still roll out finite
        ("params", "beta_z", 1e-6, None),
        ("params", "alpha_s", 100.0, None),
        ("fitted", "goal", 1e6, 0),
        ("fitted", "weights", 1e12, 0),
    ],
)
def test_extreme_accepted_values_give_a_finite_rollout(tmp_path, section, key, value, index):
    path = _edited(tmp_path, section, key, value, index)
    y = DMP.load(path).rollout()
    assert np.isfinite(y).all()


def test_default_alpha_s_past_its_bound_names_where_it_came_from():
    with pytest.raises(
        ValueError,
        match=r"^alpha_s \(alpha_z / 3 by default\) must be a finite number in \[1e-06, 100\], got 1000",
    ):
        DMP(4, alpha_z=3000.0)
