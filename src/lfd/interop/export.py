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


def check_export_target(src: str | Path, out: str | Path, format: str, overwrite: bool = False) -> bool:
    """Check, before any data is read or generated, that ``out`` may receive a ``format`` export of
    ``src`` (the same rules the exporter applies when it publishes: :func:`lfd.io.files.check_output`).

    Returns:
        whether ``out`` exists and would be replaced.

    Raises:
        ValueError: unknown ``format``.
        FileExistsError: ``out`` exists and ``overwrite`` is not set.
        lfd.io.files.OutputRefused: ``out`` is not an lfd export of ``format``, or it is ``src`` or
            holds it (and the other refusals of :func:`lfd.io.files.check_output`).
    """
    from lfd.io.files import check_output

    if format not in FORMATS:
        raise ValueError(f"export_dataset.format: expected one of {FORMATS}, got {format!r}")
    kind_of = None
    if format == "robomimic":
        from lfd.interop.robomimic import export_kind as kind_of
    out = Path(out).absolute()
    return check_output(
        out, format, overwrite=overwrite, protect=[Path(src)], kind_of=kind_of, who=f"export_{format}"
    )


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
