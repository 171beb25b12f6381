"""Closed-loop evaluation: controllers, metrics, plots, scenario files, the Sawyer protocol.

``python evaluate.py`` instantiates :class:`ReachEvaluator` from ``configs/eval/reach.yaml``
(or :class:`lfd.model_reaching.protocol.SawyerProtocol` with ``eval=sawyer``) and the datamodule, finds
the checkpoints (``resolve_checkpoints``) and calls
``run(datamodule=..., checkpoints=..., out_dir=...)``; see :mod:`lfd.visuomotor.eval.evaluator` for the
outputs, :mod:`lfd.visuomotor.eval.metrics` for the metric definitions and :mod:`lfd.visuomotor.eval.rollout` for
the controllers (:func:`run_episode`, :func:`closed_loop_reach`).
"""

from lfd.visuomotor.eval.evaluator import ReachEvaluator, find_checkpoints
from lfd.visuomotor.eval.metrics import summarise, wilson_interval
from lfd.visuomotor.eval.rollout import (
    Observation,
    PlanController,
    ReachTrace,
    VelocityController,
    closed_loop_reach,
    run_episode,
)
from lfd.visuomotor.eval.scenario import Scenario, ScenarioError, load_scenario

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
