"""configs/grid/mt10.yaml: the Meta-World grid is one multirun over the MT10 tasks, every policy kind,
three demonstration counts and three seeds, each job reading one dataset per task."""

from lfd.metaworld import MT10


def test_grid_sweeps_mt10_kinds_counts_and_seeds(compose):
    cfg = compose("train", "experiment=metaworld", "+grid=mt10", "task=door-open-v3", "seed=2")
    params = cfg.hydra.sweeper.params
    assert tuple(params.task.split(",")) == MT10  # the same ten tasks as lfd.metaworld.MT10
    assert params.model == "glob(*,exclude=sawyer_models)"
    assert [int(n) for n in params["data.train_episodes"].split(",")] == [10, 50, 100]
    assert params.seed == "0,1,2"
    # one dataset per task whatever the training seed, scored right after training
    assert (
        cfg.data.name == "metaworld_door-open-v3_n100_s42_fovy25"
        and cfg.data.seed == 42
        and cfg.data.n_train == 100
    )
    assert (
        cfg.evaluate and cfg.eval._target_.endswith("MetaWorldEvaluator") and cfg.eval.task == "door-open-v3"
    )
