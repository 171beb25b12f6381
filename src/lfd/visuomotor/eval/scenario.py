"""Scenario files: a set of objects, each evaluated at every one of a set of placements.

Format (YAML; torso frame, metres, radians)::

    objects:
      - {name: can, shape: cylinder, radius: 0.035, height: 0.14, rgba: [1.0, 0.5, 0.0, 1.0]}
      - {name: block, shape: box, size: [0.05, 0.07, 0.06], rgba: [0.5, 0.0, 0.5, 1.0]}
      - {name: ball, shape: sphere, radius: 0.04, rgba: [0.1, 0.6, 0.1, 1.0]}
      - {name: pill, shape: capsule, radius: 0.03, length: 0.08, rgba: [0.2, 0.2, 0.9, 1.0], mass: 0.2}
    placements:        # x, y in metres; yaw_deg in degrees, or yaw in radians
      - {x: 0.55, y: 0.05, yaw_deg: 17}
      - {x: 0.60, y: -0.10, yaw: -0.5}
      - [0.62, 0.10, 0.3]          # [x, y, yaw] with yaw in radians

A yaw in radians must lie in [-pi, pi] (a ``yaw: 45`` meant as degrees is an error, not
45 rad); give degrees explicitly as ``yaw_deg``.

Validation beyond the fields (errors name the file and the entry):

* a placement off the table (:data:`~lfd.sim.scene.TABLE_X`, :data:`~lfd.sim.scene.TABLE_HALF_Y`);
* an object whose bounding box at a placement leaves the fixed camera's image
  (``camera`` argument of :func:`load_scenario`);
* an object whose pre-grasp and approach poses (:func:`~lfd.sim.approach.plan_approach`)
  have no IK solution (``robot`` argument).

An object or placement outside the *training* ranges (``training``: a
:class:`~lfd.visuomotor.data.GeneratorConfig` -- its families, its size set (:data:`~lfd.sim.objects.SIZE_SETS`),
its placement ranges) is accepted with a printed warning and marked out of distribution
(:meth:`Scenario.ood`, the ``ood`` column of ``episodes.csv``).

Per shape the size fields are: cylinder ``radius``, ``height``; capsule ``radius``,
``length`` (straight part); sphere ``radius``; box ``size: [x, y, z]`` (full side lengths).
``name`` and ``rgba`` are required, ``mass`` (kg) is optional (default
:data:`DEFAULT_MASS`). A bad field raises :class:`ScenarioError` naming the file, the
entry and the field.

Limits (bounded work on any file): at most :data:`MAX_SCENARIO_BYTES` bytes and
:data:`MAX_SCENARIO_CASES` cases (objects x placements); YAML aliases, a key repeated in one
mapping and nesting deeper than :data:`lfd.io.files.MAX_YAML_DEPTH` are refused
(:func:`lfd.io.files.load_yaml`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lfd.io.files import YamlError, read_yaml, show
from lfd.sim.approach import TABLE_Z, plan_approach
from lfd.sim.camera import Camera
from lfd.sim.objects import SHAPE_DIMS, SIZE_SETS, ObjectSpec, Placement
from lfd.sim.scene import TABLE_HALF_Y, TABLE_X

#: Mass (kg) of a scenario object that does not give one.
DEFAULT_MASS = 0.3
#: Size fields per shape: the names of :data:`~lfd.sim.objects.SHAPE_DIMS`, except that a box
#: gives its three side lengths as one list ``size``.
SIZE_FIELDS: dict[str, tuple[str, ...]] = {
    s: ("size",) if s == "box" else dims for s, dims in SHAPE_DIMS.items()
}
COMMON_FIELDS = ("name", "shape", "rgba", "mass")
#: Largest scenario file read (bytes).
MAX_SCENARIO_BYTES = 1 << 20
#: Most cases (objects x placements) in one scenario.
MAX_SCENARIO_CASES = 10_000


class ScenarioError(ValueError):
    """A scenario file is missing, unparsable or has a bad field (the message names it)."""


@dataclass(frozen=True)
class Scenario:
    """Objects and placements; every object is evaluated at every placement."""

    objects: tuple[ObjectSpec, ...]
    placements: tuple[Placement, ...]
    source: str = ""
    #: per object / placement: why it lies outside the training ranges ("" = inside).
    object_ood: tuple[str, ...] = field(default=())
    placement_ood: tuple[str, ...] = field(default=())

    def ood(self, object_index: int, placement_index: int) -> str:
        """Why case ``(object_index, placement_index)`` is out of distribution ("" = it is not)."""
        reasons = [
            r[i]
            for r, i in ((self.object_ood, object_index), (self.placement_ood, placement_index))
            if r and r[i]
        ]
        return "; ".join(reasons)

    def cases(self) -> list[tuple[int, ObjectSpec, int, Placement]]:
        """``(object_index, object, placement_index, placement)`` for every combination."""
        return [(i, o, j, p) for i, o in enumerate(self.objects) for j, p in enumerate(self.placements)]


def _sorted(keys) -> list:
    """Mapping keys sorted for a message (YAML keys need not be strings, nor of one type)."""
    return sorted(keys, key=repr)


def _show(value: Any, limit: int = 80) -> str:
    """``value`` for a message (:func:`lfd.io.files.show`: at most ``limit`` characters, bounded work)."""
    return show(value, limit)


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or None if it is not a finite real number."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        value = float(value)
    except OverflowError:  # an int beyond float range
        return None
    return value if math.isfinite(value) else None


def _numbers(value: Any, n: int) -> list[float] | None:
    """``value`` as a list of ``n`` finite floats, or None."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        return None
    out = [_number(v) for v in value]
    return None if any(v is None for v in out) else out


def _parse_object(entry: Any, where: str) -> ObjectSpec:
    """Structural checks here (fields present, known, numeric); value ranges by :class:`ObjectSpec`."""
    if not isinstance(entry, dict):
        raise ScenarioError(
            f"{where}: expected a mapping with fields {COMMON_FIELDS} + size fields, got {_show(entry)}"
        )
    shape = entry.get("shape")
    if not isinstance(shape, str) or shape not in SIZE_FIELDS:
        raise ScenarioError(f"{where}: field 'shape' must be one of {tuple(SIZE_FIELDS)}, got {_show(shape)}")
    allowed = set(COMMON_FIELDS) | set(SIZE_FIELDS[shape])
    unknown = _sorted(set(entry) - allowed)
    if unknown:
        raise ScenarioError(f"{where}: unknown field(s) {unknown} for a {shape}; allowed: {sorted(allowed)}")
    name = entry.get("name")
    if not isinstance(name, str) or not name:
        raise ScenarioError(f"{where}: field 'name' must be a non-empty string, got {_show(name)}")
    where = f"{where} ({name})"
    fields = {
        f: (3, "3 lengths [x, y, z] in metres") if f == "size" else (1, "a length in metres")
        for f in SIZE_FIELDS[shape]
    }
    fields["rgba"] = (4, "4 numbers in [0, 1]")
    fields["mass"] = (1, "a mass in kg")
    values: dict[str, list[float]] = {}
    for key, (n, expected) in fields.items():
        raw = entry.get(key, DEFAULT_MASS if key == "mass" else None)
        parsed = _numbers(raw, n) if n > 1 else [_number(raw)]
        if parsed is None or None in parsed:
            raise ScenarioError(f"{where}: field '{key}' must be {expected}, got {_show(raw)}")
        values[key] = parsed
    dims = tuple(v for f in SIZE_FIELDS[shape] for v in values[f])
    try:
        return ObjectSpec(
            shape=shape, dims=dims, rgba=tuple(values["rgba"]), mass=values["mass"][0], name=name
        )
    except ValueError as e:
        raise ScenarioError(f"{where}: {e}") from e


PLACEMENT_FIELDS = ("x", "y", "yaw", "yaw_deg")


def _parse_placement(entry: Any, where: str) -> Placement:
    """``[x, y, yaw]`` (yaw in rad) or ``{x, y, yaw | yaw_deg}``; yaw in rad within [-pi, pi]."""
    if isinstance(entry, dict):
        unknown = _sorted(set(entry) - set(PLACEMENT_FIELDS))
        if unknown:
            raise ScenarioError(
                f"{where}: unknown field(s) {unknown}; allowed: x, y (m) and one of yaw (rad), yaw_deg (deg)"
            )
        if ("yaw" in entry) == ("yaw_deg" in entry):
            raise ScenarioError(
                f"{where}: give exactly one of 'yaw' (radians) or 'yaw_deg' (degrees), got {_show(entry)}"
            )
        values = [_number(entry.get(k)) for k in ("x", "y")]
        if None in values:
            raise ScenarioError(f"{where}: fields 'x' and 'y' must be numbers (metres), got {_show(entry)}")
        x, y = values
        if "yaw_deg" in entry:
            deg = _number(entry["yaw_deg"])
            if deg is None or abs(deg) > 180:
                raise ScenarioError(
                    f"{where}: field 'yaw_deg' must be a number of degrees in [-180, 180], "
                    f"got {_show(entry['yaw_deg'])}"
                )
            yaw = math.radians(deg)
        else:
            yaw = _number(entry["yaw"])
            if yaw is None:
                raise ScenarioError(
                    f"{where}: field 'yaw' must be a number of radians, got {_show(entry['yaw'])}"
                )
    else:
        values = _numbers(entry, 3)
        if values is None:
            raise ScenarioError(
                f"{where}: expected [x, y, yaw] (metres, metres, radians) or {{x, y, yaw_deg}}, got {_show(entry)}"
            )
        x, y, yaw = values
    if abs(yaw) > math.pi + 1e-9:
        raise ScenarioError(
            f"{where}: yaw = {yaw} rad lies outside [-pi, pi]; yaw is in radians "
            f"(for degrees write yaw_deg: {yaw:g})"
        )
    if not (TABLE_X[0] <= x <= TABLE_X[1] and abs(y) <= TABLE_HALF_Y):
        raise ScenarioError(
            f"{where}: (x, y) = ({x}, {y}) m lies off the table "
            f"(x in [{TABLE_X[0]}, {TABLE_X[1]}], |y| <= {TABLE_HALF_Y}, torso frame)"
        )
    return Placement(x, y, yaw)


def object_corners(obj: ObjectSpec, placement: Placement, table_z: float = TABLE_Z) -> np.ndarray:
    """``(8, 3)`` corners (torso frame, m) of the object's bounding box standing at ``placement``."""
    half_xy = (obj.dims[0] / 2, obj.dims[1] / 2) if obj.shape == "box" else (obj.dims[0], obj.dims[0])
    c, s = math.cos(placement.yaw), math.sin(placement.yaw)
    pts = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            dx, dy = sx * half_xy[0], sy * half_xy[1]
            for z in (table_z, table_z + obj.height):
                pts.append((placement.x + c * dx - s * dy, placement.y + s * dx + c * dy, z))
    return np.array(pts)


def object_ood_reason(obj: ObjectSpec, families: tuple[str, ...], sizes: str = "classic") -> str:
    """Why ``obj`` lies outside the generator's training objects ("" = inside): a shape
    not among ``families`` or a dimension outside the training ranges of the size set
    ``sizes`` (:data:`~lfd.sim.objects.SIZE_SETS`)."""
    if obj.shape not in families:
        return f"shape {obj.shape} not among the training families {list(families)}"
    out = [
        f"{label} {value:.3f} m outside [{lo}, {hi}]"
        for label, value, (lo, hi) in zip(
            SHAPE_DIMS[obj.shape], obj.dims, SIZE_SETS[sizes].inside[obj.shape], strict=True
        )
        if not lo <= value <= hi
    ]
    return "; ".join(out)


def placement_ood_reason(placement: Placement, x_range, y_range, yaw_range_deg) -> str:
    """Why ``placement`` lies outside the training placement ranges ("" = inside)."""
    out = []
    for label, value, (lo, hi), unit in (
        ("x", placement.x, x_range, "m"),
        ("y", placement.y, y_range, "m"),
        ("yaw", math.degrees(placement.yaw), yaw_range_deg, "deg"),
    ):
        if not lo - 1e-9 <= value <= hi + 1e-9:
            out.append(f"{label} {value:.3f} {unit} outside [{lo}, {hi}]")
    return "; ".join(out)


def _check_camera(objects, placements, camera: Camera, table_z: float, path) -> None:
    for i, obj in enumerate(objects):
        for j, pl in enumerate(placements):
            uv = camera.project(object_corners(obj, pl, table_z))
            inside = np.isfinite(uv).all() and (uv[:, 0] >= 0).all() and (uv[:, 0] <= camera.width).all()
            inside = inside and (uv[:, 1] >= 0).all() and (uv[:, 1] <= camera.height).all()
            if not inside:
                raise ScenarioError(
                    f"{path}: objects[{i}] ({obj.name}) at placements[{j}] ({pl.x}, {pl.y}) m leaves the camera image "
                    f"(bounding box projects to u in [{np.nanmin(uv[:, 0]):.0f}, {np.nanmax(uv[:, 0]):.0f}], "
                    f"v in [{np.nanmin(uv[:, 1]):.0f}, {np.nanmax(uv[:, 1]):.0f}] px of {camera.width}x{camera.height})"
                )


def _check_reach(objects, placements, robot, table_z: float, path) -> None:
    """Every case's approach and pre-grasp poses must be solvable by the scripted expert's
    IK (:meth:`~lfd.sim.expert.ScriptedExpert.joint_targets`, the reach the demonstrations have)."""
    from lfd.sim.expert import DemoDiscarded, ScriptedExpert  # torch; only when a robot is given

    expert = ScriptedExpert(robot)
    for i, obj in enumerate(objects):
        for j, pl in enumerate(placements):
            plan = plan_approach(obj, pl, table_z=table_z)
            try:
                expert.joint_targets(plan)
            except DemoDiscarded as e:
                raise ScenarioError(
                    f"{path}: objects[{i}] ({obj.name}) at placements[{j}] ({pl.x}, {pl.y}) m is out of reach "
                    f"({plan.mode} approach): {e}"
                ) from e


def read_scenario_yaml(path: str | Path) -> dict:
    """The top-level mapping of the scenario file ``path``, parsed by :func:`lfd.io.files.read_yaml`
    from its bytes (UTF-8, or UTF-16 with a byte-order mark; no Python object is built from a
    tag; aliases, duplicate keys and deep nesting are refused, so the work is bounded by the
    file's size).

    Raises:
        ScenarioError: one line naming the file: missing, not a regular file, over
            :data:`MAX_SCENARIO_BYTES`, unreadable, not text, not YAML, refused, or not a mapping.
    """
    path = Path(path)
    try:
        data = read_yaml(path, max_bytes=MAX_SCENARIO_BYTES, what="a scenario YAML file")
    except FileNotFoundError:
        raise ScenarioError(f"scenario file not found: {path}") from None
    except YamlError as e:
        raise ScenarioError(str(e)) from None
    if not isinstance(data, dict):
        raise ScenarioError(
            f"{path}: expected a mapping with keys 'objects' and 'placements', got "
            f"{'an empty file' if data is None else type(data).__name__}"
        )
    return data


def load_scenario(
    path: str | Path,
    *,
    camera: Camera | None = None,
    robot: Any = None,
    training: Any = None,
    table_z: float = TABLE_Z,
) -> Scenario:
    """Read and validate a scenario YAML file (format in the module docstring).

    Args:
        path: the YAML file.
        camera: the fixed camera every object must stay inside of (default :class:`Camera`).
        robot: robot model for the reach check (None: no reach check).
        training: a :class:`~lfd.visuomotor.data.GeneratorConfig`; objects and placements outside its
            ranges are warned about and marked (:meth:`Scenario.ood`). None: nothing marked.
        table_z: table top height in the torso frame.

    Raises:
        ScenarioError: missing, unreadable or unparsable file (:func:`read_scenario_yaml`), or
            a bad field (file, entry and field named).
    """
    path = Path(path)
    data = read_scenario_yaml(path)
    unknown = _sorted(set(data) - {"objects", "placements"})
    if unknown:
        raise ScenarioError(
            f"{path}: unknown top-level key(s) {unknown}; expected 'objects' and 'placements'"
        )
    lists = {}
    for key in ("objects", "placements"):
        value = data.get(key)
        if not isinstance(value, list) or not value:
            raise ScenarioError(f"{path}: '{key}' must be a non-empty list, got {_show(value)}")
        lists[key] = value
    n_cases = len(lists["objects"]) * len(lists["placements"])
    if n_cases > MAX_SCENARIO_CASES:
        raise ScenarioError(
            f"{path}: {len(lists['objects'])} objects x {len(lists['placements'])} placements = {n_cases} cases; "
            f"a scenario has at most {MAX_SCENARIO_CASES} (split it into several files)"
        )
    objects = tuple(_parse_object(o, f"{path}: objects[{i}]") for i, o in enumerate(lists["objects"]))
    names = [o.name for o in objects]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise ScenarioError(f"{path}: object names must be unique, repeated: {duplicates}")
    placements = tuple(
        _parse_placement(p, f"{path}: placements[{i}]") for i, p in enumerate(lists["placements"])
    )
    _check_camera(objects, placements, camera if camera is not None else Camera(), table_z, path)
    if robot is not None:
        _check_reach(objects, placements, robot, table_z, path)
    object_ood = placement_ood = ()
    if training is not None:
        object_ood = tuple(
            object_ood_reason(o, training.group_families("train"), training.sizes) for o in objects
        )
        placement_ood = tuple(
            placement_ood_reason(p, training.x_range, training.y_range, training.yaw_range_deg)
            for p in placements
        )
        notes = [f"objects[{i}] ({o.name}): {r}" for i, (o, r) in enumerate(zip(objects, object_ood)) if r]
        notes += [f"placements[{j}]: {r}" for j, r in enumerate(placement_ood) if r]
        if notes:
            msg = f"{path}: outside the training ranges (marked ood in episodes.csv): " + " | ".join(notes)
            warnings.warn(msg, UserWarning, stacklevel=2)
            print(f"[lfd] warning: {msg}")
    return Scenario(
        objects=objects,
        placements=placements,
        source=str(path),
        object_ood=object_ood,
        placement_ood=placement_ood,
    )
