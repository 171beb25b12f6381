"""``lfd-imitate`` / ``python scripts/imitate.py``: a demonstration -> a robot skill.

The entry point; the repository's ``scripts/imitate.py`` documents the command and is a wrapper of
this module.
"""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.cli import configs_dir, run_app
from lfd.imitation import ImitationSettings, run
from lfd.imitation.settings import ENTRY_POINT_KEYS

#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()

__all__ = ["main", "run", "settings_of"]


def settings_of(cfg: DictConfig) -> ImitationSettings:
    """The composed config's pipeline keys as :class:`ImitationSettings` (interpolations resolved; the
    entry point's own keys, ``paths`` and ``task_name``, left out). Raises ``ValueError`` on a bad value."""
    pipeline = OmegaConf.masked_copy(cfg, [k for k in cfg if k not in ENTRY_POINT_KEYS])
    return ImitationSettings.from_mapping(OmegaConf.to_container(pipeline, resolve=True))


@hydra.main(version_base="1.3", config_path=str(CONFIGS), config_name="imitate")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    try:
        run(settings_of(cfg), HydraConfig.get().runtime.output_dir)
    except (ValueError, FileNotFoundError, FileExistsError) as e:
        print(f"imitate: {e}", file=sys.stderr)
        raise SystemExit(2) from None


USAGE = """
lfd-imitate (python scripts/imitate.py): a demonstration -> a robot skill (configs/imitate.yaml)
  source=FILE|FOLDER|[FILE,...]   a joint CSV, skeleton file, video, ROS bag / MCAP, teach export, views
  source_type=...                 the kind of source when its name does not say (e.g. joint_csv)
  robot=wam4|sawyer|pr2_right_arm|panda|iiwa14   side=right|left   topic=/joint_states (a bag)
  calibration=FILE                the cameras of calibrated views
  refine.task=reach refine.target=[x,y,z]   refine the DMP by policy search (refine.method=power)
Outputs: outputs/imitate/<date>_<time>/ (dmp.json, robot_trajectory.csv/.bag, summary.json).
"""


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-imitate`` command (``python scripts/imitate.py``): ``--help`` prints :data:`USAGE`."""
    run_app(main, USAGE, argv)


if __name__ == "__main__":
    cli()
