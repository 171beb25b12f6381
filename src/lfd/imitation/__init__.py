"""Imitation: from any demonstration (a video, several calibrated videos or a skeleton file of a person, a
teach export, a robot bag or joint CSV) to a robot skill, refined by policy search and executed (docs/imitation.md).

The pipeline's stages are functions callable from the package, each taking the
configuration (``configs/imitate.yaml``) and the previous stages' results
(:mod:`lfd.imitation.pipeline`): :func:`estimate_pose` -> :func:`analyse` (or
:func:`analyse_skeleton`) -> :func:`retarget` -> :func:`fit_dmp` -> :func:`refine` -> :func:`execute`
(PyBullet, optionally towards a new goal) -> outputs; :func:`run` chains them. ``scripts/imitate.py``
is the Hydra entry point.

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
    analyse_skeleton,
    basis_count,
    check_config,
    estimate_pose,
    execute,
    fill_missing,
    fit_dmp,
    refine,
    retarget,
    run,
    source_of,
)
from .side_by_side import write_outputs, write_side_by_side

__all__ = [
    "ROBOTS",
    "DMPFit",
    "Execution",
    "analyse",
    "analyse_skeleton",
    "basis_count",
    "check_config",
    "estimate_pose",
    "execute",
    "fill_missing",
    "fit_dmp",
    "refine",
    "retarget",
    "run",
    "source_of",
    "write_outputs",
    "write_side_by_side",
]
