"""Evaluate trained models: ``python evaluate.py [ckpt=PATH | ckpt=[PATH,...]] [eval.kinds=[...]]
[eval.scenario=FILE] [experiment=...]``.

A thin Hydra entry point (lightning-hydra-template's ``eval.py``): it composes
``configs/evaluate.yaml`` with your overrides, instantiates the evaluator named by
``eval._target_``, finds the checkpoints (those given, else the newest of each policy kind), and
calls ``evaluator.run(datamodule=..., checkpoints=..., out_dir=...)`` with plain objects in this
run's output directory, whose path it prints with a summary of the results.

The checkpoints remember how they were trained (:mod:`lfd.visuomotor.eval.provenance`): the
experiment is theirs unless ``experiment=`` is given, and the data settings are theirs unless the
command line sets ``seed``, ``data`` or a ``data.*`` key. So ``python train.py model=velocity``
then ``python evaluate.py`` scores that checkpoint with no override repeated.

Examples::

    python evaluate.py                                    # every policy kind, newest checkpoints
    python evaluate.py experiment=quick eval.split=val    # the validation objects
    python evaluate.py ckpt=[a/last.ckpt,b/last.ckpt]     # these two (kinds read from the files)
    python evaluate.py eval.scenario=configs/scenarios/mixed.yaml
    python evaluate.py eval=sawyer                        # the Sawyer models' protocol
"""

from lfd.cli.evaluate import *  # noqa: F403  (the entry point's functions, as the tests and notebooks import them)
from lfd.cli.evaluate import CONFIGS, cli, main  # noqa: F401

if __name__ == "__main__":
    cli()
