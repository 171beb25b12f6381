"""Closed-loop evaluation: controllers, metrics, plots, scenario files, the Sawyer protocol.

``python evaluate.py`` instantiates :class:`ReachEvaluator` from ``configs/eval/reach.yaml``
(or :class:`lfd.model_reaching.protocol.SawyerProtocol` with ``eval=sawyer``) and the datamodule, finds
the checkpoints (``resolve_checkpoints``) and calls
``run(datamodule=..., checkpoints=..., out_dir=...)``; see :mod:`lfd.visuomotor.eval.evaluator` for the
outputs, :mod:`lfd.visuomotor.eval.metrics` for the metric definitions and :mod:`lfd.visuomotor.eval.rollout` for
the closed loops (:func:`run_episode` steps a policy's controller, :func:`closed_loop_reach`).
"""

from lfd.visuomotor.eval.evaluator import ReachEvaluator, find_checkpoints
from lfd.visuomotor.eval.metrics import summarise, wilson_interval
from lfd.visuomotor.eval.rollout import ReachTrace, closed_loop_reach, run_episode
from lfd.visuomotor.eval.scenario import Scenario, ScenarioError, load_scenario

__all__ = [
    "ReachEvaluator",
    "ReachTrace",
    "Scenario",
    "ScenarioError",
    "closed_loop_reach",
    "find_checkpoints",
    "load_scenario",
    "run_episode",
    "summarise",
    "wilson_interval",
]
