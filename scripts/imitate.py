"""Learn a robot skill from a video of a person (docs/video.md): the Hydra entry point.

Usage::

    python scripts/imitate.py video=person.mp4 robot=wam4 side=right
    python scripts/imitate.py video=person.mp4 robot=sawyer goal=[0.6,-0.1,0.5]

Composes ``configs/imitate.yaml`` and runs :func:`lfd.imitation.run` (video -> pose -> arm
angles -> retargeting -> time-scaled DMP -> PyBullet -> side-by-side video) in the Hydra run
directory: ``keypoints.csv`` (+ ``.npz``), ``arm.csv``/``arm.mot``/``arm.json``, ``dmp.json``,
``robot_trajectory.csv``, ``summary.json``, ``side_by_side.mp4`` and ``side_by_side.gif``.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

from lfd.imitation import run

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")

__all__ = ["main", "run"]


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="imitate")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    run(cfg, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    main()
