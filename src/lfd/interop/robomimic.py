"""robomimic HDF5 export of an lfd dataset (h5py, no robomimic import).

Layout (robomimic's dataset structure, ``robomimic/docs/datasets/overview``)::

    data                      attrs: total (frames), env_args (JSON: env_name, type, env_kwargs),
                                     action_space, action_scale (rad/s per joint)
    data/demo_<i>             attrs: num_samples; i = the lfd episode index
        obs/<key>             (N, ...) per step
        next_obs/<key>        obs shifted by one step (the last repeated)
        actions               (N, 7) velocity commands / action_scale, in [-1, 1]
        rewards, dones        (N,) 1 at the last step (every demonstration succeeds there)
        states                (N, 21) joints (7), joint velocities (7), object position (3)
                              and quaternion x, y, z, w (4): the simulator state
    mask/train, mask/valid    demo names as byte strings (lfd's train / val split)
    mask/test                 the test split (new objects; robomimic ignores unknown masks)
    (root)                    attrs: lfd_export (JSON: {"kind": "robomimic", "lfd_version": ...}),
                                     the marker that lets ``overwrite`` replace the file

Observation keys: ``agentview_image`` (fixed camera, uint8 ``(N, H, W, 3)``),
``robot0_eye_in_hand_image`` (wrist camera, if recorded), ``robot0_joint_pos``,
``robot0_joint_vel``, ``robot0_eef_pos``, ``robot0_eef_quat`` (x, y, z, w) and
``object`` (object position and quaternion), all in the robot base (torso) frame.

Example::

    export_robomimic("data/quick_s42", "data/quick_s42.hdf5")
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from lfd.checks import check_int
from lfd.io.files import export_marker, publish_output
from lfd.robots.spatial import matrix_to_quaternion

#: robomimic's EnvType.GYM_TYPE (robomimic.envs.env_base): the closest of its env kinds.
GYM_ENV_TYPE = 2
ENV_NAME = "LfdReach-v0"
#: Root attribute holding lfd's export marker (:func:`lfd.io.files.export_marker`).
MARKER_ATTR = "lfd_export"


def _h5py():
    try:
        import h5py
    except ImportError as e:  # pragma: no cover - h5py is a declared dependency
        raise ImportError("lfd.interop.robomimic needs h5py: pip install h5py") from e
    return h5py


def export_kind(path: str | Path) -> str | None:
    """The kind in the lfd export marker of HDF5 file ``path`` (``"robomimic"`` for a file
    written by :func:`export_robomimic`), or None for any other file, readable or not."""
    try:
        with _h5py().File(path, "r") as f:
            marker = json.loads(f.attrs[MARKER_ATTR])
    except Exception:  # not HDF5, truncated, no marker, not JSON: not ours
        return None
    return marker.get("kind") if isinstance(marker, dict) else None


def _obs(record, frames: np.ndarray, wrist: np.ndarray | None) -> dict[str, np.ndarray]:
    a = record.arrays
    ee, obj = np.asarray(a["ee_poses"]), np.asarray(a["object_poses"])
    obs = {
        "agentview_image": frames,
        "robot0_joint_pos": np.asarray(a["joints"], np.float64),
        "robot0_joint_vel": np.asarray(a["velocities"], np.float64),
        "robot0_eef_pos": ee[:, :3, 3],
        "robot0_eef_quat": matrix_to_quaternion(ee[:, :3, :3], order="xyzw"),
        "object": np.concatenate([obj[:, :3, 3], matrix_to_quaternion(obj[:, :3, :3], order="xyzw")], axis=1),
    }
    if wrist is not None:
        obs["robot0_eye_in_hand_image"] = wrist
    return obs


def export_robomimic(
    dataset: str | Path,
    out: str | Path,
    *,
    overwrite: bool = False,
    progress: bool = True,
    compression: str | None = "gzip",
    limit: int | None = None,
) -> Path:
    """Export a verified lfd dataset folder to one robomimic HDF5 file ``out``.

    Actions are the velocity commands that reproduce the demonstration under velocity control,
    the joints' mean velocity over each control period
    (:func:`lfd.visuomotor.data.datasets.command_velocities`; the recorded instantaneous
    velocities stay in ``obs/robot0_joint_vel``), divided by ``action_scale``, the largest
    absolute command of each joint over the whole dataset, so they lie in ``[-1, 1]``;
    ``data.attrs["action_scale"]`` (rad/s) turns them back. The file is written in a
    temporary sibling folder and renamed to ``out`` when complete
    (:func:`lfd.io.files.publish_output`): an interrupted export leaves ``out`` as it was.
    Its root attribute ``lfd_export`` marks it as lfd's (an HDF5 attribute rather than a
    sidecar file, so that the mark travels with the file and replacing it stays one rename).

    Args:
        dataset: lfd dataset folder (verified against its manifest first).
        out: ``.hdf5`` file to write (``overwrite`` replaces an existing one, only a file
            written by this function).
        compression: h5py filter for the image datasets (``"gzip"``, ``"lzf"`` or None).
        limit: export only the first ``limit`` episodes (index order; None: all, else an
            integer >= 1).

    Returns:
        ``out``.

    Raises:
        lfd.io.files.DatasetError: ``dataset`` is missing, unfinished or corrupt.
        ValueError: ``limit`` is not None or an integer >= 1.
        FileExistsError: ``out`` exists and ``overwrite`` is not set, or another process wrote
            it while this export ran (exactly one of two racing exports succeeds).
        lfd.io.files.OutputRefused: ``out`` lies inside ``dataset``; ``overwrite`` is set but
            ``out`` is no lfd robomimic export, or is (or holds) ``dataset``, the current or the
            home folder.
    """
    from lfd.visuomotor.data.datasets import command_velocities, load_dataset

    check_int(limit, "export_robomimic: limit", minimum=1, optional=True)
    h5py = _h5py()
    data = load_dataset(dataset)
    records = data.episodes[:limit]
    cfg = data.config
    commands = {r.index: command_velocities(r.arrays["joints"], r.arrays["t"]) for r in records}
    scale = np.max([np.abs(c).max(axis=0) for c in commands.values()], axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    total = 0
    out = Path(out)
    published = publish_output(
        out,
        "robomimic",
        overwrite=overwrite,
        protect=[Path(dataset)],
        kind_of=export_kind,
        who="export_robomimic",
    )
    with published as tmp, h5py.File(tmp, "w") as f:
        f.attrs[MARKER_ATTR] = json.dumps(export_marker("robomimic"))
        items = records
        if progress:  # after the output is accepted: a refusal prints no bar
            from tqdm import tqdm

            items = tqdm(records, desc="robomimic", unit="ep")
        grp = f.create_group("data")
        for r in items:
            frames = r.frames()
            wrist = r.frames("wrist_frames") if cfg.wrist_camera else None
            obs = _obs(r, frames, wrist)
            n = len(frames)
            demo = grp.create_group(f"demo_{r.index}")
            demo.attrs["num_samples"] = n
            for key, value in obs.items():
                kw = (
                    {"compression": compression, "chunks": (1, *value.shape[1:])}
                    if value.dtype == np.uint8 and compression
                    else {}
                )
                demo.create_dataset(f"obs/{key}", data=value, **kw)
                demo.create_dataset(f"next_obs/{key}", data=np.concatenate([value[1:], value[-1:]]), **kw)
            demo.create_dataset("actions", data=commands[r.index] / scale)
            done = np.zeros(n)
            done[-1] = 1.0
            demo.create_dataset("rewards", data=done)
            demo.create_dataset("dones", data=done.astype(np.int64))
            demo.create_dataset(
                "states",
                data=np.concatenate(
                    [obs["robot0_joint_pos"], obs["robot0_joint_vel"], obs["object"]], axis=1
                ),
            )
            demo.attrs["model_file"] = ""
            demo.attrs["lfd_split"] = r.split
            demo.attrs["lfd_object"] = json.dumps(r.obj.to_dict())
            total += n
        grp.attrs["total"] = total
        grp.attrs["env_args"] = json.dumps(
            {
                "env_name": ENV_NAME,
                "type": GYM_ENV_TYPE,
                "env_kwargs": {"lfd_generator_config": cfg.to_dict(), "control_dt": cfg.control_dt},
            }
        )
        grp.attrs["action_space"] = "joint_velocity"
        grp.attrs["action_scale"] = scale
        for name, split in (("train", "train"), ("valid", "val"), ("test", "test")):
            demos = [f"demo_{r.index}" for r in records if r.split == split]
            f.create_dataset(f"mask/{name}", data=np.array(demos, dtype="S"))
    return out


__all__ = ["ENV_NAME", "GYM_ENV_TYPE", "MARKER_ATTR", "export_kind", "export_robomimic"]
