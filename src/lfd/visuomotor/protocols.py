"""The interfaces between the visuomotor policies, their data and their evaluator.

* :class:`Observation` and :class:`Controller`: the one inference interface. Every policy
  returns a controller (:meth:`lfd.visuomotor.policies.VisuomotorPolicy.controller`) that the
  closed-loop evaluator (:func:`lfd.visuomotor.eval.rollout.run_episode`) starts once per
  episode and steps every control period with an :class:`Observation`, whatever the policy's
  kind.
* :class:`EpisodeReport`: a writer of the evaluated episodes in another layout, which the
  evaluator calls after its own outputs (configured in ``configs/eval/reach.yaml``).
* :class:`PolicyData` and :class:`GeneratedPolicyData`: what a policy takes from its datamodule
  at ``setup("fit")`` (:class:`lfd.visuomotor.data.ReachDataModule` offers both,
  :class:`lfd.interop.lerobot.datamodule.LeRobotDataModule` the first).

The protocols are ``runtime_checkable``: ``isinstance`` checks that the members exist (not
their types).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np

__all__ = ["Controller", "EpisodeReport", "GeneratedPolicyData", "Observation", "PolicyData"]


@dataclass(frozen=True)
class Observation:
    """What a policy may see at one control step.

    Attributes:
        image: ``(H, W, 3)`` uint8 RGB frame of the fixed camera, or ``(H, W, 4)`` RGB-D
            (:func:`lfd.sim.depth.rgbd_image`) for a policy trained on depth (None at steps
            where the controller said it does not look, to save rendering).
        joints: ``(n,)`` float64 measured joint angles, rad.
        time: seconds since the episode started (control step x control period).
    """

    image: np.ndarray
    joints: np.ndarray
    time: float = 0.0


@runtime_checkable
class Controller(Protocol):
    """A policy in closed loop: started once per episode, asked for a command every step.

    Attributes:
        dt: control period, s (the observations' clock advances by it every step).
        actuation: how the command is executed: ``"position"`` (position target with the
            velocity as feed-forward) or ``"velocity"`` (the joints move at the velocity for
            one period).
        input_channels: image channels the policy takes: 3 (RGB) or 4 (RGB-D).
        depth_encoding: the RGB-D depth channel's encoding (:data:`lfd.sim.depth.DEPTH_ENCODINGS`).
        needs_image: whether :meth:`command` looks at the image this step (else the caller
            may pass ``image=None`` and skip rendering).
    """

    dt: float
    actuation: Literal["position", "velocity"]
    input_channels: int
    depth_encoding: str

    @property
    def needs_image(self) -> bool: ...

    def start(self, steps: int | None = None) -> None:
        """A new episode of ``steps`` control steps (None: the policy's default length)."""
        ...

    def command(self, obs: Observation, step: int, latencies: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """``(q_target, qd_target)``, both ``(n,)`` float64 (rad, rad/s), for control step ``step``
        (0-based); appends the wall time (ms) of each network call to ``latencies``."""
        ...


class EpisodeReport(Protocol):
    """Writes one evaluation's episodes into ``out_dir`` in some layout, e.g.
    :func:`lfd.interop.lerobot.report.write_lerobot_eval`.

    Args:
        out_dir: the evaluation's run directory.
        rows: one dict per episode and method (the rows of ``episodes.csv``).
        cases: the :class:`~lfd.visuomotor.eval.cases.Case` list, in episode order.
        traces: ``{method: [EpisodeTrace per case]}``.
        gen: the dataset's generator config (``control_dt``, ``image_size``, ...).
        seed: the dataset seed; eval_s: wall time of the evaluation so far, s.
        n_videos, frame_every: episodes to render per method, and every how many control steps.
    """

    def __call__(
        self,
        out_dir: Path,
        rows: list[dict[str, Any]],
        cases: list,
        traces: dict[str, list],
        gen: Any,
        *,
        seed: int | None,
        eval_s: float,
        n_videos: int,
        frame_every: int,
    ) -> Any: ...


#: Item layouts a policy trains on (its ``item_mode``): one item per demonstration (``"dmp"``) or
#: one per time step (``"velocity"``). The datamodules serve each of them.
ITEM_MODES = ("dmp", "velocity")


@runtime_checkable
class PolicyData(Protocol):
    """What every visuomotor policy takes from its datamodule at ``setup("fit")``.

    Attributes:
        mode: item layout served, ``"dmp"`` (one item per demonstration) or ``"velocity"``
            (one per time step); must equal the policy's ``item_mode``.
        datasets: ``{split: Dataset}`` after ``setup``; a velocity policy reads its output
            statistics from ``datasets["train"].tensors``.
        stats: normalisation statistics of the train split, ``{name: {"mean", "std"}}``
            (:func:`lfd.visuomotor.data.stats.compute_stats`).
        config: the data's rendering and timing settings (attributes ``image_size``,
            ``depth``, ``duration``, ``n_steps``, ``robot``), or None when unknown.
    """

    mode: str
    datasets: dict

    @property
    def stats(self) -> Mapping[str, Mapping[str, Any]]: ...

    @property
    def config(self) -> Any: ...


@runtime_checkable
class GeneratedPolicyData(PolicyData, Protocol):
    """:class:`PolicyData` of a dataset lfd generated, which also says what the policy sees of
    its depth and which items it holds.

    Attributes:
        input_depth: the items' images are RGB-D (else RGB, also of an RGB-D dataset).
        depth_encoding: the depth channel's encoding (:data:`lfd.sim.depth.DEPTH_ENCODINGS`).
    """

    input_depth: bool
    depth_encoding: str

    def fingerprint(self) -> dict:
        """The dataset's fingerprint (:mod:`lfd.visuomotor.data.fingerprint`), stored in checkpoints."""
        ...
