"""UI-PRMD Vicon marker files: 39 Plug-in Gait markers per frame (docs/human.md).

Layout (``Vicon/Positions/mMM_sSS_eEE_positions.txt[.gz]``): one row per frame, 117
comma-separated numbers = 39 markers x (x, y, z) in millimetres, z up, in the order of
:data:`PLUG_IN_GAIT_MARKERS`; a marker the cameras lost is written as (0, 0, 0). The markers
are surface markers, not joint centres (``RSHO`` on the acromion, ``RELB`` on the lateral
epicondyle, ``RWRA``/``RWRB`` on the radial/ulnar side of the wrist). UI-PRMD recorded them at
100 Hz; the Vicon and Kinect recordings of a trial are segmented separately (not
frame-synchronised).

Example::

    >>> from lfd.human.readers.vicon import read_uiprmd_vicon
    >>> sk = read_uiprmd_vicon("tests/fixtures/human/ui_prmd/Vicon/Positions/m07_s02_e01_positions.txt.gz")
    >>> sk.positions.shape, sk.names[:2]
    ((233, 39, 3), ('lfhd', 'rfhd'))
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..skeleton import Skeleton
from .common import SkeletonFormatError, check_rate, length_scale, parse_row, read_lines

__all__ = ["PLUG_IN_GAIT_MARKERS", "read_uiprmd_vicon"]

#: The 39 Plug-in Gait markers of UI-PRMD's Vicon files, in file order (0-based index = position).
PLUG_IN_GAIT_MARKERS = (
    "LFHD", "RFHD", "LBHD", "RBHD", "C7", "T10", "CLAV", "STRN", "RBAK", "LSHO", "LUPA", "LELB", "LFRM",
    "LWRA", "LWRB", "LFIN", "RSHO", "RUPA", "RELB", "RFRM", "RWRA", "RWRB", "RFIN", "LASI", "RASI", "LPSI",
    "RPSI", "LTHI", "LKNE", "LTIB", "LANK", "LHEE", "LTOE", "RTHI", "RKNE", "RTIB", "RANK", "RHEE", "RTOE",
)  # fmt: skip


def read_uiprmd_vicon(path: str | os.PathLike, *, rate: float = 100.0, units: str | None = None) -> Skeleton:
    """A UI-PRMD Vicon marker file -> :class:`Skeleton` of the 39 markers (lower-case names, m, z up).

    Args:
        path: the ``.txt`` or ``.txt.gz`` file.
        rate: Hz (UI-PRMD's Vicon rate, 100, by default).
        units: unit of the file's numbers (m, cm, mm; ``None``/``"auto"``: millimetres).

    Returns:
        A :class:`Skeleton` whose ``tracked`` is False (and positions NaN) where a marker was lost
        (written as 0, 0, 0).

    Raises:
        FileNotFoundError: no such file. SkeletonFormatError: a row without 117 numbers, a non-number,
        an empty file. ValueError: a bad ``rate`` or ``units``.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such Vicon marker file")
    rate = check_rate(rate, path)
    scale = length_scale(units, "mm", path)
    fields = [f"{m}.{c}" for m in PLUG_IN_GAIT_MARKERS for c in "xyz"]
    rows = []
    for number, line in enumerate(read_lines(path), start=1):
        if not line.strip():
            continue
        tokens = line.strip().rstrip(",").split(",")
        if len(tokens) != len(fields):
            raise SkeletonFormatError(
                path, number, "columns", f"expected {len(fields)} comma-separated values, got {len(tokens)}"
            )
        rows.append(parse_row(tokens, path, number, fields))
    if not rows:
        raise SkeletonFormatError(path, None, "content", "file is empty")
    positions = np.array(rows).reshape(-1, len(PLUG_IN_GAIT_MARKERS), 3)
    lost = (positions == 0).all(2)
    positions = np.where(lost[..., None], np.nan, positions * scale)
    return Skeleton(
        t=np.arange(len(positions)) / rate,
        names=tuple(m.lower() for m in PLUG_IN_GAIT_MARKERS),
        positions=positions,
        tracked=~lost,
        source=f"{path} (uiprmd_vicon)",
        up=np.array([0.0, 0.0, 1.0]),
    )
