"""Observing a person: upper-limb motion and joint torques from skeleton recordings (docs/human.md).

Pipeline: :func:`read_skeleton` (Kinect v2 CSV, NTU RGB+D, UI-PRMD, OpenSim .trc, generic
CSV) -> :func:`analyze_arm` (gap handling, swap repair, filters, trunk frame, closed-form
arm IK in the ISB convention: plane of elevation, elevation 0-180 deg, axial rotation, elbow
flexion; smooth fit, Newton-Euler torques) -> :class:`ArmAnalysis` (CSV, OpenSim .mot,
JSON, figures, stick-figure GIF; the thesis's abduction/flexion/rotation as derived columns).

Example (runnable)::

    from lfd.human import analyze_arm, read_skeleton
    from lfd.human.synthetic import synthetic_recording

    skeleton = synthetic_recording(duration=5.0, noise=0.01, seed=0).skeleton  # or read_skeleton("file.csv")
    result = analyze_arm(skeleton, side="right", body_mass=80.0, sex="female", filter="butterworth")
    print(result.summary()["elevation_max_deg"], result.tau.shape)     # peak elevation (deg), (T, 4) N m
"""

from .analysis import JOINT_NAMES, THESIS_NAMES, ArmAnalysis, analyze_arm
from .readers import FORMATS, SkeletonFormatError, read_skeleton
from .skeleton import Skeleton, canonical_joint_name

__all__ = [
    "FORMATS",
    "JOINT_NAMES",
    "THESIS_NAMES",
    "ArmAnalysis",
    "Skeleton",
    "SkeletonFormatError",
    "analyze_arm",
    "canonical_joint_name",
    "read_skeleton",
]
