"""From a demonstration to a robot skill (docs/imitation.md): the Hydra entry point.

Usage::

    python scripts/imitate.py source=person.mp4 robot=wam4 side=right
    python scripts/imitate.py source=recording.csv robot=sawyer side=left         # a skeleton file
    python scripts/imitate.py source=[cam01.mp4,cam02.mp4] calibration=Calib.qca.txt robot=wam4   # calibrated views
    python scripts/imitate.py source=arm.bag robot=wam4 topic=/joint_states        # a ROS 1/2 bag or .mcap
    python scripts/imitate.py source=outputs/teach/export/demo-20261205-101500 robot=wam4
    python scripts/imitate.py source=arm.bag robot=wam4 refine.task=reach refine.target=[0.4,0.2,0.1]

Composes ``configs/imitate.yaml``, turns it into :class:`lfd.imitation.ImitationSettings` (every value
checked once) and runs :func:`lfd.imitation.run` (source -> arm analysis and
retargeting for people -> time-scaled DMP -> optional policy-search refinement -> PyBullet) in the
Hydra run directory: ``dmp.json``, ``robot_trajectory.csv``, ``robot_trajectory.bag``,
``summary.json``, ``refinement.png`` when refining; for people ``arm.csv``/``arm.mot``/``arm.json``;
for a video ``keypoints.csv`` (+ ``.npz``) and ``side_by_side.mp4``/``.gif``; for calibrated views
``keypoints_<camera>.npz``. Bad input is one line on
stderr and exit status 2.
"""

from lfd.cli.imitate import *  # noqa: F403  (the entry point's functions, as the tests import them)
from lfd.cli.imitate import cli, main  # noqa: F401

if __name__ == "__main__":
    cli()
