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
    "lfd.visuomotor.metaworld.MetaWorldDataModule": [
        "data.n_train=2",
        "data.n_val=1",
        "data.image_size=32",
        "data.n_steps=80",
        "data.batch_size=2",
        "data.progress=false",
        "model.channels=[4,4,8]",
        "model.hidden=[16,16]",
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


@pytest.mark.parametrize("experiment", ["quick", "original"])
def test_experiment_specialises_each_policy(compose, experiment):
    """configs/experiment_model/<experiment>_<model>.yaml tunes the policies an experiment tunes further."""
    dmp = compose("train", f"experiment={experiment}", "model=cnn_dmp")
    vel = compose("train", f"experiment={experiment}", "model=velocity")
    assert (dmp.model.global_pool, dmp.model.aux_weight, dmp.model.mode_heads) == (True, 1.0, True)
    assert (vel.model.global_pool, vel.model.aux_weight, vel.model.mode_heads) == (False, 0.0, False)
    assert dmp.callbacks.model_checkpoint.monitor == "val/final_ee_err_m"
    assert vel.callbacks.model_checkpoint.monitor == "val/loss"
    if experiment == "quick":  # one RGB-D dataset: CNN -> DMP reads its relief depth, the velocity CNN RGB
        assert dmp.data.name == vel.data.name and dmp.data.depth and vel.data.depth
        assert (dmp.data.input_depth, dmp.data.depth_encoding) == (True, "relief")
        assert (vel.data.input_depth, vel.data.depth_encoding) == (False, "range")
    # a command-line override still wins over the specialization
    relief = compose("train", f"experiment={experiment}", "model=cnn_dmp", "data.depth_encoding=range")
    assert relief.data.depth_encoding == "range"


def test_evaluators_satisfy_the_entry_points_protocol(compose):
    """Every configs/eval/*.yaml names an lfd.training.Evaluator; experiment=quick switches on
    CNN -> DMP's colour averaging (configs/experiment/quick.yaml), nothing else does."""
    import evaluate
    from lfd.interop.lerobot.report import write_lerobot_eval
    from lfd.training import Evaluator

    for name in ("reach", "sawyer"):
        evaluator = evaluate.instantiate_evaluator(compose("evaluate", f"eval={name}"))
        assert isinstance(evaluator, Evaluator), name
    # the LeRobot episode report is wired in by the config (lfd.visuomotor does not import lfd.interop)
    (report,) = evaluate.instantiate_evaluator(compose("evaluate")).settings.episode_reports
    assert report.func is write_lerobot_eval
    assert list(compose("evaluate", "experiment=quick").eval.colour_tta) == ["cnn_dmp"]
    assert list(compose("evaluate", "experiment=original").eval.colour_tta) == []
    assert "global_pool" not in compose("evaluate", "experiment=original").model  # no policy options
