"""``lfd-evaluate`` / ``python evaluate.py``: evaluate trained models (the entry point; the
repository's ``evaluate.py`` documents the command and is a wrapper of this module).

Composes ``configs/evaluate.yaml`` with the command-line overrides, instantiates the evaluator named
by ``eval._target_``, finds the checkpoints (those given, else the newest of each policy kind),
follows the experiment and data settings they were trained with where the command line leaves them
open, runs the evaluator in this run's output directory and prints a table of the results.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import hydra
from hydra.errors import InstantiationException
from omegaconf import DictConfig, ListConfig, OmegaConf, open_dict

from lfd.cli import config_file, configs_dir, quiet, run_app, user_errors
from lfd.training import Evaluator

#: Command-line keys after which the data settings are the command line's, not the checkpoints'.
DATA_OVERRIDES = ("seed", "data")
#: The configs composed (the checkout's configs/, else the packaged copy: :func:`lfd.cli.configs_dir`).
CONFIGS = configs_dir()


def instantiate_evaluator(cfg: DictConfig) -> Evaluator:
    """``cfg.eval`` instantiated (nested ``_target_``s too, as plain containers); the
    evaluator checks its settings and files (e.g. the scenario file) as it is built.

    Raises:
        TypeError: ``eval._target_`` is not an :class:`lfd.training.Evaluator`.
        ValueError: the evaluator refused a setting or file (its own error, unwrapped from Hydra's).
    """
    scenario = cfg.eval.get("scenario")
    if isinstance(scenario, str) and scenario:  # configs/scenarios/... runs from any folder
        with open_dict(cfg):
            cfg.eval.scenario = str(config_file(scenario))
    try:
        evaluator = hydra.utils.instantiate(cfg.eval, _convert_="all")
    except InstantiationException as e:
        if isinstance(e.__cause__, ValueError):
            raise e.__cause__ from None
        raise
    if not isinstance(evaluator, Evaluator):
        raise TypeError(
            f"eval._target_={cfg.eval._target_}: {type(evaluator).__name__} is not an lfd.training.Evaluator"
        )
    return evaluator


def register_policy_configs() -> list[str]:
    """Import the class of every ``configs/model/<name>.yaml`` (and of model configs on
    ``hydra.searchpath``), so that each policy kind a model config names is registered
    (:data:`lfd.visuomotor.policies.POLICIES`); returns the model config names. The classes come
    from the configs (trusted, as ``train.py``'s), never from a checkpoint."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.hydra_config import HydraConfig

    if not GlobalHydra.instance().is_initialized():  # called outside an app (tests, notebooks)
        with initialize_config_dir(str(CONFIGS), version_base="1.3"):
            return register_policy_configs()
    names = set(GlobalHydra.instance().config_loader().get_group_options("model"))
    searchpath = list(HydraConfig.get().searchpath) if HydraConfig.initialized() else []
    for entry in searchpath:  # the group listing above does not see hydra.searchpath
        if entry.startswith("file://"):
            names |= {p.stem for p in Path(entry.removeprefix("file://"), "model").glob("*.yaml")}
    extra = [f"hydra.searchpath=[{','.join(searchpath)}]"] if searchpath else []
    for name in sorted(names):
        model = compose(config_name="evaluate", overrides=[*extra, f"+model={name}"]).model
        if model.get("_target_"):
            hydra.utils.get_class(model._target_)
    return sorted(names)


def _keys(overrides: Sequence[str]) -> set[str]:
    """The config keys a list of command-line overrides sets (``+a.b=1`` -> ``a.b``)."""
    return {o.lstrip("+~").split("=")[0] for o in overrides}


def _same_kind(composed: Any, recorded: Any) -> bool:
    """Whether a recorded data value may replace the composed one: the same kind of value (a bool
    for a bool, a number for a number, a string for a string, a list for a list), or anything plain
    where either is null."""
    if composed is None or recorded is None:
        return True
    if isinstance(composed, bool) or isinstance(recorded, bool):
        return isinstance(composed, bool) and isinstance(recorded, bool)
    kinds = ((int, float), str, (list, tuple, ListConfig))
    return any(isinstance(composed, k) and isinstance(recorded, k) for k in kinds)


def follow_training_run(
    cfg: DictConfig,
    run: dict[str, Any] | None,
    overrides: Sequence[str] | None,
    source: str = "the checkpoints",
) -> DictConfig:
    """``cfg`` with the checkpoints' training run filled in where the command line (``overrides``)
    left it open: the experiment and the data config (recomposing ``configs/evaluate.yaml`` with
    them), the seed, and the data settings (only keys the data config has, with values of the same
    kind; never a ``_target_``, never ``root``). ``overrides=None`` (a config composed by a caller)
    or ``run=None`` (checkpoints that recorded nothing) leave ``cfg`` as is.

    Raises:
        ValueError: a recorded config choice that is no config here, a recorded value of another
            kind than the config's, or a data config that still misses a value (one line each).
    """
    if run is None or overrides is None:
        return cfg
    from hydra import compose
    from hydra.core.global_hydra import GlobalHydra

    keys = _keys(overrides)
    takes_data = not any(k == top or k.startswith(f"{top}.") for k in keys for top in DATA_OVERRIDES)
    extra = []
    for group, choice, wanted in (
        ("experiment", run["experiment"], "experiment" not in keys),
        ("data", run["data_config"], takes_data),
    ):
        if choice is None or not wanted:
            continue
        options = GlobalHydra.instance().config_loader().get_group_options(group)
        if choice not in options:
            raise ValueError(
                f"{source} were trained with {group}={choice}, which is no config here (one of {options}); "
                f"pass {group}=..."
            )
        extra.append(f"{group}={choice}")
    if extra:
        cfg = compose(config_name="evaluate", overrides=[*overrides, *extra])
    if not takes_data:
        return cfg
    with open_dict(cfg):
        if run.get("seed") is not None:
            cfg.seed = run["seed"]
        for key, value in run["data"].items():
            if key not in cfg.data or key == "root":
                continue
            if not _same_kind(cfg.data[key], value):
                raise ValueError(
                    f"{source}: the recorded data.{key}={value!r} is not of the kind of the config's "
                    f"{cfg.data[key]!r}; pass data.{key}=..."
                )
            cfg.data[key] = value
    missing = sorted(OmegaConf.missing_keys(cfg.data))
    if missing:
        raise ValueError(
            f"data.{missing[0]}: not set; {source} were trained with data={run['data_config']}, which needs "
            "it on the command line"
        )
    return cfg


def evaluate(cfg: DictConfig, out_dir: str | Path, overrides: Sequence[str] | None = None) -> dict[str, Any]:
    """Instantiate ``cfg.eval`` (which checks its settings and scenario file first), resolve the
    checkpoints (``ckpt``, ``eval.checkpoint`` or the newest under ``paths.output_root``), follow
    their training run where ``overrides`` (the command line's) leave it open
    (:func:`follow_training_run`), instantiate ``cfg.data`` for evaluators that read a dataset,
    and run; returns the metrics.

    Raises:
        ValueError: a bad setting, checkpoint (:class:`lfd.training.CheckpointError`) or scenario
            file (:class:`lfd.visuomotor.eval.scenario.ScenarioError`); checkpoints of two datasets.
        FileNotFoundError: a missing file, or no checkpoint.
    """
    import lightning as L

    register_policy_configs()
    evaluator = instantiate_evaluator(cfg)
    datamodule = hydra.utils.instantiate(cfg.data) if evaluator.needs_datamodule else None
    check_inputs = getattr(evaluator, "check_inputs", None)
    if check_inputs is not None:  # e.g. a scenario out of reach: refused before any checkpoint is read
        check_inputs(datamodule)
    given = cfg.get("ckpt")
    given = [] if given is None else [given] if isinstance(given, str) else list(given)
    checkpoints = evaluator.resolve_checkpoints(cfg.paths.output_root, given)
    if evaluator.needs_datamodule:
        from lfd.training import checkpoint_kind
        from lfd.visuomotor.eval.provenance import shared_training_run

        named = {checkpoint_kind(p) for p in given}
        run, checkpoints, notes = shared_training_run(checkpoints, named)
        for note in notes:
            print(f"[lfd] {note}")
        followed = follow_training_run(cfg, run, overrides)
        if followed is not cfg:  # the checkpoints' experiment and data: the evaluator and data again
            cfg, evaluator = followed, instantiate_evaluator(followed)
            datamodule = hydra.utils.instantiate(cfg.data)
    L.seed_everything(cfg.seed, workers=True)
    return evaluator.run(datamodule=datamodule, checkpoints=checkpoints, out_dir=Path(out_dir))


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _percent(value: Any) -> str:
    return f"{100 * value:.0f} %" if _number(value) else "-"


def _table_row(kind: str, m: dict[str, Any]) -> dict[str, str] | None:
    """The main metrics of one policy kind as table cells (reaching or success-rate metrics), or
    None for an entry that is neither."""
    episodes = str(m["episodes"]) if _number(m.get("episodes")) else "-"
    if "final_distance_m" in m:
        d = m["final_distance_m"]
        mean = d.get("mean") if isinstance(d, dict) else d
        return {
            "policy": kind,
            "episodes": episodes,
            "final distance": f"{100 * mean:.2f} cm" if _number(mean) else "-",
            "success": _percent(m.get("success_5cm")),
            "correct approach": _percent(m.get("approach_correct")),
        }
    if "success_rate" not in m:
        return None
    rate, ci, n, wins = m["success_rate"], m.get("success_ci95"), m.get("episodes"), m.get("successes")
    if not _number(wins) and _number(n) and _number(rate):
        wins = round(rate * n)
    if isinstance(ci, (list, tuple)) and len(ci) == 2 and all(map(_number, ci)):
        interval = f"{100 * ci[0]:.0f}-{100 * ci[1]:.0f} %"
    else:
        interval = "-"
    time = m.get("mean_time_to_success_s")
    return {
        "policy": kind,
        "episodes": episodes,
        "success": f"{wins}/{n}" if _number(wins) and _number(n) else "-",
        "success rate": _percent(rate),
        "95 % CI": interval,
        "time to success": f"{time:.2f} s" if _number(time) else "-",
        "task": " ".join(str(m[k]) for k in ("task", "split") if m.get(k) is not None) or "-",
    }


def results_table(metrics: dict[str, Any]) -> list[str]:
    """The table ``lfd-evaluate`` ends with: one row per evaluated policy kind, in the order of
    ``metrics``, with its main metrics (reaching: episodes, mean final distance, success within
    5 cm, correct approach; success-rate tasks such as Meta-World's: successes, rate, its 95 %
    interval, mean time to success, task and split); a cell the metrics lack is ``-``, an entry
    that is neither kind of metrics is left out; no row, no table (``[]``). E.g.::

        policy   episodes  final distance  success  correct approach
        -------  --------  --------------  -------  ----------------
        cnn_dmp  24        1.78 cm         96 %     96 %
    """
    rows = [row for kind, m in metrics.items() if isinstance(m, dict) and (row := _table_row(kind, m))]
    if not rows:
        return []
    columns = list(dict.fromkeys(column for row in rows for column in row))
    width = {c: max(len(c), *(len(row.get(c, "-")) for row in rows)) for c in columns}

    def line(cells: dict[str, str]) -> str:
        return "  ".join(cells.get(c, "-").ljust(width[c]) for c in columns).rstrip()

    return [line({c: c for c in columns}), line({c: "-" * width[c] for c in columns}), *map(line, rows)]


@hydra.main(version_base="1.3", config_path=str(CONFIGS), config_name="evaluate")
def main(cfg: DictConfig) -> str:
    from hydra.core.hydra_config import HydraConfig

    out_dir = Path(cfg.paths.output_dir)
    with user_errors("evaluate"):  # a bad checkpoint, scenario file or setting: one line, exit status 2
        metrics = evaluate(cfg, out_dir, overrides=list(HydraConfig.get().overrides.task))
    print(f"[lfd] evaluation written to: {out_dir}")
    table = results_table(metrics)
    if table:
        print("\n".join(table))
    return str(out_dir)


USAGE = """
lfd-evaluate (python evaluate.py): evaluate policy checkpoints in closed loop (configs/evaluate.yaml)
  ckpt=PATH | ckpt=[PATH,...]      checkpoints (default: the newest of each kind under outputs/train/)
  eval.kinds=[cnn_dmp,velocity]    the policy kinds to score (default: every kind with a checkpoint)
  eval.split=test|val              the dataset split (without a scenario)
  eval.scenario=FILE               a scenario file, e.g. configs/scenarios/user_objects.yaml
  eval=reach|sawyer|metaworld      the evaluator   eval.limit=N: the first N cases   eval.n_gifs=3
  experiment=... data.*=...        override what the checkpoints were trained with (followed by default)
Outputs: outputs/evaluate/<date>_<time>/ (metrics.json, plots, GIFs) and a table of the results.
"""


def cli(argv: list[str] | None = None) -> None:
    """The ``lfd-evaluate`` command (``python evaluate.py``): ``--help`` prints :data:`USAGE`."""
    quiet()
    run_app(main, USAGE, argv)


if __name__ == "__main__":
    cli()
