"""Scenario files: parsing, and clear errors that name the file, the entry and the field."""

import math
from pathlib import Path

import pytest

from lfd.visuomotor.eval.scenario import DEFAULT_MASS, ScenarioError, load_scenario

GOOD = """
objects:
  - {name: can, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1.0, 0.5, 0.0, 1.0]}
  - {name: block, shape: box, size: [0.05, 0.07, 0.06], rgba: [0.5, 0.0, 0.5, 1.0], mass: 0.2}
placements:
  - [0.55, 0.05, 0.3]
  - [0.60, -0.10, -0.5]
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scenario.yaml"
    path.write_text(text)
    return path


def test_good_scenario(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD))
    assert [o.name for o in sc.objects] == ["can", "block"]
    assert sc.objects[0].dims == (0.035, 0.14) and sc.objects[0].mass == DEFAULT_MASS
    assert sc.objects[1].dims == (0.05, 0.07, 0.06) and sc.objects[1].mass == 0.2
    assert sc.placements[1].yaw == pytest.approx(-0.5)
    cases = sc.cases()
    assert len(cases) == 4 and {(c[0], c[2]) for c in cases} == {(0, 0), (0, 1), (1, 0), (1, 1)}


def test_example_scenarios_in_configs_load():
    files = sorted(Path(__file__).resolve().parents[3].joinpath("configs", "scenarios").glob("*.yaml"))
    assert files
    for f in files:
        sc = load_scenario(f)
        assert sc.objects and sc.placements


@pytest.mark.parametrize(
    ("old", "new", "expected"),
    [
        (
            "radius: 0.035, height: 0.14",
            "radius: 0.035",
            r"objects\[0\] \(can\): field 'height' must be a length",
        ),
        (
            "size: [0.05, 0.07, 0.06]",
            "size: [0.05, 0.07]",
            r"objects\[1\] \(block\): field 'size' must be 3 lengths",
        ),
        (
            "size: [0.05, 0.07, 0.06]",
            "size: [0.05, 0.07, -0.06]",
            r"objects\[1\] \(block\): .*size_z must be",
        ),
        ("rgba: [1.0, 0.5, 0.0, 1.0]", "rgba: [1.0, 0.5, 0.0, 2.0]", r"objects\[0\] \(can\): .*rgba"),
        ("rgba: [1.0, 0.5, 0.0, 1.0]", "rgba: red", r"objects\[0\] \(can\): field 'rgba' must be 4 numbers"),
        ("shape: cylinder", "shape: cone", r"objects\[0\]: field 'shape' must be one of"),
        ("height: 0.14", "height: 0.14, colour: red", r"objects\[0\]: unknown field\(s\) \['colour'\]"),
        ("mass: 0.2", "mass: -1", r"objects\[1\] \(block\): .*mass"),
        ("name: can, ", "", r"objects\[0\]: field 'name' must be a non-empty string"),
        ("[0.60, -0.10, -0.5]", "[0.60, -0.10]", r"placements\[1\]: expected \[x, y, yaw\]"),
        ("[0.60, -0.10, -0.5]", "[2.0, 0.0, 0.0]", r"placements\[1\]: .* lies off the table"),
        ("name: block", "name: can", r"object names must be unique"),
        ("placements:", "placement:", r"unknown top-level key"),
    ],
)
def test_bad_field_is_named(tmp_path, old, new, expected):
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(ScenarioError, match=expected) as info:
        load_scenario(path)
    assert str(path) in str(info.value)


def test_missing_and_unparsable_files(tmp_path):
    with pytest.raises(ScenarioError, match="not found"):
        load_scenario(tmp_path / "nope.yaml")
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(write(tmp_path, "objects: [\n"))
    with pytest.raises(ScenarioError, match="'objects' must be a non-empty list"):
        load_scenario(write(tmp_path, "objects: []\nplacements: [[0.5, 0, 0]]\n"))
    assert math.isfinite(load_scenario(write(tmp_path, GOOD)).placements[0].x)


@pytest.mark.parametrize(
    ("data", "expected"),
    [
        (bytes(range(256)), r"not UTF-8 or UTF-16 text \(position \d+: #x[0-9a-f]{4}, "),
        (GOOD.replace("can", "caf\u00e9").encode("latin-1"), r"not UTF-8 or UTF-16 text .*save it as UTF-8"),
        (
            GOOD.encode("utf-16-le"),
            r"not UTF-8 or UTF-16 text \(position \d+: #x0000, ",
        ),  # no byte-order mark
        (b"", r"expected a mapping with keys 'objects' and 'placements', got an empty file"),
        (b"- 1\n- 2\n", r"expected a mapping .*got list"),
        (b"objects: [1, 2\nplacements: {", r"not valid YAML at line 2, column \d+: expected ','"),
        (b"? [1, 2]\n: 3\n", r"not valid YAML at line 1, column \d+: found unhashable key"),
        (
            b"!!python/object/apply:os.system ['true']\n",
            r"not valid YAML .*could not determine a constructor",
        ),
        (GOOD.encode() + b"1: 2\nextra: 3\n", r"unknown top-level key\(s\) \['extra', 1\]"),
        (
            GOOD.replace("shape: cylinder", "shape: [cylinder]").encode(),
            r"objects\[0\]: field 'shape' must be one",
        ),
        (
            GOOD.replace("0.035", "1" + "0" * 400).encode(),
            r"field 'radius' must be a length in metres, got 1000+\.\.\.$",
        ),
    ],
    ids=[
        "binary",
        "latin-1",
        "utf-16-no-bom",
        "empty",
        "list",
        "unclosed",
        "unhashable-key",
        "python-tag",
        "unknown-keys",
        "shape-list",
        "huge-int",
    ],
)
def test_any_bytes_give_one_line_naming_the_file(tmp_path, data, expected):
    path = tmp_path / "scenario.yaml"
    path.write_bytes(data)
    with pytest.raises(ScenarioError, match=expected) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message


def test_utf16_with_a_byte_order_mark_loads_and_odd_paths_are_refused(tmp_path):
    path = tmp_path / "utf16.yaml"
    path.write_bytes(GOOD.encode("utf-16"))  # YAML's other encoding, with its BOM
    assert [o.name for o in load_scenario(path).objects] == ["can", "block"]
    with pytest.raises(ScenarioError, match="not a regular file"):
        load_scenario(tmp_path)
    big = tmp_path / "big.yaml"
    big.write_bytes(b"#" * (2 << 20))
    with pytest.raises(ScenarioError, match="a scenario YAML file has at most"):
        load_scenario(big)


# --- hostile scenario files: bounded work, one short line ------------------------------------------------


def _until(seconds: float):
    """Fail with TimeoutError instead of hanging when the protection is switched off."""
    import signal

    def _raise(*_):
        raise TimeoutError(f"still running after {seconds} s")

    signal.signal(signal.SIGALRM, _raise)
    signal.setitimer(signal.ITIMER_REAL, seconds)


@pytest.fixture
def deadline():
    import signal

    old = signal.getsignal(signal.SIGALRM)
    yield _until
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.signal(signal.SIGALRM, old)


def test_alias_bomb_in_mass_is_one_short_line_at_once(tmp_path, deadline):
    # 9 levels of 10 aliases: a 10**9-value list as the mass, in a file of a few hundred bytes
    obj = "{name: %s, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1, 0.5, 0, 1], mass: %s}"
    lines = ["objects:", "  - " + obj % ("c0", "&m0 [0.3]")]
    lines += [
        "  - " + obj % (f"c{i}", f"&m{i} [" + ", ".join([f"*m{i - 1}"] * 10) + "]") for i in range(1, 10)
    ]
    bomb = "\n".join([*lines, "placements:", "  - [0.55, 0.05, 0.3]"]) + "\n"
    path = write(tmp_path, bomb)
    assert path.stat().st_size < 1500
    deadline(10)
    with pytest.raises(ScenarioError, match=r"line 3, column \d+: alias \*m0 refused") as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}: ") and len(str(info.value)) < 300


def test_many_alias_placements_are_refused(tmp_path, deadline):
    # 100 objects x 100k aliased placements: a 700 KB file standing for 10**7 cases
    objects = [f"  - {{name: o{i}, shape: sphere, radius: 0.03, rgba: [1, 0, 0, 1]}}" for i in range(100)]
    text = (
        "objects:\n" + "\n".join(objects) + "\nplacements:\n  - &p [0.55, 0.0, 0.0]\n" + "  - *p\n" * 100_000
    )
    path = write(tmp_path, text)
    assert path.stat().st_size < 1 << 20
    deadline(20)
    with pytest.raises(ScenarioError, match=r"alias \*p refused"):
        load_scenario(path)


def test_case_count_is_capped_with_a_clear_line(tmp_path, deadline):
    from lfd.visuomotor.eval.scenario import MAX_SCENARIO_CASES

    n_objects = 101
    n_placements = MAX_SCENARIO_CASES // 100
    objects = [
        f"  - {{name: o{i}, shape: sphere, radius: 0.03, rgba: [1, 0, 0, 1]}}" for i in range(n_objects)
    ]
    text = "objects:\n" + "\n".join(objects) + "\nplacements:\n" + "  - [0.55, 0.0, 0.0]\n" * n_placements
    path = write(tmp_path, text)
    deadline(60)
    with pytest.raises(
        ScenarioError,
        match=rf"101 objects x {n_placements} placements = \d+ cases; a scenario has at most {MAX_SCENARIO_CASES}",
    ):
        load_scenario(path)


def test_duplicate_top_level_key_is_refused_not_silently_replaced(tmp_path):
    text = GOOD + "objects:\n  - {name: ball, shape: sphere, radius: 0.04, rgba: [0.1, 0.6, 0.1, 1.0]}\n"
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError, match=r"line \d+, column 1: duplicate key 'objects'") as info:
        load_scenario(path)
    assert str(info.value).startswith(f"{path}: ")
