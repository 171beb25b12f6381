"""Episode plan (which object, which split) and the per-episode ``.npz`` file.

Episode ``i`` of a dataset is fully determined by the generator config, the seed and
``i``: :func:`plan_episodes` fixes its object and split, and the placement is drawn from
:func:`placement_rng` inside the generator. That is what makes the bytes independent of
the number of worker processes and shards.

Split keys: objects come in three *groups*, ``train`` (training objects; a share of their
placements is validation), ``val`` (held-out validation objects) and ``test`` (test
objects). Object ``j`` of group ``g`` is drawn from
``default_rng([seed, OBJECT_STREAM, GROUP_KEYS[g], j])`` and its placement ``k`` from
``default_rng([seed, PLACEMENT_STREAM, GROUP_KEYS[g], j, k])`` -- never from a stream
indexed by the episode number -- so two datasets with the same seed (``quick`` and
``original``) share an item only when it has the same group, object and placement number:
one experiment's test object or placement is never another's training item.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lfd.checks import one_line
from lfd.io.files import DatasetError
from lfd.sim.camera import Camera, Lighting, jitter_camera, sample_lighting
from lfd.sim.expert import DISCARD_REASONS
from lfd.sim.objects import ObjectSpec, Placement, sample_object
from lfd.sim.textures import TableTexture, sample_table_texture
from lfd.visuomotor.data.config import GeneratorConfig

SPLITS = ("train", "val", "test")
#: Image arrays of an episode file, read only on demand (:meth:`EpisodeRecord.frames`).
IMAGE_KEYS = ("frames", "wrist_frames", "depth")
EPISODE_DIR = "episodes"
#: Arrays every episode file holds (besides its images) and :meth:`EpisodeRecord.load` checks for
#: (a generated episode also holds ``object_poses``; a teach export's episode does not).
EPISODE_KEYS = (
    "index",
    "split",
    "object_index",
    "object_group",
    "object_name",
    "object_shape",
    "object_dims",
    "object_rgba",
    "object_mass",
    "placement",
    "approach_mode",
    "target_point",
    "t",
    "joints",
    "velocities",
    "ee_poses",
    "dmp_y0",
    "dmp_goal",
    "dmp_weights",
    "dmp_tau",
    "discarded",
)
# Independent random streams derived from the seed (0, 1: retired streams of format 1).
SPLIT_STREAM, PLACEMENT_STREAM, OBJECT_STREAM, LIGHTING_STREAM, CAMERA_STREAM, TEXTURE_STREAM = (
    2,
    3,
    4,
    5,
    6,
    7,
)
CLUTTER_STREAM = 8
#: Stream key of each object group (see the module docstring).
GROUP_KEYS = {"train": 0, "val": 1, "test": 2}


#: Most bytes the arrays of one episode file may declare once decompressed (its zip directory's
#: sizes, checked before anything is read): images (:data:`IMAGE_KEYS`) and the other arrays.
MAX_EPISODE_IMAGE_BYTES = 4 * 2**30
MAX_EPISODE_ARRAY_BYTES = 256 * 2**20


def _check_sizes(path: Path, *, images: bool) -> None:
    """Refuse an episode file whose image arrays (``images``) or other arrays declare more
    decompressed bytes than :data:`MAX_EPISODE_IMAGE_BYTES` / :data:`MAX_EPISODE_ARRAY_BYTES`
    (the zip directory only is read; reading stops at the declared sizes)."""
    try:
        with zipfile.ZipFile(path) as zf:
            members = zf.infolist()
    except FileNotFoundError as e:
        raise DatasetError(f"missing episode file {path}") from e
    except (zipfile.BadZipFile, OSError) as e:
        raise DatasetError(f"corrupt episode file {path}: {one_line(str(e))}") from e
    cap = MAX_EPISODE_IMAGE_BYTES if images else MAX_EPISODE_ARRAY_BYTES
    size = sum(m.file_size for m in members if (m.filename.removesuffix(".npy") in IMAGE_KEYS) == images)
    if size > cap:
        kind = "image arrays" if images else "arrays"
        raise DatasetError(
            f"corrupt episode file {path}: its {kind} declare {size} bytes, more than lfd reads ({cap})"
        )


def episode_path(index: int) -> str:
    """Path of episode ``index`` relative to the dataset folder."""
    return f"{EPISODE_DIR}/ep-{index:05d}.npz"


@dataclass(frozen=True)
class EpisodePlan:
    """What episode ``index`` shows: ``obj`` (``object_index`` within its group, the
    training or the test objects), in split ``split``, placement number
    ``placement_index`` of that object."""

    index: int
    split: str
    object_index: int
    placement_index: int
    obj: ObjectSpec
    group: str = "train"


def group_objects(cfg: GeneratorConfig, group: str, n: int) -> list[ObjectSpec]:
    """The first ``n`` objects of ``group``, object ``j`` from its own keyed stream (family
    ``families[j % len(families)]``, :meth:`GeneratorConfig.group_families`), named
    ``f"{group}-{j:02d}-{shape}"``, sizes from ``cfg.sizes``; the validation objects outside
    the training ranges with ``val_sizes="outside"``."""
    key, families = GROUP_KEYS[group], cfg.group_families(group)
    shapes = [families[j % len(families)] for j in range(n)]
    outside = group == "val" and cfg.val_sizes == "outside"
    return [
        sample_object(
            np.random.default_rng([cfg.seed, OBJECT_STREAM, key, j]),
            shape,
            f"{group}-{j:02d}-{shape}",
            outside=outside,
            sizes=cfg.sizes,
        )
        for j, shape in enumerate(shapes)
    ]


def plan_episodes(cfg: GeneratorConfig) -> list[EpisodePlan]:
    """All episodes, in index order: training objects (object-major, ``n_train_placements``
    each; per object a random ``n_val_placements`` of them are validation), then the
    held-out validation objects (``n_val_object_placements`` each, split ``val``), then the
    test objects with ``n_test_placements`` each."""
    plans: list[EpisodePlan] = []
    for j, obj in enumerate(group_objects(cfg, "train", cfg.n_train_objects)):
        perm = np.random.default_rng([cfg.seed, SPLIT_STREAM, j]).permutation(cfg.n_train_placements)
        val = set(perm[: cfg.n_val_placements].tolist())
        for k in range(cfg.n_train_placements):
            plans.append(EpisodePlan(len(plans), "val" if k in val else "train", j, k, obj, "train"))
    for group, n_obj, n_pl in (
        ("val", cfg.n_val_objects, cfg.n_val_object_placements),
        ("test", cfg.n_test_objects, cfg.n_test_placements),
    ):
        for j, obj in enumerate(group_objects(cfg, group, n_obj)):
            for k in range(n_pl):
                plans.append(EpisodePlan(len(plans), group, j, k, obj, group))
    return plans


def _episode_rng(cfg: GeneratorConfig, plan: EpisodePlan, stream: int) -> np.random.Generator:
    """The random stream ``stream`` of an episode: keyed by the seed, the object group, the
    object and the placement number, not the episode index."""
    return np.random.default_rng(
        [cfg.seed, stream, GROUP_KEYS[plan.group], plan.object_index, plan.placement_index]
    )


def episode_lighting(cfg: GeneratorConfig, plan: EpisodePlan) -> Lighting | None:
    """The light of an episode: None with ``lighting="fixed"``, else drawn from its own keyed
    stream (:data:`LIGHTING_STREAM`)."""
    return None if cfg.lighting == "fixed" else sample_lighting(_episode_rng(cfg, plan, LIGHTING_STREAM))


def episode_camera(cfg: GeneratorConfig, plan: EpisodePlan, camera: Camera) -> Camera:
    """The fixed camera of an episode: ``camera`` with ``camera_pose="fixed"``, else ``camera``
    jittered from the episode's own keyed stream (:data:`CAMERA_STREAM`)."""
    return (
        camera
        if cfg.camera_pose == "fixed"
        else jitter_camera(camera, _episode_rng(cfg, plan, CAMERA_STREAM))
    )


def episode_table_texture(cfg: GeneratorConfig, plan: EpisodePlan) -> TableTexture | None:
    """The table top of an episode: None (the plain table) with ``table_texture="plain"``, else
    drawn from its own keyed stream (:data:`TEXTURE_STREAM`)."""
    if cfg.table_texture == "plain":
        return None
    return sample_table_texture(_episode_rng(cfg, plan, TEXTURE_STREAM))


def clutter_rng(cfg: GeneratorConfig, plan: EpisodePlan) -> np.random.Generator:
    """The random stream an episode draws its clutter from (:data:`CLUTTER_STREAM`, keyed like
    the placements): one :func:`lfd.sim.clutter.sample_clutter` per placement tried."""
    return _episode_rng(cfg, plan, CLUTTER_STREAM)


def placement_rng(cfg: GeneratorConfig, plan: EpisodePlan) -> np.random.Generator:
    """The random stream an episode draws its placement (and retries) from: keyed by the
    seed, the object group, the object and the placement number, not the episode index."""
    return _episode_rng(cfg, plan, PLACEMENT_STREAM)


def split_keys(cfg: GeneratorConfig) -> dict[str, list[int]]:
    """The stream keys of each object group (for a dataset fingerprint)."""
    return {g: [cfg.seed, OBJECT_STREAM, k] for g, k in GROUP_KEYS.items()}


@dataclass
class EpisodeRecord:
    """One episode loaded from disk (everything but the image frames).

    Attributes:
        index, split, object_index: from the plan.
        group: the object group (``train``, ``val`` or ``test``; :data:`GROUP_KEYS`).
        obj, placement: the object and where it stood (torso frame).
        arrays: every numeric array of the file except the images (:data:`IMAGE_KEYS`)
            (``data/README.md`` lists the keys and shapes).
        path: the ``.npz`` file.
    """

    index: int
    split: str
    object_index: int
    obj: ObjectSpec
    placement: Placement
    arrays: dict[str, np.ndarray]
    path: Path
    group: str = "train"

    @property
    def target_point(self) -> np.ndarray:
        """``(3,)`` grasp target point (torso frame): where the demonstration's tool
        frame ends; evaluation measures the final distance to it."""
        return self.arrays["target_point"]

    def discarded(self) -> dict[str, int]:
        """Discarded attempts before this episode succeeded, by reason."""
        return dict(zip(DISCARD_REASONS, self.arrays["discarded"].tolist(), strict=True))

    def frames(self, key: str = "frames") -> np.ndarray:
        """``(T, H, W, 3)`` uint8 frames (``key="wrist_frames"`` for the wrist camera,
        ``key="depth"`` for the fixed camera's ``(T, H, W)`` uint16 depth in mm)."""
        _check_sizes(self.path, images=True)
        with np.load(self.path, allow_pickle=False) as z:
            if key not in z.files:
                raise DatasetError(f"{self.path}: no '{key}' in the episode file")
            return z[key]

    @classmethod
    def load(cls, path: Path) -> EpisodeRecord:
        """Read an episode file (without decompressing its frames).

        Raises:
            DatasetError: the file is missing or damaged, lacks one of :data:`EPISODE_KEYS`, or
                holds a number that is not finite (one line naming the file and the array).
        """
        try:
            _check_sizes(path, images=False)
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files if k not in IMAGE_KEYS}
        except DatasetError:
            raise
        except FileNotFoundError as e:
            raise DatasetError(f"missing episode file {path}") from e
        except Exception as e:  # zipfile/numpy raise several types for damaged archives
            raise DatasetError(f"corrupt episode file {path}: {one_line(str(e))}") from e
        missing = [k for k in EPISODE_KEYS if k not in arrays]
        if missing:
            raise DatasetError(f"corrupt episode file {path}: no {missing}")
        for key, value in arrays.items():
            if value.dtype.kind in "fc" and not np.isfinite(value).all():
                raise DatasetError(f"corrupt episode file {path}: {key} is not finite (NaN or inf)")
        obj = ObjectSpec(
            shape=str(arrays["object_shape"]),
            dims=tuple(arrays["object_dims"].tolist()),
            rgba=tuple(arrays["object_rgba"].tolist()),
            mass=float(arrays["object_mass"]),
            name=str(arrays["object_name"]),
        )
        x, y, yaw = arrays["placement"].tolist()
        return cls(
            index=int(arrays["index"]),
            split=str(arrays["split"]),
            object_index=int(arrays["object_index"]),
            obj=obj,
            placement=Placement(x, y, yaw),
            arrays=arrays,
            path=Path(path),
            group=str(arrays["object_group"]),
        )
