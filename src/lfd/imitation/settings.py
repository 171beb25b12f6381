"""Typed, validated settings of the imitation pipeline (the keys of ``configs/imitate.yaml``).

:class:`ImitationSettings` holds the top-level keys and one frozen dataclass per config section
(:class:`PoseSettings` ``pose``, :class:`MultiviewSettings` ``multiview``, :class:`AnalysisSettings`
``analysis``, :class:`DMPSettings` ``dmp``, :class:`SimSettings` ``sim``, :class:`RefineSettings`
``refine``, :class:`OutputSettings` ``outputs``). Every value is checked once, in ``__post_init__``,
before any file is read: a bad value raises ``ValueError`` with one line naming the field (as the
config spells it, e.g. ``refine.target``) and what it must be. Lists become tuples; defaults are
those of ``configs/imitate.yaml``.

The robots offered are the catalogue's (:func:`lfd.robots.catalogue.catalogue_entries`) whose entry
says how a person's arm is retargeted to them (``retarget``); nothing here names a robot.

Units: s, rad, m, px, Hz, kg.

Example::

    from lfd.imitation.settings import DMPSettings, ImitationSettings

    s = ImitationSettings(source="arm.bag", robot="wam4", dmp=DMPSettings(n_basis=30))
    s = ImitationSettings.from_mapping({"source": "arm.bag", "refine": {"task": "reach", "target": [0.4, 0.2, 0.1]}})
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeVar

from lfd.human.filters import FILTERS
from lfd.human.video.estimator import MODELS
from lfd.io.rosbag import BAG_FORMATS
from lfd.rl.skill import SKILL_TASKS
from lfd.robots.catalogue import catalogue_entries

from .refine import METHODS
from .sources import SOURCE_TYPES, is_path_list

__all__ = [
    "ENTRY_POINT_KEYS",
    "AnalysisSettings",
    "DMPSettings",
    "ImitationSettings",
    "MultiviewSettings",
    "OutputSettings",
    "PoseSettings",
    "RefineSettings",
    "SimSettings",
    "imitation_robots",
]

#: Keys of the composed Hydra config that belong to the entry point, not to the pipeline (ignored).
ENTRY_POINT_KEYS = ("task_name", "paths", "hydra")


def imitation_robots() -> tuple[str, ...]:
    """Catalogue robots a demonstration can be imitated on: those whose entry has a ``retarget`` kind."""
    return tuple(e.name for e in catalogue_entries() if e.retarget is not None)


# ---------------------------------------------------------------------------------------------- checks
def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _choice(name: str, value: Any, choices: Sequence, nullable: bool = False) -> None:
    if value is None and nullable:
        return
    if value not in choices:
        null = " (or null)" if nullable else ""
        raise ValueError(f"{name} must be one of {', '.join(map(str, choices))}{null}, got {value!r}")


def _number(name: str, value: Any, *, minimum: float = 0.0, strict: bool = True, nullable: bool = False):
    """``value`` as a float checked against ``minimum`` (``> minimum`` when strict, else ``>=``)."""
    if value is None and nullable:
        return None
    ok = _is_number(value) and (value > minimum if strict else value >= minimum)
    if not ok:
        bound = f"{'>' if strict else '>='} {minimum:g}"
        raise ValueError(f"{name} must be a number {bound}{' (or null)' if nullable else ''}, got {value!r}")
    return float(value)


def _integer(name: str, value: Any, *, minimum: int = 1, nullable: bool = False):
    if value is None and nullable:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(
            f"{name} must be an integer >= {minimum}{' (or null)' if nullable else ''}, got {value!r}"
        )
    return int(value)


def _flag(name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")
    return value


def _text(name: str, value: Any, nullable: bool = True):
    if value is None and nullable:
        return None
    if not isinstance(value, str | os.PathLike) or not str(value):
        raise ValueError(
            f"{name} must be a non-empty string{' (or null)' if nullable else ''}, got {value!r}"
        )
    return str(value)


def _point(name: str, value: Any, nullable: bool = True, what: str = "a tool position [x, y, z] in metres"):
    if value is None and nullable:
        return None
    values = list(value) if is_path_list(value) else []
    if len(values) != 3 or not all(_is_number(v) for v in values):
        shown = values if values else value
        raise ValueError(f"{name} must be {what}, got {shown}")
    return tuple(float(v) for v in values)


# ---------------------------------------------------------------------------------------------- sections
@dataclass(frozen=True)
class PoseSettings:
    """``pose``: MediaPipe keypoints of a video.

    Attributes:
        model: ``"full"`` or ``"heavy"`` (:data:`lfd.human.video.estimator.MODELS`).
        heavy_model: path of a verified heavy model file; None: MediaPipe's module folder.
        width: px, frames are resized to this width. stride: every n-th frame (>= 1).
        max_frames: at most this many frames (None: the whole video).
        min_visibility: landmarks below (0..1) are treated as missing.
        repair_flips: undo MediaPipe's front/back relabelling. lift_depth: arm depth from bone lengths.
    """

    model: str = "full"
    heavy_model: str | None = None
    width: int = 640
    stride: int = 1
    max_frames: int | None = None
    min_visibility: float = 0.5
    repair_flips: bool = True
    lift_depth: bool = True

    def __post_init__(self) -> None:
        _choice("pose.model", self.model, tuple(MODELS))
        _set(self, "heavy_model", _text("pose.heavy_model", self.heavy_model))
        _set(self, "width", _integer("pose.width", self.width, minimum=16))
        _set(self, "stride", _integer("pose.stride", self.stride))
        _set(self, "max_frames", _integer("pose.max_frames", self.max_frames, nullable=True))
        visibility = _number("pose.min_visibility", self.min_visibility, strict=False)
        if visibility > 1.0:
            raise ValueError(f"pose.min_visibility must be within [0, 1], got {self.min_visibility!r}")
        _set(self, "min_visibility", visibility)
        _flag("pose.repair_flips", self.repair_flips)
        _flag("pose.lift_depth", self.lift_depth)

    def estimator_options(self, progress: bool = True) -> dict:
        """Keyword arguments of :func:`lfd.human.video.estimate_keypoints`."""
        return dict(
            width=self.width,
            stride=self.stride,
            max_frames=self.max_frames,
            progress=progress,
            model=self.model,
            heavy_model=self.heavy_model,
        )


@dataclass(frozen=True)
class MultiviewSettings:
    """``multiview``: several calibrated videos (:mod:`lfd.imitation.multiview`).

    Attributes:
        max_error_px: views reprojecting worse than this (px, > 0) are dropped per joint and frame.
        other_person_px: a view fitting the others worse than this (px) shows someone else; None: never.
        up: the calibration's world up vector (3 numbers, not zero).
    """

    max_error_px: float = 20.0
    other_person_px: float | None = 50.0
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        _set(self, "max_error_px", _number("multiview.max_error_px", self.max_error_px))
        _set(
            self,
            "other_person_px",
            _number("multiview.other_person_px", self.other_person_px, nullable=True),
        )
        up = _point("multiview.up", self.up, nullable=False, what="a non-zero vector [x, y, z]")
        if math.hypot(*up) < 1e-9:
            raise ValueError(f"multiview.up must be a non-zero vector [x, y, z], got {list(up)}")
        _set(self, "up", up)


@dataclass(frozen=True)
class AnalysisSettings:
    """``analysis``: options of :func:`lfd.human.analyze_arm`.

    Attributes:
        filter: one of :data:`lfd.human.filters.FILTERS`. cutoff: Hz (> 0). max_gap: s (>= 0), longest gap
        filled. body_mass: kg (> 0). sex: ``"male"`` or ``"female"`` (de Leva segment fractions).
    """

    filter: str = "butterworth"
    cutoff: float = 6.0
    max_gap: float = 0.3
    body_mass: float = 75.0
    sex: str = "male"

    def __post_init__(self) -> None:
        _choice("analysis.filter", self.filter, FILTERS)
        _set(self, "cutoff", _number("analysis.cutoff", self.cutoff))
        _set(self, "max_gap", _number("analysis.max_gap", self.max_gap, strict=False))
        _set(self, "body_mass", _number("analysis.body_mass", self.body_mass))
        _choice("analysis.sex", self.sex, ("male", "female"))


@dataclass(frozen=True)
class DMPSettings:
    """``dmp``: the DMP's basis functions.

    Attributes:
        n_basis: a positive integer, or ``"auto"``: ``max(min_basis, ceil(basis_per_second x duration))``.
        basis_per_second: > 0 (auto only). min_basis: a positive integer (auto only).
    """

    n_basis: int | str = "auto"
    basis_per_second: float = 10.0
    min_basis: int = 30

    def __post_init__(self) -> None:
        n = self.n_basis
        if not (n == "auto" or (isinstance(n, int) and not isinstance(n, bool) and n >= 1)):
            raise ValueError(f"dmp.n_basis must be a positive integer or 'auto', got {n!r}")
        rate, least = self.basis_per_second, self.min_basis
        if not (_is_number(rate) and rate > 0 and isinstance(least, int) and not isinstance(least, bool)):
            least = None
        if least is None or least < 1:
            raise ValueError(
                f"dmp.basis_per_second must be > 0 and dmp.min_basis a positive integer, "
                f"got {self.basis_per_second!r}, {self.min_basis!r}"
            )
        _set(self, "basis_per_second", float(rate))


@dataclass(frozen=True)
class SimSettings:
    """``sim``: the PyBullet execution.

    Attributes:
        rate: Hz physics (> 0). position_gain, velocity_gain: the position controller's gains (> 0).
        image_size: ``(width, height)`` px of the robot renders.
    """

    rate: float = 240.0
    position_gain: float = 0.3
    velocity_gain: float = 1.0
    image_size: tuple[int, int] = (320, 320)

    def __post_init__(self) -> None:
        _set(self, "rate", _number("sim.rate", self.rate))
        _set(self, "position_gain", _number("sim.position_gain", self.position_gain))
        _set(self, "velocity_gain", _number("sim.velocity_gain", self.velocity_gain))
        size = list(self.image_size) if is_path_list(self.image_size) else []
        if len(size) != 2 or not all(isinstance(v, int) and not isinstance(v, bool) and v >= 8 for v in size):
            shown = list(size) if size else self.image_size
            raise ValueError(f"sim.image_size must be [width, height] in px (integers >= 8), got {shown}")
        _set(self, "image_size", (size[0], size[1]))


@dataclass(frozen=True)
class RefineSettings:
    """``refine``: policy search for a task (:mod:`lfd.imitation.refine`); ``task`` None: no refinement.

    Attributes:
        task: one of :data:`lfd.rl.skill.SKILL_TASKS` or None. target: ``(3,)`` m, robot base frame (needed
            with a task). method: one of :data:`lfd.imitation.refine.METHODS`. tol: m (> 0).
        max_rollouts: >= 2. shape_weight: >= 0. t_via: s in the demonstration's time (None: the middle).
        radius: m (> 0), the avoid task's clearance. goal_init: ``"demo"`` or ``"ik"``. seed: integer.
    """

    task: str | None = None
    target: tuple[float, float, float] | None = None
    method: str = "power"
    tol: float = 0.01
    max_rollouts: int = 400
    shape_weight: float = 0.1
    t_via: float | None = None
    radius: float = 0.05
    goal_init: str = "demo"
    seed: int = 0

    def __post_init__(self) -> None:
        _choice("refine.task", self.task, SKILL_TASKS, nullable=True)
        _choice("refine.method", self.method, METHODS)
        _set(self, "target", _point("refine.target", self.target, nullable=self.task is None))
        _set(self, "tol", _number("refine.tol", self.tol))
        _set(self, "max_rollouts", _integer("refine.max_rollouts", self.max_rollouts, minimum=2))
        _set(self, "shape_weight", _number("refine.shape_weight", self.shape_weight, strict=False))
        _set(self, "t_via", _number("refine.t_via", self.t_via, strict=False, nullable=True))
        _set(self, "radius", _number("refine.radius", self.radius))
        _choice("refine.goal_init", self.goal_init, ("demo", "ik"))
        _set(self, "seed", _integer("refine.seed", self.seed, minimum=0))


@dataclass(frozen=True)
class OutputSettings:
    """``outputs``: what is written besides ``dmp.json``, ``robot_trajectory.csv`` and ``summary.json``.

    Attributes:
        bag: ``robot_trajectory.bag`` as ``"ros1"``, ``"ros2"`` or ``"mcap"`` (a bag folder), None: none.
        video, gif: the side-by-side MP4 / GIF of a video source. gif_frames: at most this many GIF frames.
    """

    bag: str | None = "ros1"
    video: bool = True
    gif: bool = True
    gif_frames: int = 60

    def __post_init__(self) -> None:
        _choice("outputs.bag", self.bag, BAG_FORMATS, nullable=True)
        _flag("outputs.video", self.video)
        _flag("outputs.gif", self.gif)
        _set(self, "gif_frames", _integer("outputs.gif_frames", self.gif_frames))


# ---------------------------------------------------------------------------------------------- top level
@dataclass(frozen=True)
class ImitationSettings:
    """Every setting of one imitation run (``configs/imitate.yaml``; see the module docstring).

    Attributes:
        source: the demonstration: a path, or several video paths (a multiview source); None: ``video``.
        video: older name of ``source`` for a video. source_type: one of
            :data:`lfd.imitation.sources.SOURCE_TYPES`, None: detected from the path.
        calibration: multiview: the cameras' calibration file. units: skeleton files: ``"m"``, ``"cm"``,
            ``"mm"`` (None: the format's own). topic: bags: the JointState topic (None: the only one).
        joint_names: bags / joint CSV: the recording's names for the robot's joints, in robot order.
        robot: one of :func:`imitation_robots`. side: ``"left"`` or ``"right"``, the person's arm.
        wam_mount: ``"auto"`` or ``"side"``, the WAM base orientation at the shoulder (posture retargeting).
        goal: a new goal for the skill, tool position ``(3,)`` m in the robot base frame; None: the demonstrated.
        pose, multiview, analysis, dmp, sim, refine, outputs: the sections.
    """

    source: str | tuple[str, ...] | None = None
    video: str | None = None
    source_type: str | None = None
    calibration: str | None = None
    units: str | None = None
    topic: str | None = None
    joint_names: tuple[str, ...] | None = None
    robot: str = "wam4"
    side: str = "right"
    wam_mount: str = "auto"
    goal: tuple[float, float, float] | None = None
    pose: PoseSettings = field(default_factory=PoseSettings)
    multiview: MultiviewSettings = field(default_factory=MultiviewSettings)
    analysis: AnalysisSettings = field(default_factory=AnalysisSettings)
    dmp: DMPSettings = field(default_factory=DMPSettings)
    sim: SimSettings = field(default_factory=SimSettings)
    refine: RefineSettings = field(default_factory=RefineSettings)
    outputs: OutputSettings = field(default_factory=OutputSettings)

    SECTIONS: ClassVar[dict[str, type]] = {
        "pose": PoseSettings,
        "multiview": MultiviewSettings,
        "analysis": AnalysisSettings,
        "dmp": DMPSettings,
        "sim": SimSettings,
        "refine": RefineSettings,
        "outputs": OutputSettings,
    }

    def __post_init__(self) -> None:
        robots = imitation_robots()
        if self.robot not in robots:
            raise ValueError(f"robot must be one of {', '.join(robots)}, got {self.robot!r}")
        _choice("side", self.side, ("left", "right"))
        _choice("wam_mount", self.wam_mount, ("auto", "side"))
        if self.source_type is not None and self.source_type not in SOURCE_TYPES:
            raise ValueError(
                f"source_type must be one of {', '.join(SOURCE_TYPES)} (or null: detected), got {self.source_type!r}"
            )
        if is_path_list(self.source):
            _set(self, "source", tuple(str(_text("source", s, nullable=False)) for s in self.source))
        else:
            _set(self, "source", _text("source", self.source))
        _set(self, "video", _text("video", self.video))
        _set(self, "calibration", _text("calibration", self.calibration))
        _choice("units", self.units, ("m", "cm", "mm"), nullable=True)
        _set(self, "topic", _text("topic", self.topic))
        if self.joint_names is not None:
            names = list(self.joint_names) if is_path_list(self.joint_names) else None
            if not names or not all(isinstance(n, str) and n for n in names):
                raise ValueError(
                    f"joint_names must be a list of joint names (or null), got {self.joint_names!r}"
                )
            _set(self, "joint_names", tuple(names))
        _set(self, "goal", _point("goal", self.goal))
        for name, kind in self.SECTIONS.items():
            if not isinstance(getattr(self, name), kind):
                raise ValueError(
                    f"{name} must be a {kind.__name__}, got {type(getattr(self, name)).__name__}"
                )

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> ImitationSettings:
        """Settings from a mapping of the config's keys (e.g. ``OmegaConf.to_container(cfg, resolve=True)``,
        or a composed config itself, which is a mapping); sections are mappings of their keys, lists may be
        any sequence. :data:`ENTRY_POINT_KEYS` are ignored.

        Raises:
            ValueError: an unknown key (named), or a bad value (see the classes).
        """
        top = {k: v for k, v in values.items() if k not in ENTRY_POINT_KEYS}
        kwargs = _fields_of(cls, top, "")
        for name, kind in cls.SECTIONS.items():
            if name in kwargs:
                section = kwargs[name]
                if not isinstance(section, Mapping):
                    raise ValueError(f"{name} must be a section of settings, got {section!r}")
                kwargs[name] = kind(**_fields_of(kind, section, f"{name}."))
        return cls(**kwargs)

    @property
    def demonstration(self) -> str | list[str]:
        """The demonstration path: ``source``, or ``video``; several calibrated videos as a ``list[str]``.

        Raises:
            ValueError: neither is given.
        """
        source = self.source or self.video
        if source is None:
            raise ValueError("source: give the demonstration, e.g. source=person.mp4 or source=arm.bag")
        return list(source) if isinstance(source, tuple) else source


_T = TypeVar("_T")


def _plain(value: Any) -> Any:
    """Sequences (lists, a config's list nodes) as tuples, recursively; mappings and scalars unchanged."""
    if is_path_list(value) and not isinstance(value, Mapping):
        return tuple(_plain(v) for v in value)
    return value


def _fields_of(cls: type[_T], values: Mapping[str, Any], prefix: str) -> dict[str, Any]:
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(str(k) for k in values if k not in names)
    if unknown:
        raise ValueError(
            f"unknown setting(s) {', '.join(prefix + k for k in unknown)}; known: {', '.join(sorted(names))}"
        )
    return {str(k): _plain(v) for k, v in values.items()}
