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
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeVar

from lfd.checks import (
    ENTRY_POINT_KEYS,
    check_choice,
    check_flag,
    check_float,
    check_int,
    check_keys,
    check_text,
    check_vector,
    positive_float,
    positive_int,
)
from lfd.human.filters import FILTERS
from lfd.human.video.estimator import MODELS
from lfd.human.video.people import check_person
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

#: What a tool position must be, as a bad one's message says.
_POSITION = "a tool position [x, y, z] in metres"


def imitation_robots() -> tuple[str, ...]:
    """Catalogue robots a demonstration can be imitated on: those whose entry has a ``retarget`` kind."""
    return tuple(e.name for e in catalogue_entries() if e.retarget is not None)


# ---------------------------------------------------------------------------------------------- checks
def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


def _point(value: Any, name: str, *, what: str = _POSITION, optional: bool = True):
    """``value`` as a tuple of 3 floats (:func:`lfd.checks.check_vector`); None too when ``optional``."""
    point = check_vector(value, 3, name, what=what, optional=optional)
    return None if point is None else tuple(float(v) for v in point)


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
        person: who to follow when several people are in view: None (MediaPipe's single-person
            tracker, the most prominent person), ``"largest"``, ``"central"``, a point ``[x, y]`` or
            a box ``[x0, y0, x1, y1]`` px in the first frame with anyone (:mod:`lfd.human.video.people`).
    """

    model: str = "full"
    heavy_model: str | None = None
    width: int = 640
    stride: int = 1
    max_frames: int | None = None
    min_visibility: float = 0.5
    repair_flips: bool = True
    lift_depth: bool = True
    person: Any = None

    def __post_init__(self) -> None:
        check_choice(self.model, "pose.model", tuple(MODELS))
        if self.person is not None:
            try:
                _set(self, "person", check_person(self.person))
            except ValueError as exc:
                raise ValueError(f"pose.{exc}") from None
        _set(self, "heavy_model", check_text(self.heavy_model, "pose.heavy_model", optional=True))
        _set(self, "width", check_int(self.width, "pose.width", minimum=16))
        _set(self, "stride", positive_int(self.stride, "pose.stride"))
        _set(self, "max_frames", check_int(self.max_frames, "pose.max_frames", minimum=1, optional=True))
        _set(
            self, "min_visibility", check_float(self.min_visibility, "pose.min_visibility", low=0.0, high=1.0)
        )
        check_flag(self.repair_flips, "pose.repair_flips")
        check_flag(self.lift_depth, "pose.lift_depth")

    def estimator_options(self, progress: bool = True) -> dict:
        """Keyword arguments of :func:`lfd.human.video.estimate_keypoints`."""
        return dict(
            width=self.width,
            stride=self.stride,
            max_frames=self.max_frames,
            progress=progress,
            model=self.model,
            heavy_model=self.heavy_model,
            person=self.person,
        )


@dataclass(frozen=True)
class MultiviewSettings:
    """``multiview``: several calibrated videos (:mod:`lfd.imitation.multiview`).

    Attributes:
        max_error_px: views reprojecting worse than this (px, > 0) are dropped per joint and frame.
        other_person_px: a view fitting the others worse than this (px) shows someone else; None: never.
        up: the calibration's world up vector (3 numbers, not zero).
        person_view: the view (index in the calibration's order) in which ``pose.person`` is chosen.
    """

    max_error_px: float = 20.0
    other_person_px: float | None = 50.0
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    person_view: int = 0

    def __post_init__(self) -> None:
        _set(self, "max_error_px", positive_float(self.max_error_px, "multiview.max_error_px"))
        _set(self, "person_view", check_int(self.person_view, "multiview.person_view", minimum=0))
        other = check_float(
            self.other_person_px, "multiview.other_person_px", low=0.0, strict_low=True, optional=True
        )
        _set(self, "other_person_px", other)
        up = _point(self.up, "multiview.up", what="a non-zero vector [x, y, z]", optional=False)
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
        check_choice(self.filter, "analysis.filter", FILTERS)
        _set(self, "cutoff", positive_float(self.cutoff, "analysis.cutoff"))
        _set(self, "max_gap", check_float(self.max_gap, "analysis.max_gap", low=0.0))
        _set(self, "body_mass", positive_float(self.body_mass, "analysis.body_mass"))
        check_choice(self.sex, "analysis.sex", ("male", "female"))


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
        _set(self, "basis_per_second", positive_float(self.basis_per_second, "dmp.basis_per_second"))
        _set(self, "min_basis", positive_int(self.min_basis, "dmp.min_basis"))


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
        _set(self, "rate", positive_float(self.rate, "sim.rate"))
        _set(self, "position_gain", positive_float(self.position_gain, "sim.position_gain"))
        _set(self, "velocity_gain", positive_float(self.velocity_gain, "sim.velocity_gain"))
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
        check_choice(self.task, "refine.task", SKILL_TASKS, optional=True)
        check_choice(self.method, "refine.method", METHODS)
        _set(self, "target", _point(self.target, "refine.target", optional=self.task is None))
        _set(self, "tol", positive_float(self.tol, "refine.tol"))
        _set(self, "max_rollouts", check_int(self.max_rollouts, "refine.max_rollouts", minimum=2))
        _set(self, "shape_weight", check_float(self.shape_weight, "refine.shape_weight", low=0.0))
        _set(self, "t_via", check_float(self.t_via, "refine.t_via", low=0.0, optional=True))
        _set(self, "radius", positive_float(self.radius, "refine.radius"))
        check_choice(self.goal_init, "refine.goal_init", ("demo", "ik"))
        _set(self, "seed", check_int(self.seed, "refine.seed", minimum=0))


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
        check_choice(self.bag, "outputs.bag", BAG_FORMATS, optional=True)
        check_flag(self.video, "outputs.video")
        check_flag(self.gif, "outputs.gif")
        _set(self, "gif_frames", positive_int(self.gif_frames, "outputs.gif_frames"))


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
        check_choice(self.robot, "robot", imitation_robots())
        check_choice(self.side, "side", ("left", "right"))
        check_choice(self.wam_mount, "wam_mount", ("auto", "side"))
        check_choice(self.source_type, "source_type", SOURCE_TYPES, optional=True)
        if is_path_list(self.source):
            _set(self, "source", tuple(check_text(s, "source") for s in self.source))
        else:
            _set(self, "source", check_text(self.source, "source", optional=True))
        _set(self, "video", check_text(self.video, "video", optional=True))
        _set(self, "calibration", check_text(self.calibration, "calibration", optional=True))
        check_choice(self.units, "units", ("m", "cm", "mm"), optional=True)
        _set(self, "topic", check_text(self.topic, "topic", optional=True))
        if self.joint_names is not None:
            names = list(self.joint_names) if is_path_list(self.joint_names) else None
            if not names or not all(isinstance(n, str) and n for n in names):
                raise ValueError(
                    f"joint_names must be a list of joint names (or null), got {self.joint_names!r}"
                )
            _set(self, "joint_names", tuple(names))
        _set(self, "goal", _point(self.goal, "goal"))
        for name, kind in self.SECTIONS.items():
            if not isinstance(getattr(self, name), kind):
                raise ValueError(
                    f"{name} must be a {kind.__name__}, got {type(getattr(self, name)).__name__}"
                )

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> ImitationSettings:
        """Settings from a mapping of the config's keys (e.g. ``OmegaConf.to_container(cfg, resolve=True)``,
        or a composed config itself, which is a mapping); sections are mappings of their keys, lists may be
        any sequence. :data:`ENTRY_POINT_KEYS` (:mod:`lfd.checks`) are ignored.

        Raises:
            ValueError: an unknown key (named), or a bad value (see the classes).
        """
        top = {k: v for k, v in values.items() if k not in ENTRY_POINT_KEYS}
        kwargs = _fields_of(cls, top, "imitation settings")
        for name, kind in cls.SECTIONS.items():
            if name in kwargs:
                section = kwargs[name]
                if not isinstance(section, Mapping):
                    raise ValueError(f"{name} must be a section of settings, got {section!r}")
                kwargs[name] = kind(**_fields_of(kind, section, name))
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


def _fields_of(cls: type[_T], values: Mapping[str, Any], name: str) -> dict[str, Any]:
    """The keyword arguments of ``cls`` in ``values`` (the section ``name``), lists as tuples."""
    check_keys(values, name, (f.name for f in dataclasses.fields(cls)))
    return {str(k): _plain(v) for k, v in values.items()}
