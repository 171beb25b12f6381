"""Evaluate trained models: ``python evaluate.py [ckpt_dmp=PATH] [ckpt_velocity=PATH] [ckpt_act=PATH]
[ckpt_diffusion=PATH] [eval.scenario=FILE]``.

A thin Hydra entry point (lightning-hydra-template's ``eval.py``): it composes
``configs/evaluate.yaml`` with your overrides, instantiates the evaluator named by
``eval._target_`` and the datamodule it reads, finds the checkpoints, and calls
``evaluator.run(datamodule=..., checkpoints=..., out_dir=...)`` with those plain objects in
this run's output directory, whose path it prints. Metrics, tables and plots land there.

Examples::

    python evaluate.py experiment=quick                   # every policy kind, newest checkpoints
    python evaluate.py eval.scenario=configs/scenarios/mixed.yaml
    python evaluate.py eval=sawyer                        # the Sawyer models' protocol
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import hydra
from hydra.errors import InstantiationException
from omegaconf import DictConfig

from lfd.training import Evaluator
from lfd.visuomotor.eval.evaluator import CKPT_KEYS

#: Errors that are the user's input (a bad checkpoint, scenario file or setting; a missing
#: file): ``main`` prints their one-line message without a traceback and exits with status 2.
USER_ERRORS = (ValueError, FileNotFoundError)


def instantiate_evaluator(cfg: DictConfig) -> Evaluator:
    """``cfg.eval`` instantiated (nested ``_target_``s too, as plain containers); the
    evaluator checks its settings and files (e.g. the scenario file) as it is built.

    Raises:
        TypeError: ``eval._target_`` is not an :class:`lfd.training.Evaluator`.
        ValueError: the evaluator refused a setting or file (its own error, unwrapped from Hydra's).
    """
    try:
        evaluator = hydra.utils.instantiate(cfg.eval, _convert_="all")
    except InstantiationException as e:
        if isinstance(e.__cause__, ValueError):
            raise e.__cause__ from None
        raise
    if not isinstance(evaluator, Evaluator):
        raise TypeError(
            f"eval._target_={cfg.eval._target_}: {type(evaluator).__name__} is not an lfd.training.Evaluator"
        )
    return evaluator


def evaluate(cfg: DictConfig, out_dir: str | Path) -> dict[str, Any]:
    """Instantiate ``cfg.eval`` (which checks its scenario file first) and (for evaluators that
    read a dataset) ``cfg.data``, resolve the checkpoints (``ckpt_dmp``, ``ckpt_velocity``,
    ``ckpt_act``, ``ckpt_diffusion``, ``eval.checkpoint`` or the newest under
    ``paths.output_root``) and run; returns the metrics
    (:func:`instantiate_evaluator` raises; a bad checkpoint raises
    :class:`lfd.training.CheckpointError`, a bad scenario file
    :class:`lfd.visuomotor.eval.scenario.ScenarioError`, both ``ValueError``s)."""
    evaluator = instantiate_evaluator(cfg)
    datamodule = hydra.utils.instantiate(cfg.data) if evaluator.needs_datamodule else None
    given = {kind: cfg.get(key) for kind, key in CKPT_KEYS.items()}
    checkpoints = evaluator.resolve_checkpoints(cfg.paths.output_root, given)
    return evaluator.run(datamodule=datamodule, checkpoints=checkpoints, out_dir=Path(out_dir))


@hydra.main(version_base="1.3", config_path="configs", config_name="evaluate")
def main(cfg: DictConfig) -> str:
    import lightning as L

    L.seed_everything(cfg.seed, workers=True)
    out_dir = Path(cfg.paths.output_dir)
    try:
        evaluate(cfg, out_dir)
    except USER_ERRORS as e:
        print(f"evaluate: {e}", file=sys.stderr)
        raise SystemExit(2) from None
    print(f"[lfd] evaluation written to: {out_dir}")
    return str(out_dir)


if __name__ == "__main__":
    main()
