"""Closed-loop evaluation of the visuomotor policies: metrics, plots, scenario files.

``python evaluate.py`` instantiates :class:`ReachEvaluator` from ``configs/eval/reach.yaml``
and calls ``run(cfg, out_dir)``; see :mod:`lfd.eval.evaluator` for the outputs and
:mod:`lfd.eval.metrics` for the metric definitions.
"""

from lfd.eval.evaluator import ReachEvaluator, find_checkpoints
from lfd.eval.metrics import summarise, wilson_interval
from lfd.eval.rollout import Observation, PlanController, VelocityController, run_episode
from lfd.eval.scenario import Scenario, ScenarioError, load_scenario

__all__ = [
    "Observation",
    "PlanController",
    "ReachEvaluator",
    "Scenario",
    "ScenarioError",
    "VelocityController",
    "find_checkpoints",
    "load_scenario",
    "run_episode",
    "summarise",
    "wilson_interval",
]
