"""Generator configuration: everything that determines a reaching dataset's bytes."""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict, dataclass, fields
from typing import Any

from lfd.io.files import json_bytes
from lfd.sim.clutter import MAX_CLUTTER
from lfd.sim.objects import SHAPES, SIZE_SETS, PlacementRanges

#: Version of the on-disk dataset format (``manifest.json``).
FORMAT_VERSION = 2  # 2: items drawn from streams keyed by (seed, group, object, placement)

__all__ = ["CAMERA_POSES", "LIGHTINGS", "TABLE_TEXTURES", "VAL_SIZES", "GeneratorConfig"]

#: Where the held-out validation objects' sizes come from (:attr:`GeneratorConfig.val_sizes`).
VAL_SIZES = ("inside", "outside")
#: How the episodes are lit (:attr:`GeneratorConfig.lighting`).
LIGHTINGS = ("fixed", "random")
#: Where the fixed camera stands (:attr:`GeneratorConfig.camera_pose`).
CAMERA_POSES = ("fixed", "jitter")
#: How the table top looks (:attr:`GeneratorConfig.table_texture`).
TABLE_TEXTURES = ("plain", "random")


@dataclass(frozen=True)
class GeneratorConfig:
    """Parameters of a reaching-demonstration dataset (see ``data/README.md``).

    Episodes: ``n_train_objects x n_train_placements`` on training objects (split into
    train and validation by placement: per object, ``round(val_fraction *
    n_train_placements)`` of its placements go to validation), ``n_val_objects x
    n_val_object_placements`` on held-out objects at new placements (validation split,
    what model selection sees of new objects), plus ``n_test_objects x
    n_test_placements`` on new object instances at new placements (test split, for the
    final report only). Every object and placement is drawn from a random stream keyed by
    ``(seed, group, object, placement)`` (:mod:`lfd.visuomotor.data.episodes`), so experiments with
    the same seed share items only within the same group: no experiment's test item is
    another's training item.

    Attributes:
        seed: drives objects, placements and splits (with the episode index).
        families: object shapes cycled through when sampling objects.
        train_families: the training objects' cycle instead (``None`` = ``families``): a
            data mix for training, e.g. one box per round object; the validation and test
            objects keep ``families``. Object ``j`` of a group is drawn from its own keyed
            stream either way, so the held-out objects do not change with it.
        x_range, y_range: placement ranges (m, torso frame); yaw_range_deg: degrees.
        image_size: side of the square camera images (px).
        wrist_camera: also record wrist-camera frames.
        depth: also record the fixed camera's depth images (``depth``, uint16 mm); policies
            trained on such a dataset see RGB-D (:func:`lfd.sim.depth.rgbd_image`).
        duration, n_steps: demonstration length (s) and number of samples.
        substeps: physics steps per sample interval.
        approach_fraction: fraction of ``duration`` at which the approach pose is reached.
        tolerance: maximum final tool distance (m) to the target point.
        n_basis: DMP basis functions per joint.
        max_attempts: placements tried per episode before generation fails.
        robot: robot model name for :func:`lfd.robots.load_robot`.
        sizes: the objects' size set, a name in :data:`lfd.sim.objects.SIZE_SETS`:
            ``"classic"`` (the default, the original ranges) or ``"wide"`` (what users put on
            a table, 1.5-26 cm, with dense cover of the approach rule's boundary) or ``"wide_edges"``
            (the wide ranges, denser at their ends).
        val_sizes: the held-out validation objects' sizes: ``"inside"`` the training ranges
            of ``sizes`` (the default) or ``"outside"`` them (one dimension per object from
            the set's bands just outside), so that model selection sees objects the
            generator never trains on. The test objects stay inside.
        lighting: ``"fixed"`` (the default: PyBullet's default light) or ``"random"`` (every
            episode under its own light, :func:`lfd.sim.camera.sample_lighting`, drawn from a
            stream keyed like the placements and stored as the episode's ``lighting`` array).
        camera_pose: ``"fixed"`` (the default: :class:`lfd.sim.camera.Camera`'s pose) or
            ``"jitter"`` (every episode's camera moved a little, :func:`lfd.sim.camera.jitter_camera`,
            from a stream keyed like the placements, stored as the episode's ``camera_pose``
            array; its ``camera_view`` is that camera's).
        table_texture: ``"plain"`` (the default: the grey table) or ``"random"`` (every episode's
            table top drawn with its own :func:`lfd.sim.textures.sample_table_texture`, from a
            stream keyed like the placements, stored as the episode's ``table_texture`` array).
        clutter: flat items laid around each episode's object, 0 (the default) to
            :data:`lfd.sim.clutter.MAX_CLUTTER` (:func:`lfd.sim.clutter.sample_clutter` for every
            placement tried, from a stream keyed like the placements; stored as the episode's
            ``clutter`` array, ``(n, 9)``; seen by the cameras, not simulated).
    """

    seed: int = 0
    n_train_objects: int = 12
    n_train_placements: int = 16
    n_test_objects: int = 4
    n_test_placements: int = 6
    val_fraction: float = 0.2
    n_val_objects: int = 0
    n_val_object_placements: int = 0
    families: tuple[str, ...] = SHAPES
    train_families: tuple[str, ...] | None = None
    x_range: tuple[float, float] = (0.45, 0.70)
    y_range: tuple[float, float] = (-0.30, 0.30)
    yaw_range_deg: tuple[float, float] = (-90.0, 90.0)
    image_size: int = 128
    wrist_camera: bool = False
    depth: bool = False
    duration: float = 4.0
    n_steps: int = 100
    substeps: int = 10
    approach_fraction: float = 0.75
    tolerance: float = 0.01
    n_basis: int = 20
    max_attempts: int = 30
    robot: str = "pr2_right_arm"
    val_sizes: str = "inside"
    sizes: str = "classic"
    lighting: str = "fixed"
    camera_pose: str = "fixed"
    table_texture: str = "plain"
    clutter: int = 0

    def __post_init__(self) -> None:
        # canonical types, so that e.g. a YAML "90" and "90.0" give the same config and hash
        object.__setattr__(self, "families", tuple(str(f) for f in self.families))
        if self.train_families is not None:
            object.__setattr__(self, "train_families", tuple(str(f) for f in self.train_families))
        for name in ("x_range", "y_range", "yaw_range_deg"):
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
        for name in ("val_fraction", "duration", "approach_fraction", "tolerance"):
            object.__setattr__(self, name, float(getattr(self, name)))
        for name, low in (
            ("n_train_objects", 1),
            ("n_train_placements", 1),
            ("n_test_objects", 0),
            ("n_test_placements", 0),
            ("n_val_objects", 0),
            ("n_val_object_placements", 0),
            ("image_size", 8),
            ("n_steps", 2),
            ("substeps", 1),
            ("n_basis", 1),
            ("max_attempts", 1),
            ("clutter", 0),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"GeneratorConfig.{name}: expected an int >= {low}, got {value!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"GeneratorConfig.seed: expected an int >= 0, got {self.seed!r}")
        if self.clutter > MAX_CLUTTER:
            raise ValueError(
                f"GeneratorConfig.clutter: expected an int in [0, {MAX_CLUTTER}], got {self.clutter}"
            )
        if not 0 <= self.val_fraction < 1:
            raise ValueError(
                f"GeneratorConfig.val_fraction: expected a value in [0, 1), got {self.val_fraction}"
            )
        if self.n_val_placements >= self.n_train_placements:
            raise ValueError(
                f"GeneratorConfig.val_fraction: {self.val_fraction} leaves no training placement "
                f"out of {self.n_train_placements}"
            )
        cycles = {"families": self.families, "train_families": self.train_families}
        for name, value in cycles.items():
            if value is not None and (not value or any(f not in SHAPES for f in value)):
                raise ValueError(
                    f"GeneratorConfig.{name}: expected a non-empty list of {SHAPES} (repeats allowed), got "
                    f"{list(value)}"
                )
        for name in ("x_range", "y_range", "yaw_range_deg"):
            low_high = getattr(self, name)
            if len(low_high) != 2 or not all(math.isfinite(v) for v in low_high) or low_high[0] > low_high[1]:
                raise ValueError(
                    f"GeneratorConfig.{name}: expected finite (low, high), low <= high, got {low_high}"
                )
        for name in ("duration", "tolerance"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"GeneratorConfig.{name}: expected a finite value > 0, got {value}")
        if not 0 < self.approach_fraction < 1:
            raise ValueError(
                f"GeneratorConfig.approach_fraction: expected a value in (0, 1), got {self.approach_fraction}"
            )
        for name, choices in (
            ("sizes", tuple(SIZE_SETS)),
            ("lighting", LIGHTINGS),
            ("camera_pose", CAMERA_POSES),
            ("table_texture", TABLE_TEXTURES),
            ("val_sizes", VAL_SIZES),
        ):
            if getattr(self, name) not in choices:
                raise ValueError(
                    f"GeneratorConfig.{name}: expected one of {choices}, got {getattr(self, name)!r}"
                )
        for name in ("wrist_camera", "depth"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"GeneratorConfig.{name}: expected a bool, got {getattr(self, name)!r}")

    @property
    def n_val_placements(self) -> int:
        """Placements per training object that go to the validation split."""
        return int(round(self.val_fraction * self.n_train_placements))

    @property
    def n_episodes(self) -> int:
        return (
            self.n_train_objects * self.n_train_placements
            + self.n_val_objects * self.n_val_object_placements
            + self.n_test_objects * self.n_test_placements
        )

    @property
    def placement_ranges(self) -> PlacementRanges:
        return PlacementRanges(self.x_range, self.y_range, self.yaw_range_deg)

    def group_families(self, group: str) -> tuple[str, ...]:
        """The shape cycle of object group ``group`` (``train``, ``val`` or ``test``)."""
        return self.train_families if group == "train" and self.train_families is not None else self.families

    @property
    def control_dt(self) -> float:
        return self.duration / (self.n_steps - 1)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (tuples as lists). Options added after format 2 are left out
        while at their default (:data:`_LATER_OPTIONS`), so datasets made before them keep
        their hash."""
        out = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}
        for key, default in _LATER_OPTIONS.items():
            if out[key] == default:
                del out[key]
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> GeneratorConfig:
        """Inverse of :meth:`to_dict`; unknown keys raise ``ValueError`` naming them."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ValueError(f"GeneratorConfig: unknown keys {unknown}")
        return cls(**d)

    def sha256(self) -> str:
        """Hash of the canonical JSON of :meth:`to_dict` and the on-disk format version."""
        return hashlib.sha256(
            json_bytes({"format_version": FORMAT_VERSION, "config": self.to_dict()})
        ).hexdigest()


#: Options added after :data:`FORMAT_VERSION` 2, with their defaults.
_LATER_OPTIONS = {
    "depth": False,
    "train_families": None,
    "val_sizes": "inside",
    "sizes": "classic",
    "lighting": "fixed",
    "camera_pose": "fixed",
    "table_texture": "plain",
    "clutter": 0,
}
