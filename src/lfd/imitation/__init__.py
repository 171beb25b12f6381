"""Imitation: from any demonstration (a video, several calibrated videos or a skeleton file of a person, a
teach export, a robot bag or joint CSV) to a robot skill, refined by policy search and executed (docs/imitation.md).

The pipeline's stages are functions callable from the package, each taking the validated settings
(:class:`ImitationSettings`, the keys of ``configs/imitate.yaml``; :mod:`lfd.imitation.settings`) and the
previous stages' results (:mod:`lfd.imitation.pipeline`): :func:`estimate_pose` -> :func:`analyse` (or
:func:`analyse_skeleton`) -> :func:`retarget` -> :func:`fit_dmp` -> :func:`refine` -> :func:`execute`
(PyBullet, optionally towards a new goal) -> outputs; :func:`run` chains them. ``scripts/imitate.py``
is the Hydra entry point; it turns the composed config into :class:`ImitationSettings`. The robots
offered are the catalogue's with a retargeting kind (:func:`imitation_robots`).

Example (needs MediaPipe and a video)::

    from pathlib import Path
    import lfd.imitation
    from lfd.imitation import ImitationSettings

    settings = ImitationSettings(source="person.mp4", robot="wam4")   # or ImitationSettings.from_mapping({...})
    summary = lfd.imitation.run(settings, "outputs/imitate")           # or stage by stage:
    out = Path("outputs/imitate")
    kp = lfd.imitation.estimate_pose(settings, out)
    t, rt = lfd.imitation.retarget(settings, lfd.imitation.analyse(settings, kp, out))
"""

from .pipeline import (
    RETARGETERS,
    analyse,
    analyse_skeleton,
    basis_count,
    estimate_pose,
    execute,
    fill_missing,
    fit_dmp,
    refine,
    retarget,
    run,
    source_of,
)
from .results import DMPFit, Execution
from .settings import ImitationSettings, imitation_robots
from .side_by_side import write_outputs, write_side_by_side

__all__ = [
    "RETARGETERS",
    "DMPFit",
    "Execution",
    "ImitationSettings",
    "analyse",
    "analyse_skeleton",
    "basis_count",
    "estimate_pose",
    "execute",
    "fill_missing",
    "fit_dmp",
    "imitation_robots",
    "refine",
    "retarget",
    "run",
    "source_of",
    "write_outputs",
    "write_side_by_side",
]
