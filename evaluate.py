"""Evaluate trained models: ``python evaluate.py [ckpt_dmp=PATH] [ckpt_velocity=PATH] [eval.scenario=FILE]``.

A thin Hydra entry point: it composes ``configs/evaluate.yaml`` with your overrides,
instantiates the evaluator named by ``eval._target_`` and runs it in this run's output
directory, whose path it prints. Metrics, tables and plots land there.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig


@hydra.main(version_base="1.3", config_path="configs", config_name="evaluate")
def main(cfg: DictConfig) -> str:
    import lightning as L

    L.seed_everything(cfg.seed, workers=True)
    out_dir = Path(cfg.paths.output_dir)
    evaluator = hydra.utils.instantiate(cfg.eval, _recursive_=False)
    evaluator.run(cfg, out_dir)
    print(f"[lfd] evaluation written to: {out_dir}")
    return str(out_dir)


if __name__ == "__main__":
    main()
