"""Several calibrated cameras: calibration files, confidence-weighted DLT triangulation.

Calibration formats (:func:`read_calibration`):

* Qualisys ``.qca.txt`` (XML; what Pose2Sim ships): per camera the position (mm) and
  orientation of the camera in the lab, intrinsics in sub-pixel units (1/64 px). The camera
  looks along its ``-z`` with ``y`` up, so the OpenCV rotation is ``Rx(pi) @ M`` with ``M``
  the file's matrix (``r11 .. r33`` row by row), translation ``-R @ position``. Distortion
  is radial ``k1, k2`` and tangential ``p1, p2`` of normalised coordinates.
* TOML (Pose2Sim/Sports2D style): one table per camera with ``matrix`` (3x3), ``distortions``
  (k1, k2, p1, p2), ``rotation`` (Rodrigues vector, world -> camera), ``translation`` (m),
  ``size`` ([w, h] px).
* JSON: ``{"cameras": [{"name", "matrix", "distortions", "rotation" (3x3 or Rodrigues),
  "translation", "size"}, ...]}``, the same meaning.

:func:`triangulate` solves each joint by weighted DLT on undistorted normalised
coordinates (weights = landmark confidence), then repeatedly drops the view with the largest
reprojection error while that error exceeds ``max_error_px`` and at least ``min_views``
views remain (``strategy="subsets"``: Pose2Sim's search over subsets of views instead); it
reports the per-joint reprojection error (px).

The ``.qca.txt`` reader follows the conventions of Pose2Sim's own converter
(``Pose2Sim.calibration.read_qca`` + ``calib_qca_fun``: ``R = Rx(pi) @ M``, principal point
minus the video field's ``left``/``top``, sizes from ``fov_video``), except that Pose2Sim
also divides the distortion coefficients by 64 and this reader does not.

Example::

    >>> from lfd.human.multiview import read_calibration, triangulate   # doctest: +SKIP
    >>> calib = read_calibration("calibration/Calib.qca.txt")           # doctest: +SKIP
    >>> result = triangulate(calib, pixels, confidence)                 # doctest: +SKIP
"""

from .calibration import Calibration, read_calibration
from .labels import LabelReconciliation, reconcile_left_right
from .triangulation import Triangulation, triangulate

__all__ = [
    "Calibration",
    "LabelReconciliation",
    "Triangulation",
    "read_calibration",
    "reconcile_left_right",
    "triangulate",
]
