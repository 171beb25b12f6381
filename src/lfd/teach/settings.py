"""Typed, validated settings of the teach app (the keys of ``configs/teach/teach.yaml``).

:class:`TeachSettings` holds the session's and the server's settings, :class:`IKSettings` the ``ik``
section. Every value is checked once, in ``__post_init__``: a bad value raises ``ValueError`` with one
line naming the field (as the config spells it, e.g. ``ik.max_joint_step``) and what it must be.

The robots offered are the catalogue's entries marked ``teach`` (:func:`teach_robots`,
:class:`lfd.robots.catalogue.CatalogueEntry`); nothing here names a robot.

Units: s, rad, m, rad/s.

Example::

    >>> from lfd.teach.settings import IKSettings, TeachSettings
    >>> s = TeachSettings(robot="sawyer", ik=IKSettings(max_joint_step=0.3))
    >>> s.ik.max_joint_step, s.token_policy
    (0.3, None)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from lfd.checks import ENTRY_POINT_KEYS, check_choice, check_float, check_keys, check_text, positive_float
from lfd.robots.catalogue import available_robots, catalogue_entries

__all__ = ["MODES", "WAM_Q3_MODES", "IKSettings", "TeachSettings", "teach_robots"]

#: Interaction modes: the 3-D drag or the 2-D panel.
MODES = ("3d", "2d")
#: Joint 3 of an arm with a closed-form IK: held (closed form) or free (LM).
WAM_Q3_MODES = ("fixed", "free")


def teach_robots() -> tuple[str, ...]:
    """Catalogue robots the teach app offers (entries with ``teach``)."""
    return tuple(e.name for e in catalogue_entries() if e.teach)


@dataclass(frozen=True)
class IKSettings:
    """``ik``: the drag IK of the 3-D mode.

    Attributes:
        time_budget: s per drag update (> 0). max_joint_step: rad (> 0), a drag update changing a joint
            more than this is refused. wam_q3: ``"fixed"`` (the closed form with the held joint kept, for
            robots whose catalogue entry has one) or ``"free"`` (LM on every joint).
        orientation_weight: m per rad (>= 0) weighting the tool orientation against the position in a
            drag given an orientation (1 rad of orientation error costs as much as this many metres);
            0: position only, an orientation is ignored.
    """

    time_budget: float = 0.02
    max_joint_step: float = 0.5
    wam_q3: str = "fixed"
    orientation_weight: float = 0.1

    def __post_init__(self) -> None:
        object.__setattr__(self, "time_budget", positive_float(self.time_budget, "ik.time_budget"))
        object.__setattr__(self, "max_joint_step", positive_float(self.max_joint_step, "ik.max_joint_step"))
        check_choice(self.wam_q3, "ik.wam_q3", WAM_Q3_MODES)
        object.__setattr__(
            self, "orientation_weight", check_float(self.orientation_weight, "ik.orientation_weight", low=0.0)
        )


@dataclass(frozen=True)
class TeachSettings:
    """Settings of one teach session and its server (see the module docstring).

    Attributes:
        robot: one of :func:`teach_robots`.
        scene: YAML scene path; None (or ``""``/``"null"``): an empty scene.
        host: interface the server binds. port: TCP port 0..65535 (0: a free one).
        token: ``"auto"`` (None too: a token exactly when ``host`` is not loopback), True or False.
        export_dir: where Export creates its ``demo-<date>-<time>`` folders.
        duration_s: serve this many seconds (>= 0; 0: start and stop, a smoke test); None: until Ctrl-C.
        mode: ``"3d"`` or ``"2d"``. ik: :class:`IKSettings`. margin: m (>= 0) of collision clearance.
        panel_speed: rad/s (> 0) timing the 2-D waypoint segments.
        sweep_resolution: rad (> 0), spacing of the collision checks along a move.
        trim_idle: the recording (Export, Send, the fitted motion) leaves out the time the arm stood still
            (:func:`lfd.teach.recording.trim_idle`); the untrimmed samples are kept as ``recorded_raw``.
        idle_speed: rad/s (> 0): a stretch between two samples whose largest joint speed is below this
            is idle and is shortened to last as if the arm moved at this speed.
    """

    robot: str = "wam4"
    scene: str | None = None
    host: str = "127.0.0.1"
    port: int = 8080
    token: str | bool = "auto"
    export_dir: str = "outputs/teach/export"
    duration_s: float | None = None
    mode: str = "3d"
    ik: IKSettings = field(default_factory=IKSettings)
    margin: float = 0.0
    panel_speed: float = 0.6
    sweep_resolution: float = 0.01
    trim_idle: bool = True
    idle_speed: float = 0.02

    def __post_init__(self) -> None:
        robots = teach_robots()
        if self.robot not in robots:
            extra = (
                " (it is in the catalogue but not a teachable arm)"
                if self.robot in available_robots()
                else ""
            )
            raise ValueError(f"unknown robot {self.robot!r}{extra}; choose one of: {', '.join(robots)}")
        scene = self.scene
        object.__setattr__(self, "scene", None if scene in (None, "", "null") else check_text(scene, "scene"))
        object.__setattr__(self, "host", check_text(self.host, "host"))
        port = self.port
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise ValueError(f"port must be an integer in 0..65535 (0: a free port), got {port!r}")
        token = "auto" if self.token is None else self.token
        if not (isinstance(token, bool) or (isinstance(token, str) and token.lower() == "auto")):
            raise ValueError(f"token must be auto, true or false, got {self.token!r}")
        object.__setattr__(self, "token", "auto" if isinstance(token, str) else token)
        object.__setattr__(self, "export_dir", check_text(self.export_dir, "export_dir"))
        duration = check_float(self.duration_s, "duration_s", low=0.0, optional=True)
        object.__setattr__(self, "duration_s", duration)
        check_choice(self.mode, "mode", MODES)
        if not isinstance(self.ik, IKSettings):
            raise ValueError(f"ik must be an IKSettings, got {type(self.ik).__name__}")
        object.__setattr__(self, "margin", check_float(self.margin, "margin", low=0.0))
        object.__setattr__(self, "panel_speed", positive_float(self.panel_speed, "panel_speed"))
        object.__setattr__(
            self, "sweep_resolution", positive_float(self.sweep_resolution, "sweep_resolution")
        )
        if not isinstance(self.trim_idle, bool):
            raise ValueError(f"trim_idle must be true or false, got {self.trim_idle!r}")
        object.__setattr__(self, "idle_speed", positive_float(self.idle_speed, "idle_speed"))

    @property
    def token_policy(self) -> bool | None:
        """``token`` as :class:`~lfd.teach.server.TeachServer` takes it: None (auto), True or False."""
        return None if self.token == "auto" else bool(self.token)

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> TeachSettings:
        """Settings from a mapping of the config's keys (e.g. ``OmegaConf.to_container(cfg, resolve=True)``);
        ``ik`` is a mapping of its keys; :data:`lfd.checks.ENTRY_POINT_KEYS` are ignored.

        Raises:
            ValueError: an unknown key (named) or a bad value.
        """
        kwargs = {str(k): v for k, v in values.items() if k not in ENTRY_POINT_KEYS}
        check_keys(kwargs, "teach settings", _field_names(cls))
        if "ik" in kwargs:
            ik = kwargs["ik"]
            if not isinstance(ik, Mapping):
                raise ValueError(f"ik must be a section of settings, got {ik!r}")
            ik = {str(k): v for k, v in ik.items()}
            check_keys(ik, "ik", _field_names(IKSettings))
            kwargs["ik"] = IKSettings(**ik)
        return cls(**kwargs)


def _field_names(cls: type) -> tuple[str, ...]:
    """The settings a settings dataclass takes."""
    return tuple(f.name for f in dataclasses.fields(cls))
