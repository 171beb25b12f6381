"""Observing a person: upper-limb motion and joint torques from skeleton recordings (docs/human.md).

Pipeline: :func:`read_skeleton` (Kinect v2 CSV, NTU RGB+D, UI-PRMD, OpenSim .trc, generic
CSV) -> :func:`analyze_arm` (gap handling, swap repair, filters, trunk frame, closed-form
4-DoF arm IK, smooth fit, Newton-Euler torques) -> :class:`ArmAnalysis` (CSV, OpenSim
.mot, JSON, figures, stick-figure GIF).

Example (runnable)::

    from lfd.human import analyze_arm, read_skeleton
    from lfd.human.synthetic import synthetic_recording

    skeleton = synthetic_recording(duration=5.0, noise=0.01, seed=0).skeleton  # or read_skeleton("file.csv")
    result = analyze_arm(skeleton, side="right", body_mass=80.0, sex="female", filter="butterworth")
    print(result.summary()["abduction_rom_deg"], result.tau.shape)     # range of motion, (T, 4) N m
"""

from .analysis import JOINT_NAMES, ArmAnalysis, analyze_arm
from .readers import FORMATS, SkeletonFormatError, read_skeleton
from .skeleton import Skeleton, canonical_joint_name

__all__ = [
    "FORMATS",
    "JOINT_NAMES",
    "ArmAnalysis",
    "Skeleton",
    "SkeletonFormatError",
    "analyze_arm",
    "canonical_joint_name",
    "read_skeleton",
]
