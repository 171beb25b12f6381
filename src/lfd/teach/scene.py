"""Teach scenes: start pose, box obstacles, goal region and table, in the robot base frame.

A scene is a YAML file or the same dict (metres, radians; ``yaw_deg`` in degrees, the
one unit converted at this edge)::

    start: [0.0, 0.6, 0.0, 1.6]          # rad, one per joint (default: the robot's home)
    # or one start per robot; an arm not listed starts at its home pose:
    # start: {wam4: [0.0, 0.6, 0.0, 1.6], sawyer: [0, -0.8, 0, 2.1, 0, 0.3, 0]}
    obstacles:
      - {center: [0.55, 0.0, 0.15], size: [0.12, 0.5, 0.3], yaw_deg: 0}
    goal: {center: [0.45, -0.4, 0.1], radius: 0.06}
    table_z: -0.05                       # optional: a table top at this height

:func:`load_scene` checks every field and raises ``ValueError`` naming it; the checks
that need the robot (start within limits, obstacle overlapping the robot base, goal
unreachable, start in collision) are in :meth:`TeachScene.validate_for` and run when a
:class:`~lfd.teach.session.TeachSession` is built.

Example::

    >>> from lfd.teach.scene import load_scene
    >>> scene = load_scene({"goal": {"center": [0.5, 0.0, 0.3], "radius": 0.05}})
    >>> scene.goal.radius, scene.obstacles
    (0.05, ())
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lfd.io.files import read_yaml, show

__all__ = ["Box", "Goal", "TeachScene", "load_scene"]

_TOP_KEYS = {"start", "obstacles", "goal", "table_z", "name"}
_BOX_KEYS = {"center", "size", "yaw_deg"}
_GOAL_KEYS = {"center", "radius"}


def _vector(value: Any, length: int | None, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"scene field '{name}' must be a list of numbers, got {show(value)}") from None
    if arr.ndim != 1 or (length is not None and arr.shape[0] != length):
        want = f"{length} numbers" if length is not None else "a flat list of numbers"
        raise ValueError(f"scene field '{name}' must be {want}, got {show(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"scene field '{name}' contains NaN or inf: {show(value)}")
    return arr


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"scene field '{name}' must be a finite number, got {show(value)}")
    return float(value)


def _unknown(keys, allowed: set[str], where: str) -> None:
    extra = sorted(set(keys) - allowed)
    if extra:
        raise ValueError(f"scene {where} has unknown key(s) {extra}; allowed: {sorted(allowed)}")


@dataclass(frozen=True)
class Box:
    """An axis-aligned box turned by ``yaw`` about the vertical: ``center`` (3,) m,
    ``size`` (3,) full edge lengths m, ``yaw`` rad."""

    center: np.ndarray
    size: np.ndarray
    yaw: float = 0.0

    def to_dict(self) -> dict:
        return {"center": self.center.tolist(), "size": self.size.tolist(), "yaw_deg": math.degrees(self.yaw)}

    def distance(self, points: np.ndarray) -> np.ndarray:
        """(P,) Euclidean distance (m) from ``points`` (P, 3) to the box (0 inside)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        d = np.asarray(points, dtype=float) - self.center
        local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]], axis=1)
        outside = np.maximum(np.abs(local) - self.size / 2.0, 0.0)
        return np.linalg.norm(outside, axis=1)


@dataclass(frozen=True)
class Goal:
    """A spherical goal region: ``center`` (3,) m and ``radius`` m."""

    center: np.ndarray
    radius: float

    def contains(self, point: np.ndarray) -> bool:
        return bool(np.linalg.norm(np.asarray(point, dtype=float) - self.center) <= self.radius)

    def overlaps(self, box: Box) -> bool:
        """Whether ``box`` reaches into the goal sphere (the tool could no longer enter it there)."""
        return bool(box.distance(self.center[None])[0] < self.radius)

    def to_dict(self) -> dict:
        return {"center": self.center.tolist(), "radius": self.radius}


@dataclass(frozen=True)
class TeachScene:
    """A validated scene (see module docstring). ``start`` is None for the robot's home, one
    configuration, or ``{robot name: configuration}`` (:meth:`start_for`)."""

    start: np.ndarray | dict[str, np.ndarray] | None
    obstacles: tuple[Box, ...]
    goal: Goal | None
    table_z: float | None = None
    name: str = "scene"
    source: str = field(default="<dict>", compare=False)

    def to_dict(self) -> dict:
        out: dict[str, Any] = {"name": self.name, "obstacles": [b.to_dict() for b in self.obstacles]}
        if isinstance(self.start, dict):
            out["start"] = {name: q.tolist() for name, q in self.start.items()}
        elif self.start is not None:
            out["start"] = self.start.tolist()
        if self.goal is not None:
            out["goal"] = self.goal.to_dict()
        if self.table_z is not None:
            out["table_z"] = self.table_z
        return out

    def start_for(self, robot: str) -> np.ndarray | None:
        """The start configuration of ``robot`` (None: its home pose, also when the scene lists
        starts of other robots only)."""
        if isinstance(self.start, dict):
            return self.start.get(robot)
        return self.start

    def with_obstacle(self, box: Box) -> TeachScene:
        """A copy with one more obstacle."""
        return TeachScene(
            self.start, self.obstacles + (box,), self.goal, self.table_z, self.name, self.source
        )


def load_scene(scene: str | os.PathLike | Mapping | TeachScene | None) -> TeachScene:
    """Read and check a scene from a YAML path or a dict (``None``: empty scene).

    Raises:
        FileNotFoundError: no file at the path.
        ValueError: malformed YAML, unknown keys, wrong lengths, non-finite numbers,
            non-positive sizes or radius; the message names the field.
    """
    if isinstance(scene, TeachScene):
        return scene
    source = "<dict>"
    if scene is None:
        scene = {}
    elif isinstance(scene, (str, os.PathLike)):
        path = Path(scene)
        if not path.is_file():
            raise FileNotFoundError(f"scene file not found: {path}")
        loaded = read_yaml(path, what="a scene YAML file")  # one line naming the file (YamlError)
        source = str(path)
        scene = {} if loaded is None else loaded
        if "name" not in scene and isinstance(scene, Mapping):
            scene = {**scene, "name": path.stem}
    if source == "<dict>":
        return _parse_scene(scene, source)
    try:
        return _parse_scene(scene, source)
    except ValueError as e:  # a field of a file: the line names the file too
        raise ValueError(f"{source}: {e}") from None


def _parse_scene(scene, source: str) -> TeachScene:
    """The checked :class:`TeachScene` of a mapping (:func:`load_scene`'s contract; errors name the field)."""
    if not isinstance(scene, Mapping):
        raise ValueError(f"a scene must be a mapping (dict / YAML mapping), got {type(scene).__name__}")
    _unknown(scene.keys(), _TOP_KEYS, "")
    raw_start = scene.get("start")
    if isinstance(raw_start, Mapping):
        if not all(isinstance(k, str) for k in raw_start):
            raise ValueError(
                f"scene field 'start' must map robot names to joint angles, got {show(raw_start)}"
            )
        start = {k: _vector(v, None, f"start.{k}") for k, v in raw_start.items()}
    else:
        start = None if raw_start is None else _vector(raw_start, None, "start")
    raw_obstacles = scene.get("obstacles") or []
    if not isinstance(raw_obstacles, (list, tuple)):
        raise ValueError(f"scene field 'obstacles' must be a list, got {show(raw_obstacles)}")
    boxes = []
    for i, ob in enumerate(raw_obstacles):
        where = f"obstacles[{i}]"
        if not isinstance(ob, Mapping):
            raise ValueError(f"scene field '{where}' must be a mapping with center/size, got {show(ob)}")
        _unknown(ob.keys(), _BOX_KEYS, f"'{where}'")
        for key in ("center", "size"):
            if key not in ob:
                raise ValueError(f"scene field '{where}.{key}' is missing")
        center = _vector(ob["center"], 3, f"{where}.center")
        size = _vector(ob["size"], 3, f"{where}.size")
        if np.any(size <= 0):
            raise ValueError(f"scene field '{where}.size' must be positive (m), got {size.tolist()}")
        yaw = math.radians(_number(ob.get("yaw_deg", 0.0), f"{where}.yaw_deg"))
        boxes.append(Box(center, size, yaw))
    goal = None
    if scene.get("goal") is not None:
        g = scene["goal"]
        if not isinstance(g, Mapping):
            raise ValueError(f"scene field 'goal' must be a mapping with center/radius, got {show(g)}")
        _unknown(g.keys(), _GOAL_KEYS, "'goal'")
        for key in ("center", "radius"):
            if key not in g:
                raise ValueError(f"scene field 'goal.{key}' is missing")
        radius = _number(g["radius"], "goal.radius")
        if radius <= 0:
            raise ValueError(f"scene field 'goal.radius' must be positive (m), got {radius}")
        goal = Goal(_vector(g["center"], 3, "goal.center"), radius)
    table_z = None if scene.get("table_z") is None else _number(scene["table_z"], "table_z")
    name = str(scene.get("name", "scene"))
    return TeachScene(start, tuple(boxes), goal, table_z, name, source)
