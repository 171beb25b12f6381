"""Datasets in the formats the field uses: LeRobot v3.0 (write and read) and robomimic HDF5.

* :func:`export_lerobot` / :class:`LeRobotWriter`: LeRobot v3.0 folders (parquet + AV1 or
  H.264 MP4, lerobot 0.4's layout), :class:`LeRobotDataModule`: train lfd's policies on any
  v3.0 folder.
* :func:`export_robomimic`: one robomimic HDF5 file.
* :func:`lfd.interop.export.export_dataset` picks one by name (``scripts/export_dataset.py``).

The libraries themselves are not needed: pyarrow, PyAV and h5py write the files.
See ``docs/formats.md``.
"""

from typing import TYPE_CHECKING

from lfd._lazy import exports, lazy_getattr

_EXPORTS = exports(
    {
        "lerobot.datamodule": ["LeRobotDataModule"],
        "lerobot.export": ["export_lerobot", "task_string"],
        "lerobot.paths": ["CODEBASE_VERSION", "update_chunk_file_indices"],
        "lerobot.reader": ["LeRobotFolder", "read_info"],
        "lerobot.writer": ["LeRobotEpisode", "LeRobotWriter"],
        "robomimic": ["export_robomimic"],
    }
)
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_getattr(__name__, _EXPORTS)

if TYPE_CHECKING:
    from lfd.interop.lerobot.datamodule import LeRobotDataModule
    from lfd.interop.lerobot.export import export_lerobot, task_string
    from lfd.interop.lerobot.paths import CODEBASE_VERSION, update_chunk_file_indices
    from lfd.interop.lerobot.reader import LeRobotFolder, read_info
    from lfd.interop.lerobot.writer import LeRobotEpisode, LeRobotWriter
    from lfd.interop.robomimic import export_robomimic
