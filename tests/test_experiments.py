"""Every experiment config composes, instantiates and fits one batch (lightning-hydra-template's
``test_train_fast_dev_run``), shrunk to a tiny dataset and tiny networks by overrides."""

from __future__ import annotations

from pathlib import Path

import pytest

import train  # the repository's entry point (pytest's pythonpath holds the root)

EXPERIMENTS = sorted(
    p.stem for p in (Path(__file__).resolve().parents[1] / "configs" / "experiment").glob("*.yaml")
)
#: Overrides that shrink an experiment, per datamodule class (the experiment's data._target_);
#: the reaching experiments add the ``tiny_reaching`` fixture's.
SHRINK = {
    "lfd.visuomotor.data.ReachDataModule": ["data.name=tiny"],
    "lfd.model_reaching.data.SawyerModelsDataModule": [
        "data.forward.batch_size=64",
        "data.forward.n_val=200",
        "data.forward.n_test=200",
        "data.forward.eval_batch_size=200",
        "data.inverse.config.n_goals=4",
        "model.forward.width=16",
        "model.forward.n_blocks=1",
    ],
}


def test_every_experiment_is_covered():
    assert EXPERIMENTS, "no configs/experiment/*.yaml found"


@pytest.mark.parametrize("name", EXPERIMENTS)
def test_experiment_fast_dev_run(compose, tiny_reaching, tmp_path_factory, capsys, name):
    root = (
        tmp_path_factory.getbasetemp() / "experiments"
    )  # shared: the reaching experiments reuse one tiny dataset
    data = compose("train", f"experiment={name}").data
    target = data._target_
    assert target in SHRINK, f"experiment={name}: no shrinking overrides for data {target}"
    shrink = [*SHRINK[target], *(tiny_reaching if target == "lfd.visuomotor.data.ReachDataModule" else ())]
    if data.get("depth"):  # an RGB-D dataset cannot share the RGB one's folder
        shrink.append("data.name=tiny_rgbd")
    run = root / f"run-{name}"
    cfg = compose(
        "train",
        f"experiment={name}",
        f"paths.root_dir={root}",
        f"paths.output_dir={run}",
        "++trainer.fast_dev_run=true",
        *shrink,
    )
    train.main(cfg)  # instantiates datamodule, model, callbacks, loggers, trainer; fits one batch
    assert f"[lfd] run directory: {run}" in capsys.readouterr().out
