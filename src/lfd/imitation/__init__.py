"""Imitation from people: learn a robot skill from a video of a person (docs/video.md).

The pipeline's stages are functions callable from the package, each taking the
configuration (``configs/imitate.yaml``) and the previous stages' results
(:mod:`lfd.imitation.pipeline`): :func:`estimate_pose` -> :func:`analyse` ->
:func:`retarget` -> :func:`fit_dmp` -> :func:`execute` (PyBullet, optionally towards a new
goal) -> :func:`write_outputs`; :func:`run` chains them. ``scripts/imitate.py`` is the Hydra
entry point.

Example (needs MediaPipe and a video)::

    from hydra import compose, initialize_config_dir
    import lfd.imitation

    with initialize_config_dir(config_dir="/abs/path/configs", version_base="1.3"):
        cfg = compose("imitate", overrides=["video=person.mp4", "robot=wam4"])
    summary = lfd.imitation.run(cfg, "outputs/imitate")   # or stage by stage:
    kp = lfd.imitation.estimate_pose(cfg, out)
    t, rt = lfd.imitation.retarget(cfg, lfd.imitation.analyse(cfg, kp, out))
"""

from .pipeline import (
    ROBOTS,
    DMPFit,
    Execution,
    analyse,
    check_config,
    estimate_pose,
    execute,
    fill_missing,
    fit_dmp,
    retarget,
    run,
    write_outputs,
)
from .side_by_side import write_side_by_side

__all__ = [
    "ROBOTS",
    "DMPFit",
    "Execution",
    "analyse",
    "check_config",
    "estimate_pose",
    "execute",
    "fill_missing",
    "fit_dmp",
    "retarget",
    "run",
    "write_outputs",
    "write_side_by_side",
]
