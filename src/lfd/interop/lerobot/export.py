"""An lfd dataset as a LeRobot v3.0 dataset: task strings, the episode mappings
(:func:`lfd_episode`, :func:`metaworld_episode`) and the export drivers (:func:`export_lerobot`,
which also takes a Meta-World demonstration dataset, and :func:`export_metaworld`).
"""

from __future__ import annotations

import colorsys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lfd.checks import check_int
from lfd.interop.lerobot.paths import (
    DEFAULT_CHUNK_SIZE,
    DEFAULT_DATA_FILE_SIZE_IN_MB,
    DEFAULT_VIDEO_FILE_SIZE_IN_MB,
)
from lfd.interop.lerobot.writer import LeRobotEpisode, LeRobotWriter
from lfd.io.files import publish_output

_HUES = (
    (15, "red"),
    (45, "orange"),
    (70, "yellow"),
    (165, "green"),
    (195, "cyan"),
    (255, "blue"),
    (290, "purple"),
    (345, "magenta"),
    (360, "red"),
)


def colour_name(rgba: Sequence[float]) -> str:
    """A plain colour word for an RGB(A) colour in ``[0, 1]`` (grey/white/black for
    unsaturated ones, else by hue): ``(0.9, 0.1, 0.1)`` -> ``"red"``."""
    h, s, v = colorsys.rgb_to_hsv(*[float(c) for c in rgba[:3]])
    if v < 0.2:
        return "black"
    if s < 0.25:
        return "white" if v > 0.8 else "grey"
    deg = h * 360
    return next(name for limit, name in _HUES if deg < limit)


def task_string(obj, approach_mode: str) -> str:
    """What an episode does: ``"reach the red cylinder from the side"`` (``approach_mode``
    ``"side"``) or ``"... from above"`` (``"top"``)."""
    where = {"side": "from the side", "top": "from above"}.get(approach_mode)
    if where is None:
        raise ValueError(f"task_string: approach_mode must be 'side' or 'top', got {approach_mode!r}")
    return f"reach the {colour_name(obj.rgba)} {obj.shape} {where}"


#: Episode arrays of an lfd dataset kept as extra episode columns ``lfd/<key>`` (flattened).
EXTRA_ARRAYS = (
    "placement",
    "object_dims",
    "object_rgba",
    "target_point",
    "dmp_y0",
    "dmp_goal",
    "dmp_weights",
    "q_approach",
    "q_pregrasp",
)
#: The fixed camera's OpenGL matrices ``(4, 4)``, kept as ``lfd/<key>`` (16 values, row-major) where the
#: episode has them: the reader then labels where the grasp target appears in the image (``target_pixels``).
CAMERA_ARRAYS = ("camera_view", "camera_projection")
EXTRA_SCALARS = ("index", "object_index", "placement_index", "object_mass", "dmp_tau", "final_error")
EXTRA_STRINGS = ("split", "object_name", "object_shape", "approach_mode")


def lfd_episode(record, frames: dict[str, np.ndarray]) -> LeRobotEpisode:
    """An lfd :class:`~lfd.visuomotor.data.episodes.EpisodeRecord` as a LeRobot episode.

    ``observation.state`` = measured joint angles (rad) then joint velocities (rad/s),
    ``(T, 14)``; ``action`` = the next sample's joint angles (the position target of the
    next control step; the last frame repeats its own), ``(T, 7)``. The object,
    placement, split and DMP parameters become extra episode columns ``lfd/<key>``
    (``lfd/dmp_weights`` joint-major, ``n_joints * n_basis`` values; ``lfd/ee_path`` the
    measured tool positions, ``T * 3`` values, m in the torso frame).
    """
    a = record.arrays
    joints, vel = np.asarray(a["joints"]), np.asarray(a["velocities"])
    action = np.concatenate([joints[1:], joints[-1:]])
    extra: dict[str, Any] = {}
    for key in EXTRA_STRINGS:
        extra[f"lfd/{key}"] = str(a[key])
    for key in EXTRA_SCALARS:
        value = a[key].item()
        extra[f"lfd/{key}"] = (
            int(value) if key in ("index", "object_index", "placement_index") else float(value)
        )
    for key in EXTRA_ARRAYS:
        extra[f"lfd/{key}"] = np.asarray(a[key], dtype=np.float64).reshape(-1)
    for key in CAMERA_ARRAYS:
        if key in a:
            extra[f"lfd/{key}"] = np.asarray(a[key], dtype=np.float64).reshape(-1)
    extra["lfd/n_basis"] = int(np.asarray(a["dmp_weights"]).shape[-1])
    extra["lfd/ee_path"] = np.asarray(a["ee_poses"], dtype=np.float64)[:, :3, 3].reshape(-1)
    return LeRobotEpisode(
        state=np.concatenate([joints, vel], axis=1),
        action=action,
        frames=frames,
        task=task_string(record.obj, str(a["approach_mode"])),
        extra=extra,
    )


def export_lerobot(
    dataset: str | Path,
    out: str | Path,
    *,
    codec: str = "av1",
    chunks_size: int = DEFAULT_CHUNK_SIZE,
    data_files_size_in_mb: float = DEFAULT_DATA_FILE_SIZE_IN_MB,
    video_files_size_in_mb: float = DEFAULT_VIDEO_FILE_SIZE_IN_MB,
    crf: int = 30,
    overwrite: bool = False,
    progress: bool = True,
    limit: int | None = None,
) -> Path:
    """Export a verified lfd dataset folder to LeRobot v3.0 at ``out``.

    Episodes are written train, then val, then test (each in index order), so that
    ``info.json``'s ``splits`` are contiguous ranges; ``lfd/index`` keeps the original
    episode number. ``fps = (n_steps - 1) / duration`` (24.75 for 100 samples in 4 s), so
    ``timestamp = frame_index / fps`` is the recorded time ``t``. Camera
    ``observation.images.front`` is the fixed camera (``observation.images.wrist`` too
    when the dataset has wrist frames).

    The folder is written as a temporary sibling and renamed to ``out`` when complete
    (:func:`lfd.io.files.publish_output`), with the marker ``.lfd-export.json`` (kind
    ``"lerobot"``) at its top: an interrupted export leaves ``out`` as it was.

    Args:
        dataset: lfd dataset folder (verified against its manifest first).
        out: new LeRobot dataset folder (``overwrite`` replaces an existing one, only an
            lfd LeRobot export).
        codec: ``"av1"`` (default, as lerobot) or ``"h264"``.
        limit: export only the first ``limit`` episodes of that order (for quick looks; None:
            all, else an integer >= 1).

    Returns:
        ``out``.

    Raises:
        lfd.io.files.DatasetError: ``dataset`` is missing, unfinished or corrupt.
        FileExistsError: ``out`` exists and ``overwrite`` is not set, or another process wrote
            it while this export ran (exactly one of two racing exports succeeds).
        lfd.io.files.OutputRefused: ``out`` lies inside ``dataset``; ``overwrite`` is set but
            ``out`` is no lfd LeRobot export, or is (or holds) ``dataset``, the current or the
            home folder.
        ValueError: an unknown ``codec``, bad rollover limits (:class:`LeRobotWriter`), a
            ``limit`` that is not None or an integer >= 1.

    A Meta-World demonstration dataset (:mod:`lfd.visuomotor.metaworld.demos`, told by its
    manifest's format) is exported by :func:`export_metaworld` with the same options.

    Example::

        export_lerobot("data/quick_s42", "data/quick_s42.lerobot")
    """
    check_int(limit, "export_lerobot: limit", minimum=1, optional=True)
    if is_metaworld_dataset(dataset):
        return export_metaworld(
            dataset,
            out,
            codec=codec,
            chunks_size=chunks_size,
            data_files_size_in_mb=data_files_size_in_mb,
            video_files_size_in_mb=video_files_size_in_mb,
            crf=crf,
            overwrite=overwrite,
            progress=progress,
            limit=limit,
        )
    from lfd.robots import load_robot
    from lfd.visuomotor.data.datasets import load_dataset
    from lfd.visuomotor.data.episodes import SPLITS

    data = load_dataset(dataset)
    cfg = data.config
    order = [r for split in SPLITS for r in data.split(split)][:limit]
    names = list(load_robot(cfg.robot).joint_names)
    cams = {"front": (cfg.image_size, cfg.image_size)}
    if cfg.wrist_camera:
        cams["wrist"] = (cfg.image_size, cfg.image_size)

    def episode(record) -> LeRobotEpisode:
        frames = {"front": record.frames()}
        if cfg.wrist_camera:
            frames["wrist"] = record.frames("wrist_frames")
        return lfd_episode(record, frames)

    writer_options = dict(
        fps=(cfg.n_steps - 1) / cfg.duration,
        robot_type=cfg.robot,
        state_names=[f"{n}.pos" for n in names] + [f"{n}.vel" for n in names],
        action_names=[f"{n}.pos" for n in names],
        cameras=cams,
        codec=codec,
        chunks_size=chunks_size,
        data_files_size_in_mb=data_files_size_in_mb,
        video_files_size_in_mb=video_files_size_in_mb,
        crf=crf,
    )
    return _write(
        dataset, out, order, SPLITS, episode, writer_options, overwrite=overwrite, progress=progress
    )


def _write(
    dataset, out, order: list, split_names, episode, writer_options: dict, *, overwrite: bool, progress: bool
) -> Path:
    """The one export loop: ``order``'s items (each with a ``split``, in ``split_names`` order) as
    LeRobot episodes (``episode(item)``), written by :class:`LeRobotWriter` (``writer_options``)
    into a temporary sibling published as ``out`` (:func:`lfd.io.files.publish_output`), with
    ``info.json``'s contiguous split ranges."""
    splits, start = {}, 0
    for split in split_names:
        n = sum(1 for item in order if item.split == split)
        if n:
            splits[split] = f"{start}:{start + n}"
            start += n
    out = Path(out)
    with publish_output(
        out, "lerobot", overwrite=overwrite, protect=[Path(dataset)], who="export_lerobot"
    ) as root:
        writer = LeRobotWriter(root, **writer_options)
        for item in _progress(order, progress, "LeRobot v3.0"):
            writer.add_episode(episode(item))
        writer.finalize(splits)
    return out


#: ``info.json`` robot type of a Meta-World export (Meta-World's simulated Sawyer, driven by its
#: mocap hand: the state and action are the hand's, not the arm's joints).
METAWORLD_ROBOT_TYPE = "sawyer_metaworld"
#: ``observation.state`` entries of a Meta-World export: hand position (m, world frame) and the
#: last gripper command (-1 open .. 1 closed).
METAWORLD_STATE_NAMES = ("hand.x", "hand.y", "hand.z", "gripper.command")
#: ``action`` entries of a Meta-World export (Meta-World's delta actions in [-1, 1]).
METAWORLD_ACTION_NAMES = ("x", "y", "z", "gripper")


def is_metaworld_dataset(dataset: str | Path) -> bool:
    """Whether folder ``dataset`` holds a Meta-World demonstration dataset (its ``manifest.json``
    names that format; any other or unreadable folder: False, the lfd reader then says why)."""
    import json

    from lfd.visuomotor.metaworld.demos import FORMAT_NAME, MANIFEST

    try:
        manifest = json.loads((Path(dataset) / MANIFEST).read_text())
    except (OSError, ValueError):
        return False
    return isinstance(manifest, dict) and manifest.get("format") == FORMAT_NAME


def metaworld_episode(episode, task: str, camera: str) -> LeRobotEpisode:
    """A Meta-World :class:`~lfd.visuomotor.metaworld.demos.MetaWorldEpisode` as a LeRobot episode.

    ``observation.state`` = the robot state before each action, ``(T, 4)``: hand x, y, z (m)
    and the last gripper command (-1 open .. 1 closed). ``action`` = the action the scripted
    expert sent at that step, ``(T, 4)``: **Meta-World's delta actions in [-1, 1]** (x, y, z
    move the hand's mocap target by up to 1 cm per step per unit, gripper is the gripper
    command), not positions. ``observation.images.<camera>`` = the frames, frame ``t`` seen at
    state ``t``. The language task is the Meta-World task name (``"reach-v3"``).
    """
    a = episode.arrays
    return LeRobotEpisode(
        state=np.asarray(a["states"]),
        action=np.asarray(a["actions"]),
        frames={camera: np.asarray(a["frames"])},
        task=task,
    )


def export_metaworld(
    dataset: str | Path,
    out: str | Path,
    *,
    codec: str = "av1",
    chunks_size: int = DEFAULT_CHUNK_SIZE,
    data_files_size_in_mb: float = DEFAULT_DATA_FILE_SIZE_IN_MB,
    video_files_size_in_mb: float = DEFAULT_VIDEO_FILE_SIZE_IN_MB,
    crf: int = 30,
    overwrite: bool = False,
    progress: bool = True,
    limit: int | None = None,
) -> Path:
    """Export a verified Meta-World demonstration dataset folder to LeRobot v3.0 at ``out``.

    One LeRobot episode per stored episode (:func:`metaworld_episode`), train then val (each in
    index order), so ``info.json``'s ``splits`` are contiguous ranges. ``fps = 1 / control_dt``
    (80 for Meta-World's 0.0125 s steps), ``robot_type`` :data:`METAWORLD_ROBOT_TYPE`, camera
    ``observation.images.<data.camera>`` (``corner`` by default); the task is the Meta-World
    task name. Published atomically with the export marker, like :func:`export_lerobot`, whose
    arguments, return value and errors these are.

    Example::

        export_metaworld("data/metaworld_reach-v3_n50_s42", "data/metaworld_reach-v3_n50_s42.lerobot")
    """
    from lfd.visuomotor.metaworld.demos import STORED_SPLITS, load_demonstrations

    check_int(limit, "export_lerobot: limit", minimum=1, optional=True)
    data = load_demonstrations(dataset)
    cfg = data.config
    order = [e for split in STORED_SPLITS for e in data.split(split)][:limit]
    writer_options = dict(
        fps=1.0 / cfg.control_dt,
        robot_type=METAWORLD_ROBOT_TYPE,
        state_names=list(METAWORLD_STATE_NAMES),
        action_names=list(METAWORLD_ACTION_NAMES),
        cameras={cfg.camera: (cfg.image_size, cfg.image_size)},
        codec=codec,
        chunks_size=chunks_size,
        data_files_size_in_mb=data_files_size_in_mb,
        video_files_size_in_mb=video_files_size_in_mb,
        crf=crf,
    )
    return _write(
        dataset,
        out,
        order,
        STORED_SPLITS,
        lambda e: metaworld_episode(e, cfg.task, cfg.camera),
        writer_options,
        overwrite=overwrite,
        progress=progress,
    )


def _progress(items: Iterable, enabled: bool, desc: str):
    if not enabled:
        return items
    from tqdm import tqdm

    items = list(items)
    return tqdm(items, desc=desc, unit="ep")
