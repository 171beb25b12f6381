"""Export an lfd dataset to another format by name: ``export_dataset(src, out, format="lerobot")``.

Formats: ``"lerobot"`` (LeRobot v3.0 folder, :func:`lfd.interop.export_lerobot`) and
``"robomimic"`` (one HDF5 file, :func:`lfd.interop.export_robomimic`). Keyword
arguments go to the exporter (``codec="h264"`` for LeRobot, ``compression=...`` for
robomimic, ``overwrite``, ``progress``, ``limit``).

Example::

    from lfd.interop.export import export_dataset
    export_dataset("data/quick_s42", "data/quick_s42.lerobot", format="lerobot", codec="h264")
"""

from __future__ import annotations

from pathlib import Path

FORMATS = ("lerobot", "robomimic")


def export_dataset(src: str | Path, out: str | Path, format: str = "lerobot", **options) -> Path:
    """Write dataset folder ``src`` to ``out`` in ``format``; returns ``out``.

    Raises:
        ValueError: unknown ``format``.
        lfd.io.files.DatasetError: ``src`` is missing, unfinished or corrupt.
        FileExistsError: ``out`` exists and ``overwrite`` is not set.
    """
    if format == "lerobot":
        from lfd.interop.lerobot.export import export_lerobot

        return export_lerobot(src, out, **options)
    if format == "robomimic":
        from lfd.interop.robomimic import export_robomimic

        return export_robomimic(src, out, **options)
    raise ValueError(f"export_dataset.format: expected one of {FORMATS}, got {format!r}")
