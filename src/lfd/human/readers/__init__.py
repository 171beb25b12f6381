"""Skeleton file readers, one module per format: Kinect v2 CSV (KIMORE, :mod:`.kinect_csv`),
NTU RGB+D ``.skeleton`` (:mod:`.ntu`), UI-PRMD (:mod:`.uiprmd`), OpenSim ``.trc`` (:mod:`.trc`) and
generic CSV (:mod:`.generic_csv`); format sniffing and dispatch in :mod:`.dispatch`. UI-PRMD's Vicon
marker files (39 Plug-in Gait markers, mm, z up) are read by :func:`read_uiprmd_vicon`
(:mod:`.vicon`, called explicitly: their names are those of the Kinect files).

:func:`read_skeleton` infers the format from the name and first line where that is
unambiguous; ``.gz`` files are read transparently. Every reader returns a
:class:`~lfd.human.skeleton.Skeleton` in metres with canonical joint names, and raises
:class:`SkeletonFormatError` (a ``ValueError``) naming the file, the 1-based line and the
field when the content is malformed; a missing file raises ``FileNotFoundError``.

``units=`` (``"m"``, ``"cm"``, ``"mm"``; ``None``/``"auto"``: the format's own unit, listed below)
is the length unit of the file's coordinates. :func:`read_skeleton` then refuses a recording
whose scale is not a person's (:mod:`lfd.human.plausibility`): an upper arm outside 0.15-0.6 m
(the message suggests the ``units=`` that fits) or a frame rate outside 1-1000 Hz.

==============  ===========================================================================
format          layout
==============  ===========================================================================
``kinect_csv``  one row per frame, no header, 25 Kinect joints x (x, y, z, tracking state),
                metres, camera frame (y up); blank row = no body; ``rate`` Hz (default 30)
``ntu``         NTU RGB+D ``.skeleton``: frame count, then per frame bodies x 25 joints x 12
                values; the body with the most frames is taken (or ``body=``: index or id)
``uiprmd``      UI-PRMD Kinect: ``.../Positions/<name>_positions.txt`` and its sibling
                ``.../Angles/<name>_angles.txt``; 22 joints, cm, local offsets and Euler
                angles (``euler_order``, default ``"ZXY"``), 30 Hz
``trc``         OpenSim marker file (tab-separated, ``Units`` mm/cm/m, y up unless ``up=``)
``csv``         generic CSV with a header: long (``t, joint, x, y, z[, tracked]``) or wide
                (``t, <joint>_x, <joint>_y, <joint>_z, ...``), metres; ``up`` option
==============  ===========================================================================

Example::

    >>> from lfd.human import read_skeleton
    >>> sk = read_skeleton("tests/fixtures/human/kimore_ex1_excerpt.csv")   # doctest: +SKIP
    >>> sk.joint("elbow_right").shape                                       # doctest: +SKIP
    (120, 3)
"""

from .common import SkeletonFormatError
from .dispatch import FORMATS, NATIVE_UNITS, iter_skeleton_files, read_skeleton
from .uiprmd import UIPRMD_JOINTS, UIPRMD_PARENTS, uiprmd_global_positions
from .vicon import PLUG_IN_GAIT_MARKERS, read_uiprmd_vicon

__all__ = [
    "FORMATS",
    "NATIVE_UNITS",
    "PLUG_IN_GAIT_MARKERS",
    "UIPRMD_JOINTS",
    "UIPRMD_PARENTS",
    "SkeletonFormatError",
    "iter_skeleton_files",
    "read_skeleton",
    "read_uiprmd_vicon",
    "uiprmd_global_positions",
]
