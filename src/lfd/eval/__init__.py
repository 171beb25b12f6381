"""Closed-loop evaluation: controllers, metrics, plots, scenario files, the Sawyer protocol.

``python evaluate.py`` instantiates :class:`ReachEvaluator` from ``configs/eval/reach.yaml``
(or :class:`lfd.eval.sawyer.SawyerProtocol` with ``eval=sawyer``) and the datamodule, finds
the checkpoints (``resolve_checkpoints``) and calls
``run(datamodule=..., checkpoints=..., out_dir=...)``; see :mod:`lfd.eval.evaluator` for the
outputs, :mod:`lfd.eval.metrics` for the metric definitions and :mod:`lfd.eval.rollout` for
the controllers (:func:`run_episode`, :func:`closed_loop_reach`).
"""

from lfd.eval.evaluator import ReachEvaluator, find_checkpoints
from lfd.eval.metrics import summarise, wilson_interval
from lfd.eval.rollout import Observation, PlanController, ReachTrace, VelocityController, closed_loop_reach, run_episode
from lfd.eval.scenario import Scenario, ScenarioError, load_scenario

__all__ = [
    "Observation",
    "PlanController",
    "ReachEvaluator",
    "ReachTrace",
    "Scenario",
    "ScenarioError",
    "VelocityController",
    "closed_loop_reach",
    "find_checkpoints",
    "load_scenario",
    "run_episode",
    "summarise",
    "wilson_interval",
]
