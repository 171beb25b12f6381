"""Evaluate trained models: ``python evaluate.py [ckpt_dmp=PATH] [ckpt_velocity=PATH] [eval.scenario=FILE]``.

A thin Hydra entry point (lightning-hydra-template's ``eval.py``): it composes
``configs/evaluate.yaml`` with your overrides, instantiates the evaluator named by
``eval._target_`` and the datamodule it reads, finds the checkpoints, and calls
``evaluator.run(datamodule=..., checkpoints=..., out_dir=...)`` with those plain objects in
this run's output directory, whose path it prints. Metrics, tables and plots land there.

Examples::

    python evaluate.py experiment=quick                   # both policies, newest checkpoints
    python evaluate.py eval.scenario=configs/scenarios/mixed.yaml
    python evaluate.py eval=sawyer                        # the Sawyer models' protocol
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import hydra
from omegaconf import DictConfig

from lfd.training import Evaluator
from lfd.visuomotor.eval.evaluator import CKPT_KEYS


def instantiate_evaluator(cfg: DictConfig) -> Evaluator:
    """``cfg.eval`` instantiated (nested ``_target_``s too, as plain containers).

    Raises:
        TypeError: ``eval._target_`` is not an :class:`lfd.training.Evaluator`.
    """
    evaluator = hydra.utils.instantiate(cfg.eval, _convert_="all")
    if not isinstance(evaluator, Evaluator):
        raise TypeError(
            f"eval._target_={cfg.eval._target_}: {type(evaluator).__name__} is not an lfd.training.Evaluator"
        )
    return evaluator


def evaluate(cfg: DictConfig, out_dir: str | Path) -> dict[str, Any]:
    """Instantiate ``cfg.eval`` and (for evaluators that read a dataset) ``cfg.data``, resolve
    the checkpoints (``ckpt_dmp``, ``ckpt_velocity``, ``eval.checkpoint`` or the newest under
    ``paths.output_root``) and run; returns the metrics (:func:`instantiate_evaluator` raises)."""
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
    evaluate(cfg, out_dir)
    print(f"[lfd] evaluation written to: {out_dir}")
    return str(out_dir)


if __name__ == "__main__":
    main()
