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

from __future__ import annotations

import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.imitation import ImitationSettings, run
from lfd.imitation.settings import ENTRY_POINT_KEYS

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")

__all__ = ["main", "run", "settings_of"]


def settings_of(cfg: DictConfig) -> ImitationSettings:
    """The composed config's pipeline keys as :class:`ImitationSettings` (interpolations resolved; the
    entry point's own keys, ``paths`` and ``task_name``, left out). Raises ``ValueError`` on a bad value."""
    pipeline = OmegaConf.masked_copy(cfg, [k for k in cfg if k not in ENTRY_POINT_KEYS])
    return ImitationSettings.from_mapping(OmegaConf.to_container(pipeline, resolve=True))


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="imitate")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    try:
        run(settings_of(cfg), HydraConfig.get().runtime.output_dir)
    except (ValueError, FileNotFoundError, FileExistsError) as e:
        print(f"imitate: {e}", file=sys.stderr)
        raise SystemExit(2) from None


if __name__ == "__main__":
    main()
