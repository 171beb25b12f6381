"""lfd: learning robot manipulation skills by observation.

Packages, one capability each; a package imports only those in rows below its own
(checked by the import-linter contracts in ``pyproject.toml``; ``docs/architecture.md``)::

    imitation/ teach/ interop/        video -> robot pipeline; browser teach app; LeRobot, robomimic
    visuomotor/ model_reaching/ human/  visuomotor policies (data, the policy registry, eval);
                                      Sawyer forward/inverse models (thesis ch. 5); observing people
    sim/  training                    the only PyBullet owner; Lightning helpers
    rl/  robots/                      PoWER, PI^BB, CMA-ES; robot models, batched FK/IK/RNE, spatial maths
    dmp/                              DMPs, fitting, batched + differentiable layer
    io/                               atomic writes, checksums, MP4 video
    checks                            argument checks (numpy and the standard library only)

Nothing here imports Hydra: the entry points (``train.py``, ``evaluate.py``, ``scripts/``)
compose configs and pass plain objects down.
"""

__version__ = "0.1.0"
