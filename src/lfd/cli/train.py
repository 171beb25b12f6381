"""``lfd-train`` / ``python train.py``: train a model (the entry point; the repository's
``train.py`` documents the command and is a wrapper of this module).

Composes ``configs/train.yaml`` with the command-line overrides, instantiates the ``_target_``
classes (datamodule, LightningModule, callbacks, loggers, trainer) and fits; a visuomotor policy
records its run's experiment and data settings in its checkpoints, which ``lfd-evaluate`` follows.
"""

from __future__ import annotations

import re
import sys
import time
from pathlib import Path
from typing import Any

import hydra
from hydra.errors import InstantiationException
from omegaconf import DictConfig, OmegaConf

from lfd.cli import configs_dir, quiet, run_app, user_errors
from lfd.cli.config import instantiate_node
from lfd.io.files import write_json_atomic
from lfd.training import (
    Adaptable,
    AdaptationSource,
    CheckpointError,
    check_state_dict,
    read_checkpoint,
    resolve_precision,
)

#: ``ckpt_path`` values Lightning resolves itself (no file of that name is read here).
LIGHTNING_CKPT_NAMES = ("last", "best", "hpc")
#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()


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


def check_resume_fits(ckpt_path: str | None, model) -> None:
    """Refuse a ``ckpt_path`` to resume from that was written for another model than this run's:
    another kind (the ``kind`` hyper-parameter), or a state_dict with a missing or extra key or a
    tensor of another shape (:func:`lfd.training.check_state_dict`; shapes only, no tensor is
    read); one line on stderr naming the file, its kind and the key or shape, exit status 2."""
    if ckpt_path is None or str(ckpt_path) in LIGHTNING_CKPT_NAMES:
        return
    try:
        ckpt = read_checkpoint(ckpt_path, keys=("state_dict",))
        hparams = ckpt.get("hyper_parameters", {})
        kind, own = hparams.get("kind"), getattr(model, "kind", None)
        if own and kind != own:
            raise CheckpointError(
                f"{ckpt_path}: a {kind!r} checkpoint, this run's model is {own!r} (model=...)"
            )
        ckpt = {**ckpt, "state_dict": dict(ckpt["state_dict"])}  # the model's hook may drop retired entries
        model.on_load_checkpoint(ckpt)
        check_state_dict(ckpt_path, kind, model.state_dict(), ckpt["state_dict"], f"this run's model={own}")
    except (CheckpointError, FileNotFoundError) as e:
        print(f"train: ckpt_path={ckpt_path}: {e}", file=sys.stderr)
        raise SystemExit(2) from None


def _train_size(datamodule) -> dict:
    """``train_items`` (the train dataset's length) and ``train_episodes`` (demonstrations, for a
    reaching datamodule) where the datamodule has them; empty otherwise."""
    out = {}
    datasets = getattr(datamodule, "datasets", None)
    if isinstance(datasets, dict) and "train" in datasets:
        out["train_items"] = len(datasets["train"])
    split = getattr(getattr(datamodule, "data", None), "split", None)
    if callable(split):
        out["train_episodes"] = len(split("train"))
    return out


def policy_class(cfg: DictConfig) -> type | None:
    """The registered visuomotor policy class ``cfg.model`` names, or None for another model
    (e.g. the Sawyer models)."""
    from lfd.visuomotor.policies import VisuomotorPolicy

    cls = hydra.utils.get_class(cfg.model._target_)
    return cls if isinstance(cls, type) and issubclass(cls, VisuomotorPolicy) and cls.kind else None


def instantiate_data_and_model(cfg: DictConfig) -> tuple[Any, Any]:
    """The datamodule and the model of ``cfg``. A policy takes its dataset settings from the data
    config (``data_arguments``), the datamodule serves the policy's item layout (``item_mode``),
    and the policy records this run's experiment and data settings for its checkpoints."""
    from hydra.core.hydra_config import HydraConfig

    cls = policy_class(cfg)
    if cls is None:
        return instantiate_node("data", cfg.data), hydra.utils.instantiate(cfg.model)
    data = OmegaConf.to_container(cfg.data, resolve=True)
    twice = sorted(set(cls.DATA_ARGUMENTS) & set(cfg.model))
    try:
        if twice:
            raise ValueError(f"model.{twice[0]}: set by the data config (data.{twice[0]}), not the model")
        arguments = cls.data_arguments(data)
    except ValueError as e:
        print(f"train: model={cls.kind}: {e}", file=sys.stderr)
        raise SystemExit(2) from None
    datamodule = instantiate_node("data", cfg.data, mode=cls.item_mode)  # a bad data.* setting: one line
    try:
        model = hydra.utils.instantiate(cfg.model, **arguments)
    except InstantiationException as e:  # a misspelt or out-of-range model setting: its one line
        if not isinstance(e.__cause__, (TypeError, ValueError)):
            raise
        print(f"train: model={cls.kind}: {e.__cause__}", file=sys.stderr)
        raise SystemExit(2) from None
    choices = HydraConfig.get().runtime.choices if HydraConfig.initialized() else {}
    model.training_run = {
        "experiment": choices.get("experiment"),
        "data_config": choices.get("data"),
        "seed": cfg.get("seed"),
        "data": data,
    }
    return datamodule, model


def check_evaluate(cfg: DictConfig) -> str | None:
    """The policy kind to evaluate after training (``evaluate=true``), or None; one line on
    stderr and exit status 2 for a model that is no visuomotor policy."""
    if not cfg.get("evaluate"):
        return None
    cls = policy_class(cfg)
    if cls is None or "kinds" not in cfg.eval:
        what = f"model {cfg.model._target_}" if cls is None else f"eval {cfg.eval._target_}"
        print(f"train: evaluate=true: {what} is not a policy and evaluator that score one policy kind",
              file=sys.stderr)  # fmt: skip
        raise SystemExit(2)
    return cls.kind


def evaluate_checkpoint(cfg: DictConfig, kind: str, ckpt: str, datamodule) -> Path:
    """Score ``ckpt`` (policy ``kind``) with this run's ``eval`` settings on this run's data
    (the evaluator's ``run``); writes ``<run dir>/evaluate/``. Test-time colour averaging only
    for a policy trained with colour augmentation."""
    out = Path(cfg.paths.output_dir) / "evaluate"
    settings = OmegaConf.to_container(cfg.eval, resolve=True)
    settings["kinds"] = [kind]
    if not cfg.model.get("colour_augment"):
        settings["colour_tta"] = []
    evaluator = hydra.utils.instantiate(settings, _convert_="all")
    evaluator.run(datamodule=datamodule, checkpoints={kind: Path(ckpt)}, out_dir=out)
    return out


@hydra.main(version_base="1.3", config_path=str(CONFIGS), config_name="train")
def main(cfg: DictConfig) -> str | None:
    with user_errors("train"):  # a bad file or setting (a dataset, a checkpoint): one line, exit status 2
        return run(cfg)


def run(cfg: DictConfig) -> str | None:
    """Fit the model of ``cfg`` on its data (resuming from ``ckpt_path``), print the run directory
    and the checkpoint, write ``timing.json``, score the checkpoint with ``evaluate=true``;
    returns the last checkpoint's path (None without a checkpoint callback)."""
    import lightning as L

    check_resume(cfg.get("ckpt_path"))
    kind = check_evaluate(cfg)
    L.seed_everything(cfg.seed, workers=True)
    datamodule, model = instantiate_data_and_model(cfg)
    callbacks = _instantiate_group(cfg.get("callbacks"))
    loggers = _instantiate_group(cfg.get("logger"))
    # bf16 on a CPU without it: float32 (one warning); no precision key: Lightning's default (None)
    precision = resolve_precision(cfg.trainer.get("precision"), cfg.trainer.get("accelerator", "auto"))
    trainer = hydra.utils.instantiate(
        cfg.trainer, callbacks=callbacks, logger=loggers or False, precision=precision
    )
    # a model that takes statistics (and demonstrations) from its data gets them as plain objects
    if isinstance(model, Adaptable) and isinstance(datamodule, AdaptationSource):
        model.adapt(datamodule.adaptation_data())
    check_resume_fits(cfg.get("ckpt_path"), model)

    if trainer.is_global_zero:
        print(OmegaConf.to_yaml(cfg, resolve=False))
    started = time.perf_counter()
    trainer.fit(model=model, datamodule=datamodule, ckpt_path=cfg.get("ckpt_path"), weights_only=True)
    fit_s = time.perf_counter() - started
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
        write_json_atomic(
            Path(cfg.paths.output_dir) / "timing.json",
            {"fit_s": fit_s, "global_step": trainer.global_step, **_train_size(datamodule)},
        )
        if kind is not None and ckpt:
            print(f"[lfd] evaluation written to: {evaluate_checkpoint(cfg, kind, ckpt, datamodule)}")
    return ckpt


USAGE = """
lfd-train (python train.py): train a model (configs/train.yaml); Hydra overrides key=value
  model=cnn_dmp|velocity|act|diffusion|sawyer_models   the model (default cnn_dmp)
  experiment=quick|original|sawyer_models|metaworld    a set of data, model and trainer settings
  data=quick|original|lerobot|metaworld                the dataset (generated when missing)
  trainer=cpu|gpu|ddp   seed=42   ckpt_path=PATH (resume)   evaluate=true (score after training)
  +trainer.fast_dev_run=true                           one batch of train + val, a smoke test
  -m key=a,b                                           one run per value (multirun)
Outputs: outputs/train/<date>_<time>/ (checkpoints, TensorBoard); --hydra-help: Hydra's own help.
"""


#: Overrides that ask for no experiment, which is the default (``experiment: null``); they are left
#: out, since the defaults list's ``${experiment}_${model}`` cannot resolve without the group.
NO_EXPERIMENT = re.compile(r"~experiment(=.*)?|experiment=(null|~)?")


def without_experiment_removal(argv: list[str]) -> list[str]:
    """``argv`` without ``~experiment`` (``~experiment=X``, ``experiment=null``): no experiment is
    the default, and Hydra could not compose ``configs/train.yaml`` without the group."""
    return [a for a in argv if not NO_EXPERIMENT.fullmatch(a)]


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-train`` command (``python train.py``): ``--help`` prints :data:`USAGE`."""
    quiet()
    run_app(main, USAGE, without_experiment_removal(list(sys.argv[1:] if argv is None else argv)))


if __name__ == "__main__":
    cli()
