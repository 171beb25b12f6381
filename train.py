"""Train a model: ``python train.py [model=...] [data=...] [trainer=...] [experiment=...]``.

A thin Hydra entry point: it composes ``configs/train.yaml`` with your overrides,
instantiates the ``_target_`` classes (datamodule, LightningModule, callbacks, loggers,
trainer) and fits. Everything numeric lives in ``src/lfd``.

Examples::

    python train.py                                   # quick reaching data + CNN->DMP policy
    python train.py -m model=cnn_dmp,velocity         # both visuomotor policies, one after the other
    python train.py experiment=original trainer=gpu   # original-scale data on a GPU
    python train.py trainer=ddp trainer.devices=2     # Lightning DDP (gloo on CPU)
    python train.py +trainer.fast_dev_run=true        # one batch of train + val, a smoke test
    python train.py experiment=sawyer_models          # the Sawyer forward + inverse models
    python train.py -m experiment=quick +grid=policies hydra/launcher=joblib   # the policy grid
                                                      # (scripts/collect_grid.py tabulates it)

A visuomotor policy (a model whose class is a registered :class:`lfd.visuomotor.policies.VisuomotorPolicy`)
gets its dataset settings from the data config (``data_arguments``), the datamodule serves its
item layout (``item_mode``), and its checkpoint records the run's experiment and data settings, so
that ``python evaluate.py`` follows them. With ``evaluate=true`` it is scored right after training
by the ``eval`` settings of this config (e.g. ``eval.split=val``; the test split by default) on this
run's data, into ``<run dir>/evaluate/metrics.json``: one self-contained result per multirun job
(and ``timing.json``: training wall time).
"""

from lfd.cli.train import *  # noqa: F403  (the entry point's functions, as the tests and notebooks import them)
from lfd.cli.train import cli, main  # noqa: F401

if __name__ == "__main__":
    cli()
