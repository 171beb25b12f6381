"""Train a model: ``python train.py [model=...] [data=...] [trainer=...] [experiment=...]``.

A thin Hydra entry point: it composes ``configs/train.yaml`` with your overrides,
instantiates the ``_target_`` classes (datamodule, LightningModule, callbacks, loggers,
trainer) and fits. Everything numeric lives in ``src/lfd``.

Examples::

    python train.py                                   # quick reaching data + CNN->DMP policy
    python train.py -m model=cnn_dmp,velocity         # both visuomotor policies, one after the other
    python train.py experiment=original trainer=gpu   # original-scale data on a GPU
    python train.py trainer=ddp trainer.devices=2     # Lightning DDP (gloo on CPU)
    python train.py trainer.fast_dev_run=true         # one batch of train + val, a smoke test
    python train.py experiment=sawyer_models          # the Sawyer forward + inverse models
"""

from __future__ import annotations

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.training import Adaptable, AdaptationSource


def _instantiate_group(group: DictConfig | None) -> list:
    """Instantiate every ``_target_`` entry of a config group mapping (callbacks, loggers)."""
    if not group:
        return []
    return [hydra.utils.instantiate(c) for c in group.values() if c is not None and "_target_" in c]


@hydra.main(version_base="1.3", config_path="configs", config_name="train")
def main(cfg: DictConfig) -> str | None:
    import lightning as L

    L.seed_everything(cfg.seed, workers=True)
    datamodule = hydra.utils.instantiate(cfg.data)
    model = hydra.utils.instantiate(cfg.model)
    callbacks = _instantiate_group(cfg.get("callbacks"))
    loggers = _instantiate_group(cfg.get("logger"))
    trainer = hydra.utils.instantiate(cfg.trainer, callbacks=callbacks, logger=loggers or False)
    # a model that takes statistics (and demonstrations) from its data gets them as plain objects
    if isinstance(model, Adaptable) and isinstance(datamodule, AdaptationSource):
        model.adapt(datamodule.adaptation_data())

    if trainer.is_global_zero:
        print(OmegaConf.to_yaml(cfg, resolve=False))
    trainer.fit(model=model, datamodule=datamodule, ckpt_path=cfg.get("ckpt_path"))
    if cfg.get("test"):
        trainer.test(
            model=model,
            datamodule=datamodule,
            ckpt_path="best" if not cfg.trainer.get("fast_dev_run") else None,
        )

    callback = trainer.checkpoint_callback
    ckpt = callback.last_model_path if callback else None
    if trainer.is_global_zero:
        print(f"[lfd] run directory: {cfg.paths.output_dir}")
        if ckpt:
            print(f"[lfd] checkpoint: {ckpt}")
            if callback.monitor and callback.best_model_score is not None:
                # Lightning >= 2.6 writes last.ckpt only beside a new best monitored checkpoint
                import torch

                step = torch.load(ckpt, map_location="cpu", weights_only=False, mmap=True).get(
                    "global_step"
                )  # no tensor is read
                best = float(callback.best_model_score)
                print(
                    f"[lfd]   the best {callback.monitor} on validation ({best:.4g}), "
                    f"at step {step} of {trainer.global_step}"
                )
    return ckpt


if __name__ == "__main__":
    main()
