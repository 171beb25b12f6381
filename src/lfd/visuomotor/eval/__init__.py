"""Closed-loop evaluation of the visuomotor policies: cases, metrics, plots, scenario files.

``python evaluate.py`` instantiates :class:`ReachEvaluator` from ``configs/eval/reach.yaml``
(or :class:`lfd.model_reaching.protocol.SawyerProtocol` with ``eval=sawyer``) and the datamodule, finds
the checkpoints (``resolve_checkpoints``) and calls
``run(datamodule=..., checkpoints=..., out_dir=...)``; see :mod:`lfd.visuomotor.eval.evaluator` for the
outputs, :mod:`lfd.visuomotor.eval.metrics` for the metric definitions and :mod:`lfd.visuomotor.eval.rollout` for
the closed loop (:func:`run_episode` steps a policy's controller).
"""

from lfd.training import find_checkpoints
from lfd.visuomotor.eval.cases import Case, evaluation_cases
from lfd.visuomotor.eval.evaluator import ReachEvaluator
from lfd.visuomotor.eval.metrics import summarise, wilson_interval
from lfd.visuomotor.eval.rollout import run_episode
from lfd.visuomotor.eval.scenario import Scenario, ScenarioError, load_scenario

__all__ = [
    "Case",
    "ReachEvaluator",
    "Scenario",
    "ScenarioError",
    "evaluation_cases",
    "find_checkpoints",
    "load_scenario",
    "run_episode",
    "summarise",
    "wilson_interval",
]
