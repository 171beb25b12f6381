"""Scenario files: a set of objects, each evaluated at every one of a set of placements.

Format (YAML; torso frame, metres, radians)::

    objects:
      - {name: can, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1.0, 0.5, 0.0, 1.0]}
      - {name: block, shape: box, size: [0.05, 0.07, 0.06], rgba: [0.5, 0.0, 0.5, 1.0]}
      - {name: ball, shape: sphere, radius: 0.04, rgba: [0.1, 0.6, 0.1, 1.0]}
      - {name: pill, shape: capsule, radius: 0.03, length: 0.08, rgba: [0.2, 0.2, 0.9, 1.0], mass: 0.2}
    placements:        # x, y in metres, yaw in radians
      - [0.55, 0.05, 0.3]

Per shape the size fields are: cylinder ``radius``, ``height``; capsule ``radius``,
``length`` (straight part); sphere ``radius``; box ``size: [x, y, z]`` (full side lengths).
``name`` and ``rgba`` are required, ``mass`` (kg) is optional (default
:data:`DEFAULT_MASS`). A bad field raises :class:`ScenarioError` naming the file, the
entry and the field.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from lfd.sim.objects import SHAPE_DIMS, ObjectSpec, Placement
from lfd.sim.scene import TABLE_HALF_Y, TABLE_X

#: Mass (kg) of a scenario object that does not give one.
DEFAULT_MASS = 0.3
#: Size fields per shape: the names of :data:`~lfd.sim.objects.SHAPE_DIMS`, except that a box
#: gives its three side lengths as one list ``size``.
SIZE_FIELDS: dict[str, tuple[str, ...]] = {s: ("size",) if s == "box" else dims for s, dims in SHAPE_DIMS.items()}
COMMON_FIELDS = ("name", "shape", "rgba", "mass")


class ScenarioError(ValueError):
    """A scenario file is missing, unparsable or has a bad field (the message names it)."""


@dataclass(frozen=True)
class Scenario:
    """Objects and placements; every object is evaluated at every placement."""

    objects: tuple[ObjectSpec, ...]
    placements: tuple[Placement, ...]
    source: str = ""

    def cases(self) -> list[tuple[int, ObjectSpec, int, Placement]]:
        """``(object_index, object, placement_index, placement)`` for every combination."""
        return [(i, o, j, p) for i, o in enumerate(self.objects) for j, p in enumerate(self.placements)]


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or None if it is not a finite real number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def _numbers(value: Any, n: int) -> list[float] | None:
    """``value`` as a list of ``n`` finite floats, or None."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        return None
    out = [_number(v) for v in value]
    return None if any(v is None for v in out) else out


def _parse_object(entry: Any, where: str) -> ObjectSpec:
    """Structural checks here (fields present, known, numeric); value ranges by :class:`ObjectSpec`."""
    if not isinstance(entry, dict):
        raise ScenarioError(f"{where}: expected a mapping with fields {COMMON_FIELDS} + size fields, got {entry!r}")
    shape = entry.get("shape")
    if shape not in SIZE_FIELDS:
        raise ScenarioError(f"{where}: field 'shape' must be one of {tuple(SIZE_FIELDS)}, got {shape!r}")
    allowed = set(COMMON_FIELDS) | set(SIZE_FIELDS[shape])
    unknown = sorted(set(entry) - allowed)
    if unknown:
        raise ScenarioError(f"{where}: unknown field(s) {unknown} for a {shape}; allowed: {sorted(allowed)}")
    name = entry.get("name")
    if not isinstance(name, str) or not name:
        raise ScenarioError(f"{where}: field 'name' must be a non-empty string, got {name!r}")
    where = f"{where} ({name})"
    fields = {f: (3, "3 lengths [x, y, z] in metres") if f == "size" else (1, "a length in metres") for f in SIZE_FIELDS[shape]}
    fields["rgba"] = (4, "4 numbers in [0, 1]")
    fields["mass"] = (1, "a mass in kg")
    values: dict[str, list[float]] = {}
    for field, (n, expected) in fields.items():
        raw = entry.get(field, DEFAULT_MASS if field == "mass" else None)
        parsed = _numbers(raw, n) if n > 1 else [_number(raw)]
        if parsed is None or None in parsed:
            raise ScenarioError(f"{where}: field '{field}' must be {expected}, got {raw!r}")
        values[field] = parsed
    dims = tuple(v for f in SIZE_FIELDS[shape] for v in values[f])
    try:
        return ObjectSpec(shape=shape, dims=dims, rgba=tuple(values["rgba"]), mass=values["mass"][0], name=name)
    except ValueError as e:
        raise ScenarioError(f"{where}: {e}") from e


def _parse_placement(entry: Any, where: str) -> Placement:
    values = _numbers(entry, 3)
    if values is None:
        raise ScenarioError(f"{where}: expected [x, y, yaw] (metres, metres, radians), got {entry!r}")
    x, y, yaw = values
    if not (TABLE_X[0] <= x <= TABLE_X[1] and abs(y) <= TABLE_HALF_Y):
        raise ScenarioError(
            f"{where}: (x, y) = ({x}, {y}) m lies off the table "
            f"(x in [{TABLE_X[0]}, {TABLE_X[1]}], |y| <= {TABLE_HALF_Y}, torso frame)"
        )
    return Placement(x, y, yaw)


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario YAML file (format in the module docstring).

    Raises:
        ScenarioError: missing or unparsable file, or a bad field (file, entry and field named).
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError as e:
        raise ScenarioError(f"scenario file not found: {path}") from e
    except yaml.YAMLError as e:
        raise ScenarioError(f"{path}: not valid YAML: {e}") from e
    if not isinstance(data, dict):
        raise ScenarioError(f"{path}: expected a mapping with keys 'objects' and 'placements', got {type(data).__name__}")
    unknown = sorted(set(data) - {"objects", "placements"})
    if unknown:
        raise ScenarioError(f"{path}: unknown top-level key(s) {unknown}; expected 'objects' and 'placements'")
    lists = {}
    for key in ("objects", "placements"):
        value = data.get(key)
        if not isinstance(value, list) or not value:
            raise ScenarioError(f"{path}: '{key}' must be a non-empty list, got {value!r}")
        lists[key] = value
    objects = tuple(_parse_object(o, f"{path}: objects[{i}]") for i, o in enumerate(lists["objects"]))
    names = [o.name for o in objects]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ScenarioError(f"{path}: object names must be unique, repeated: {duplicates}")
    placements = tuple(_parse_placement(p, f"{path}: placements[{i}]") for i, p in enumerate(lists["placements"]))
    return Scenario(objects=objects, placements=placements, source=str(path))
