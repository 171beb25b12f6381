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

import sys

import hydra
from omegaconf import DictConfig, OmegaConf

from lfd.training import Adaptable, AdaptationSource, CheckpointError, read_checkpoint

#: ``ckpt_path`` values Lightning resolves itself (no file of that name is read here).
LIGHTNING_CKPT_NAMES = ("last", "best", "hpc")


def _instantiate_group(group: DictConfig | None) -> list:
    """Instantiate every ``_target_`` entry of a config group mapping (callbacks, loggers)."""
    if not group:
        return []
    return [hydra.utils.instantiate(c) for c in group.values() if c is not None and "_target_" in c]


def check_resume(ckpt_path: str | None) -> None:
    """Refuse a ``ckpt_path`` to resume from that is not a checkpoint of train.py with one line
    on stderr (exit status 2), before any data is touched; no code from the file runs
    (:func:`lfd.training.read_checkpoint`)."""
    if ckpt_path is None or str(ckpt_path) in LIGHTNING_CKPT_NAMES:
        return
    try:
        read_checkpoint(ckpt_path, keys=("state_dict",))
    except (CheckpointError, FileNotFoundError) as e:
        print(f"train: ckpt_path={ckpt_path}: {e}", file=sys.stderr)
        raise SystemExit(2) from None


@hydra.main(version_base="1.3", config_path="configs", config_name="train")
def main(cfg: DictConfig) -> str | None:
    import lightning as L

    check_resume(cfg.get("ckpt_path"))
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
    trainer.fit(model=model, datamodule=datamodule, ckpt_path=cfg.get("ckpt_path"), weights_only=True)
    if cfg.get("test"):
        trainer.test(
            model=model,
            datamodule=datamodule,
            ckpt_path="best" if not cfg.trainer.get("fast_dev_run") else None,
            weights_only=True,
        )

    callback = trainer.checkpoint_callback
    ckpt = callback.last_model_path if callback else None
    if trainer.is_global_zero:
        print(f"[lfd] run directory: {cfg.paths.output_dir}")
        if ckpt:
            print(f"[lfd] checkpoint: {ckpt}")
            if callback.monitor and callback.best_model_score is not None:
                # Lightning >= 2.6 writes last.ckpt only beside a new best monitored checkpoint
                step = read_checkpoint(ckpt).get("global_step")  # no tensor is read
                best = float(callback.best_model_score)
                print(
                    f"[lfd]   the best {callback.monitor} on validation ({best:.4g}), "
                    f"at step {step} of {trainer.global_step}"
                )
    return ckpt


if __name__ == "__main__":
    main()
