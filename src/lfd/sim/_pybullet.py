"""The one import of PyBullet: ``from lfd.sim._pybullet import pybullet as p``.

PyBullet's C code prints ``pybullet build time: <date>`` when it is imported (on standard error in
PyBullet 3.2.7, on standard output in some builds), before any lfd output, even ``lfd-teach --help``.
Here the process's standard output and error file descriptors point to the null device for the
import alone (the C library's buffers flushed before they are restored), so the line is never
written; everything PyBullet prints later is kept. An error importing PyBullet is raised as usual.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys

__all__ = ["pybullet"]

#: The file descriptors silenced during the import: standard output and standard error.
_SILENCED = (1, 2)


def _flush_c_streams() -> None:
    """Flush the C library's output buffers (a pipe or file is block-buffered, not flushed at ``\\n``)."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


def _import_quietly():
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, OSError, ValueError):
            stream.flush()
    saved: dict[int, int] = {}
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            for fd in _SILENCED:
                with contextlib.suppress(OSError):  # a closed descriptor stays as it is
                    saved[fd] = os.dup(fd)
                    os.dup2(devnull, fd)
        finally:
            os.close(devnull)
        import pybullet

        _flush_c_streams()
    finally:
        for fd, copy in saved.items():
            os.dup2(copy, fd)
            os.close(copy)
    return pybullet


pybullet = _import_quietly()
