"""Closed-loop reaching evaluation of the visuomotor policies in PyBullet.

:class:`ReachEvaluator` (``configs/eval/reach.yaml``) runs every policy checkpoint it is
given (or finds) on a set of cases -- the dataset's test split (new objects at new
placements) or every object x placement of a scenario file -- and writes to its run
directory:

* ``metrics.json``: per method (``cnn_dmp``, ``velocity``) the summary of
  :func:`lfd.visuomotor.eval.metrics.summarise`, plus the checkpoint and the case source;
* ``episodes.csv``: one row per episode and method;
* ``distance_<object>.png``: final distance per placement, both methods side by side;
* ``paths3d_<object>.png``: demonstrated and executed end-effector paths;
* ``rollouts/<method>_<object>_p<k>.gif``: the first ``n_gifs`` episodes per method;
* ``<method>/eval_info.json`` and ``<method>/videos/eval_episode_<i>.mp4``: LeRobot's
  layout (:mod:`lfd.interop.lerobot.report`).
"""

from __future__ import annotations

import csv
import io
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch

from lfd.io.files import json_bytes, write_bytes_atomic
from lfd.robots import load_robot
from lfd.sim.camera import Camera, Lighting, jitter_camera, sample_lighting
from lfd.sim.clutter import MAX_CLUTTER, FlatItem, sample_clutter
from lfd.sim.scene import ReachScene
from lfd.sim.textures import TableTexture, sample_table_texture
from lfd.training import CHECKPOINT_GLOB, checkpoint_kind, find_checkpoints
from lfd.visuomotor.data.datasets import load_dataset
from lfd.visuomotor.data.fingerprint import training_overlap
from lfd.visuomotor.eval.cases import Case, evaluation_cases
from lfd.visuomotor.eval.metrics import (
    MAX_DISPLACEMENT_M,
    SUCCESS_RADIUS_M,
    approach_angle_deg,
    integrated_squared_jerk,
    summarise,
)
from lfd.visuomotor.eval.plots import distance_bars, paths_3d, write_gif
from lfd.visuomotor.eval.rollout import EpisodeTrace, observe, run_episode
from lfd.visuomotor.eval.scenario import Scenario, load_scenario
from lfd.visuomotor.policies import POLICIES, load_policy
from lfd.visuomotor.protocols import Controller, EpisodeReport, Observation

#: The evaluator's settings that are lists of policy kinds.
KIND_LISTS = ("kinds", "colour_tta")


def train_command(kind: str) -> str:
    """The command that trains a policy of ``kind``, quoted when its checkpoint is missing."""
    return f"python train.py model={kind}"


#: ``eval.lighting`` values (:class:`ReachEvalSettings`).
EVAL_LIGHTINGS = ("dataset", "fixed", "random")
#: Stream key of ``eval.lighting=random`` (apart from every dataset stream).
EVAL_LIGHTING_STREAM = 7
#: ``eval.camera_pose`` values (:class:`ReachEvalSettings`).
EVAL_CAMERA_POSES = ("dataset", "fixed", "jitter")
#: Stream key of ``eval.camera_pose=jitter`` (apart from every dataset stream).
EVAL_CAMERA_STREAM = 8
#: ``eval.table_texture`` values (:class:`ReachEvalSettings`).
EVAL_TABLE_TEXTURES = ("dataset", "plain", "random")
#: Stream key of ``eval.table_texture=random`` (apart from every dataset stream).
EVAL_TEXTURE_STREAM = 9
#: Stream key of ``eval.clutter=N`` (apart from every dataset stream).
EVAL_CLUTTER_STREAM = 10


@dataclass(frozen=True)
class ReachEvalSettings:
    """The closed-loop reaching evaluation's settings (``configs/eval/reach.yaml``), checked once
    when built: every bad value raises ``ValueError`` naming the field and the expectation.

    Args:
        scenario: scenario YAML file (:mod:`lfd.visuomotor.eval.scenario`); None = the ``split`` of
            the ``data`` config's dataset. Its fields, values, table and camera are checked here.
        split: dataset split evaluated without a scenario: ``"test"`` (the report) or
            ``"val"`` (model selection and tuning: the val split's held-out validation
            objects at their placements; its training objects' other placements are left
            out, the overlap check refuses them as training objects).
        kinds: policy kinds to evaluate (registered ones, :data:`lfd.visuomotor.policies.POLICIES`);
            None = every kind with a checkpoint. :meth:`ReachEvaluator.resolve_checkpoints` skips a
            listed kind without a checkpoint with a one-line note, and raises when none has one.
        colour_tta: kinds whose policies average their output over the 6 orders of the RGB
            channels (:attr:`lfd.visuomotor.policies.KeypointPolicy.colour_tta`; only for
            checkpoints trained with ``colour_augment``).
        chunk_execution: ``{kind: {"replan_every": ..., "ensemble_m": ...}}`` for chunking policies
            (ACT, Diffusion Policy): run their chunks otherwise than trained (an ablation; a key left
            out keeps the trained value; :meth:`~lfd.visuomotor.policies.chunking.ChunkPolicy.set_execution`).
        n_gifs: rollout GIFs per kind (the first cases).
        gif_every: keep every this many control steps in a GIF (at least 1).
        max_steps: control steps per episode; None = twice the demonstrations' length
            (``2 (n_steps - 1)``): the velocity policy, started at rest, is slower than the
            demonstrations, and the DMP policy holds its final point once its plan ends.
        approach_tol_deg: tolerance of ``approach_correct`` (degrees between the final tool
            x-axis and the approach rule's direction).
        limit: evaluate only the first ``limit`` cases (None: all).
        torch_threads: torch intra-op threads during the closed-loop runs (a batch of one
            gains nothing from more, and loses much to thread hand-offs on a busy CPU).
        lighting: the light of each episode: ``"dataset"`` (the default: a dataset case's
            recorded light, :attr:`~lfd.visuomotor.eval.cases.Case.lighting`; PyBullet's default
            light for scenario cases and datasets made with ``lighting: fixed``), ``"fixed"``
            (always the default light) or ``"random"`` (case ``i`` under
            :func:`lfd.sim.camera.sample_lighting` of ``default_rng([EVAL_LIGHTING_STREAM, i])``,
            the same for every kind: a robustness check under lights the training never saw).
        camera_pose: where the fixed camera stands in each episode: ``"dataset"`` (the default:
            a dataset case's recorded pose, :attr:`~lfd.visuomotor.eval.cases.Case.camera_pose`;
            the default pose for scenario cases and datasets made with ``camera_pose: fixed``),
            ``"fixed"`` (always the default pose) or ``"jitter"`` (case ``i``'s camera moved by
            :func:`lfd.sim.camera.jitter_camera` of ``default_rng([EVAL_CAMERA_STREAM, i])``, the same
            for every kind: a robustness check against a camera put back a little off).
        table_texture: the table top of each episode: ``"dataset"`` (the default: a dataset case's
            recorded table, :attr:`~lfd.visuomotor.eval.cases.Case.table_texture`; the plain table for
            scenario cases and datasets made with ``table_texture: plain``), ``"plain"`` (always the
            plain table) or ``"random"`` (case ``i``'s table drawn by
            :func:`lfd.sim.textures.sample_table_texture` of ``default_rng([EVAL_TEXTURE_STREAM, i])``,
            the same for every kind: a robustness check on tables the training never saw).
        clutter: the flat items around each episode's object: ``"dataset"`` (the default: a
            dataset case's recorded items, :attr:`~lfd.visuomotor.eval.cases.Case.clutter`; none
            for scenario cases and datasets made with ``clutter: 0``) or an integer ``N`` in
            ``[0, MAX_CLUTTER]`` (case ``i`` with up to ``N`` items of
            :func:`lfd.sim.clutter.sample_clutter` from ``default_rng([EVAL_CLUTTER_STREAM, i])``, the
            same for every kind: a robustness check on cluttered tables; 0 clears every table).
        episode_reports: writers of the episodes in other layouts, called in order after the
            outputs above (:class:`~lfd.visuomotor.protocols.EpisodeReport`;
            ``configs/eval/reach.yaml``: LeRobot's, :func:`lfd.interop.lerobot.report.write_lerobot_eval`).
    """

    scenario: str | None = None
    split: str = "test"
    kinds: tuple[str, ...] | None = None
    colour_tta: tuple[str, ...] = ()
    chunk_execution: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    n_gifs: int = 2
    gif_every: int = 2
    max_steps: int | None = None
    approach_tol_deg: float = 30.0
    limit: int | None = None
    torch_threads: int = 1
    lighting: str = "dataset"
    camera_pose: str = "dataset"
    table_texture: str = "dataset"
    clutter: str | int = "dataset"
    episode_reports: tuple[EpisodeReport, ...] = ()

    def __post_init__(self) -> None:
        def fix(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        if self.split not in ("test", "val"):
            raise ValueError(f"eval.split: expected 'test' or 'val', got {self.split!r}")
        for name, choices in (
            ("lighting", EVAL_LIGHTINGS),
            ("camera_pose", EVAL_CAMERA_POSES),
            ("table_texture", EVAL_TABLE_TEXTURES),
        ):
            if getattr(self, name) not in choices:
                raise ValueError(f"eval.{name}: expected one of {choices}, got {getattr(self, name)!r}")
        if self.clutter != "dataset" and (
            isinstance(self.clutter, bool)
            or not isinstance(self.clutter, int)
            or not 0 <= self.clutter <= MAX_CLUTTER
        ):
            raise ValueError(
                f"eval.clutter: expected 'dataset' or an int in [0, {MAX_CLUTTER}], got {self.clutter!r}"
            )
        for name in KIND_LISTS:
            value = getattr(self, name)
            if value is None and name == "kinds":
                continue
            if isinstance(value, str) or not all(isinstance(k, str) for k in value):
                raise ValueError(f"eval.{name}: expected a list of policy kinds, got {value!r}")
            unknown = sorted(set(value) - set(POLICIES))
            if unknown:
                raise ValueError(f"eval.{name}: unknown {unknown}; expected a subset of {sorted(POLICIES)}")
            fix(name, tuple(value))
        if self.kinds == ():
            raise ValueError("eval.kinds: expected a non-empty list of policy kinds, or null for every kind")
        for name in ("n_gifs", "torch_threads", "gif_every"):
            value = getattr(self, name)
            least = 0 if name == "n_gifs" else 1
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ValueError(f"eval.{name}: expected an int >= {least}, got {value!r}")
        for name in ("max_steps", "limit"):
            value = getattr(self, name)
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
                raise ValueError(f"eval.{name}: expected an int >= 1 or null, got {value!r}")
        if not (isinstance(self.approach_tol_deg, (int, float)) and 0 < self.approach_tol_deg <= 180):
            raise ValueError(
                f"eval.approach_tol_deg: expected degrees in (0, 180], got {self.approach_tol_deg!r}"
            )
        fix("approach_tol_deg", float(self.approach_tol_deg))
        execution = {k: dict(v) for k, v in (self.chunk_execution or {}).items()}
        chunking = sorted(k for k, c in POLICIES.items() if hasattr(c, "set_execution"))
        for kind, settings in execution.items():
            if kind not in chunking or set(settings) - {"replan_every", "ensemble_m"}:
                raise ValueError(
                    f"eval.chunk_execution: expected {{kind: {{replan_every, ensemble_m}}}} with a chunking "
                    f"policy's kind {chunking}, got {kind!r}: {settings!r}"
                )
        fix("chunk_execution", execution)
        fix("episode_reports", tuple(self.episode_reports))
        if self.scenario is not None:  # fields, values, table and camera: before any checkpoint or data
            load_scenario(self.scenario)


class ReachEvaluator:
    """Closed-loop evaluation of the visuomotor policies (CNN -> DMP, velocity CNN, ACT, Diffusion
    Policy, or any registered kind; an :class:`lfd.training.Evaluator`).

    Built from its settings (:class:`ReachEvalSettings`), or from their fields as keywords
    (``configs/eval/reach.yaml``: ``ReachEvaluator(scenario=..., split=..., ...)``).

    Raises:
        ValueError: a bad setting (one line naming it).
    """

    #: :meth:`run` reads the policies' dataset (``evaluate.py`` instantiates ``cfg.data`` for it).
    needs_datamodule = True

    def __init__(self, settings: ReachEvalSettings | None = None, **fields: Any) -> None:
        if settings is not None and fields:
            raise TypeError("ReachEvaluator: give its settings or their fields, not both")
        self.settings = settings if settings is not None else ReachEvalSettings(**fields)

    # ------------------------------------------------------------------ inputs
    def resolve_checkpoints(
        self, output_root: str | Path, given: Sequence[str | Path] | str | Path | None = None
    ) -> dict[str, Path]:
        """``{kind: path}`` of the checkpoints to evaluate, in the registry's order: the ``given``
        files (``evaluate.py ckpt=[...]``; each one's kind is read from it), and for the kinds
        without one (``kinds``; None = every registered kind) the newest ``last.ckpt`` under
        ``output_root``. A listed kind without a checkpoint is reported with the command that
        makes it.

        Raises:
            FileNotFoundError: a given file does not exist, or no checkpoint at all was found.
            ValueError: a given file is not a registered policy's, two are of one kind, or one
                is of a kind that ``kinds`` leaves out (one line naming the file).
        """
        if given is None:
            given = ()
        elif isinstance(given, (str, Path)):
            given = (given,)
        wanted = self.settings.kinds
        chosen: dict[str, Path] = {}
        for path in map(Path, given):
            if not path.is_file():
                raise FileNotFoundError(f"ckpt={path}: no such checkpoint file")
            kind = checkpoint_kind(path)
            if kind not in POLICIES:
                raise ValueError(
                    f"ckpt={path}: kind {kind!r} is not a policy; expected one of {sorted(POLICIES)}"
                )
            if kind in chosen:
                raise ValueError(
                    f"ckpt: two '{kind}' checkpoints ({chosen[kind]}, {path}); evaluate them apart"
                )
            if wanted is not None and kind not in wanted:
                raise ValueError(f"ckpt={path}: a '{kind}' checkpoint, but eval.kinds={list(wanted)}")
            chosen[kind] = path
        searched = tuple(k for k in (wanted or tuple(POLICIES)) if k not in chosen)
        if searched and (wanted is not None or not chosen):
            chosen.update(find_checkpoints(output_root, searched))
        missing = [k for k in (wanted or ()) if k not in chosen]
        hints = "; ".join(
            f"no '{k}' checkpoint under {Path(output_root) / CHECKPOINT_GLOB}: train one with "
            f"`{train_command(k)}` or pass ckpt=PATH"
            for k in (missing or (tuple(POLICIES) if not chosen else ()))
        )
        if not chosen:
            raise FileNotFoundError(hints)
        if missing:
            warnings.warn(hints, RuntimeWarning, stacklevel=2)
            print(f"[lfd] {hints}")
        return {k: chosen[k] for k in POLICIES if k in chosen}

    def check_inputs(self, datamodule) -> None:
        """Everything that can be checked before any checkpoint is opened: the scenario file
        against the ``datamodule``'s robot (reach), camera and training ranges.

        Raises:
            lfd.visuomotor.eval.scenario.ScenarioError: a bad scenario file (one line).
        """
        if self.settings.scenario is None:
            return
        gen = datamodule.config
        camera = Camera(width=gen.image_size, height=gen.image_size)
        self.load_scenario(gen, load_robot(gen.robot), camera)

    def load_scenario(self, gen, robot, camera: Camera) -> Scenario | None:
        """This evaluator's scenario file fully checked for the data config ``gen``: fields,
        the ``camera`` image, the ``robot``'s reach, the training ranges (None: no scenario).

        Raises:
            lfd.visuomotor.eval.scenario.ScenarioError: a bad scenario file (one line).
        """
        if self.settings.scenario is None:
            return None
        return load_scenario(self.settings.scenario, camera=camera, robot=robot, training=gen)

    def cases(self, data, scene, scenario: Scenario | None = None) -> tuple[list[Case], str]:
        """The evaluation cases and a description of their source
        (:func:`~lfd.visuomotor.eval.cases.evaluation_cases` of this evaluator's settings;
        ``scenario``: this evaluator's scenario already loaded by :meth:`load_scenario`)."""
        return evaluation_cases(
            data,
            scene,
            scenario if scenario is not None else self.settings.scenario,
            self.settings.split,
            self.settings.limit,
        )

    # ------------------------------------------------------------------ run
    def run(self, datamodule, checkpoints: Mapping[str, str | Path], out_dir: str | Path) -> dict[str, Any]:
        """Evaluate, write the outputs into ``out_dir`` and return the ``metrics.json`` content.

        Args:
            datamodule: the :class:`~lfd.visuomotor.data.ReachDataModule` the policies were trained on
                (its dataset gives the test split and the rendering and timing settings).
            checkpoints: ``{kind: path}`` of the policies to run (:meth:`resolve_checkpoints`).
            out_dir: run directory for the outputs (created).
        """
        unknown = sorted(set(checkpoints) - set(POLICIES))
        if unknown or not checkpoints:
            raise ValueError(
                f"ReachEvaluator.run: checkpoints must map some of {sorted(POLICIES)} to files, got "
                f"{sorted(checkpoints)}"
            )
        t0 = time.perf_counter()
        gen = datamodule.config
        robot = load_robot(gen.robot)
        camera = Camera(width=gen.image_size, height=gen.image_size)  # the scene's fixed camera
        scenario = self.load_scenario(gen, robot, camera)  # before any checkpoint or dataset file
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        checkpoints = {kind: Path(path) for kind, path in checkpoints.items()}
        policies = {kind: load_policy(path) for kind, path in checkpoints.items()}
        for kind in set(self.settings.colour_tta) & set(policies):
            try:
                policies[kind].colour_tta = True
            except ValueError as e:
                raise ValueError(
                    f"eval.colour_tta: {kind} checkpoint {checkpoints[kind]}: {e}; evaluate it without: "
                    "eval.colour_tta=[]"
                ) from e
        for kind in set(self.settings.chunk_execution) & set(policies):
            try:
                policies[kind].set_execution(**self.settings.chunk_execution[kind])
            except ValueError as e:
                raise ValueError(f"eval.chunk_execution.{kind}: {e}") from e
        for kind, policy in policies.items():
            try:
                # the dataset gives the cases, and each policy gets its own input rendered
                # (observe): RGB or RGB-D need not match the dataset, everything else must
                policy.check_data(gen, depth=bool(policy.hparams.get("depth", False)))
            except ValueError as e:
                raise ValueError(
                    f"{kind} checkpoint {checkpoints[kind]}: {e}; evaluate with the data config it was trained on"
                ) from e
        datamodule.prepare_data()
        data = load_dataset(datamodule.path, gen)
        steps = self.settings.max_steps or 2 * (gen.n_steps - 1)
        threads = torch.get_num_threads()
        torch.set_num_threads(self.settings.torch_threads)
        try:
            with ReachScene(
                robot,
                image_size=gen.image_size,
                control_dt=gen.control_dt,
                substeps=gen.substeps,
                camera=camera,
            ) as scene:
                cases, source = self.cases(data, scene, scenario)
                for kind, policy in policies.items():
                    labels = [
                        (f"{c.obj.name} at placement {c.placement_index}", c.obj, c.placement) for c in cases
                    ]
                    overlap = training_overlap(policy.dataset_fingerprint, labels)
                    if overlap:
                        shown = "; ".join(overlap[:5]) + (
                            f"; ... ({len(overlap)} in all)" if len(overlap) > 5 else ""
                        )
                        raise ValueError(
                            f"{kind} checkpoint {checkpoints[kind]} was trained on items of the evaluation "
                            f"cases ({source}): "
                            f"{shown}; evaluate on cases it never saw"
                        )
                traces = {
                    kind: self._episodes(kind, policy, cases, scene, steps, out_dir)
                    for kind, policy in policies.items()
                }
        finally:
            torch.set_num_threads(threads)
        rows = [
            self._row(kind, case, trace, gen.control_dt)
            for kind in traces
            for case, trace in zip(cases, traces[kind])
        ]
        metrics = {}
        for kind in traces:
            mine = [r for r in rows if r["method"] == kind]
            metrics[kind] = summarise(
                final_distance=np.array([r["final_distance_m"] for r in mine]),
                approach_ok=np.array([r["approach_angle_ok"] for r in mine]),
                jerk=np.array([r["jerk"] for r in mine]),
                demo_jerk=np.array([r["demo_jerk"] for r in mine]),
                limit_violations=np.array([r["joint_limit_violations"] for r in mine]),
                latency_ms=np.concatenate([t.latencies_ms for t in traces[kind]]),
                displacement=np.array([r["object_displacement_m"] for r in mine]),
                clusters=np.array(
                    [f"{r['object_index']}:{r['object']}" for r in mine]
                ),  # one per object (the val split has two groups)
                object_distance=np.array([r["object_distance_m"] for r in mine]),
                table_contact=np.array([r["arm_table_contact"] for r in mine]),
                object_contact=np.array([r["arm_object_contact"] for r in mine]),
            )
            ood = [r for r in mine if r["ood"]]
            if ood and len(ood) < len(mine):  # reported separately, never mixed into one number silently
                metrics[kind]["in_distribution"] = self._subset([r for r in mine if not r["ood"]])
                metrics[kind]["out_of_distribution"] = self._subset(ood)
            metrics[kind].update(
                {
                    "checkpoint": str(checkpoints[kind]),
                    "cases": source,
                    "steps_per_episode": steps,
                    "colour_tta": kind in self.settings.colour_tta,
                    "lighting": self.settings.lighting,
                    "camera_pose": self.settings.camera_pose,
                    "table_texture": self.settings.table_texture,
                    "clutter": self.settings.clutter,
                    "chunk_execution": policies[kind].execution
                    if kind in self.settings.chunk_execution
                    else None,
                }
            )
        self._write(out_dir, metrics, rows, cases, traces)
        for (
            report
        ) in self.settings.episode_reports:  # e.g. LeRobot's layout: <method>/eval_info.json, videos/
            report(
                out_dir,
                rows,
                cases,
                traces,
                gen,
                seed=gen.seed,
                eval_s=time.perf_counter() - t0,
                n_videos=self.settings.n_gifs,
                frame_every=self.settings.gif_every,
            )
        return metrics

    def _episodes(
        self, kind: str, policy, cases: list[Case], scene, steps: int, out_dir: Path
    ) -> list[EpisodeTrace]:
        """Closed-loop episodes of one policy on every case (GIFs of the first ``n_gifs``)."""
        robot, dt = scene.robot, scene.control_dt
        continuous = robot.continuous.numpy()
        lower = np.where(continuous, -np.inf, robot.lower.numpy())
        upper = np.where(continuous, np.inf, robot.upper.numpy())
        controller = policy.controller(dt)
        self._warm_up(scene, cases[0], controller, steps)
        traces = []
        for i, case in enumerate(cases):
            self._stage(scene, i, case)
            scene.reset(case.obj, case.placement, q=robot.home.numpy())
            trace = run_episode(
                scene,
                controller,
                steps,
                lower,
                upper,
                record_every=self.settings.gif_every if i < self.settings.n_gifs else 0,
            )
            if trace.frames:
                (out_dir / "rollouts").mkdir(exist_ok=True)
                write_gif(
                    out_dir / "rollouts" / f"{kind}_{case.obj.name}_p{case.placement_index}.gif",
                    trace.frames,
                    dt * self.settings.gif_every,
                )
            traces.append(trace)
        return traces

    def case_lighting(self, i: int, case: Case) -> Lighting | None:
        """The light of case ``i`` under ``eval.lighting`` (:class:`ReachEvalSettings`)."""
        if self.settings.lighting == "random":
            return sample_lighting(np.random.default_rng([EVAL_LIGHTING_STREAM, i]))
        return case.lighting if self.settings.lighting == "dataset" else None

    def case_camera(self, i: int, case: Case, camera: Camera) -> Camera:
        """The fixed camera of case ``i`` under ``eval.camera_pose`` (:class:`ReachEvalSettings`),
        ``camera`` being the scene's default."""
        if self.settings.camera_pose == "jitter":
            return jitter_camera(camera, np.random.default_rng([EVAL_CAMERA_STREAM, i]))
        if self.settings.camera_pose == "dataset" and case.camera_pose is not None:
            return camera.with_pose(case.camera_pose)
        return camera

    def case_table_texture(self, i: int, case: Case) -> TableTexture | None:
        """The table top of case ``i`` under ``eval.table_texture`` (:class:`ReachEvalSettings`)."""
        if self.settings.table_texture == "random":
            return sample_table_texture(np.random.default_rng([EVAL_TEXTURE_STREAM, i]))
        return case.table_texture if self.settings.table_texture == "dataset" else None

    def case_clutter(self, i: int, case: Case) -> tuple[FlatItem, ...]:
        """The flat items around case ``i``'s object under ``eval.clutter`` (:class:`ReachEvalSettings`)."""
        if self.settings.clutter == "dataset":
            return case.clutter
        rng = np.random.default_rng([EVAL_CLUTTER_STREAM, i])
        return sample_clutter(rng, self.settings.clutter, case.obj, case.placement)

    def _stage(self, scene, i: int, case: Case) -> None:
        """Light case ``i``, stand its camera and dress its table (before ``scene.reset``)."""
        scene.set_lighting(self.case_lighting(i, case))
        scene.set_table_texture(self.case_table_texture(i, case))
        scene.set_clutter(self.case_clutter(i, case))
        scene.set_camera(
            self.case_camera(i, case, Camera(width=scene.camera.width, height=scene.camera.height))
        )

    def _warm_up(self, scene, case: Case, controller: Controller, steps: int) -> None:
        """One untimed policy call, so one-off costs (allocation, operator caches) stay out of the latencies."""
        self._stage(scene, 0, case)
        scene.reset(case.obj, case.placement, q=scene.robot.home.numpy())
        controller.start(steps)
        controller.command(
            Observation(image=observe(scene, controller), joints=scene.joint_state()[0]), 0, []
        )

    @staticmethod
    def _subset(rows: list[dict[str, Any]]) -> dict[str, Any]:
        """Headline numbers of a subset of one method's episodes (in / out of distribution)."""
        d = np.array([r["final_distance_m"] for r in rows])
        return {
            "episodes": len(rows),
            "objects": sorted({r["object"] for r in rows}),
            "final_distance_m": {"mean": float(d.mean()), "median": float(np.median(d))},
            "success_5cm": float(np.mean([r["success_5cm"] for r in rows])),
            "approach_correct": float(np.mean([r["approach_correct"] for r in rows])),
        }

    def _row(self, kind: str, case: Case, trace: EpisodeTrace, dt: float) -> dict[str, Any]:
        """One ``episodes.csv`` row; the definitions are those of :mod:`lfd.visuomotor.eval.metrics`."""
        final = trace.ee_poses[-1]
        distance = float(np.linalg.norm(final[:3, 3] - case.plan.target_point))
        angle = float(approach_angle_deg(final[:3, 0], case.plan.approach_dir))
        p = case.placement
        centre = case.object_centre
        moved = float(trace.object_displacement)
        near = distance < SUCCESS_RADIUS_M
        still = moved < MAX_DISPLACEMENT_M
        return {
            "method": kind,
            "object": case.obj.name,
            "shape": case.obj.shape,
            "object_index": case.object_index,
            "placement_index": case.placement_index,
            "x": p.x,
            "y": p.y,
            "yaw_deg": math.degrees(p.yaw),
            "approach_mode": case.plan.mode,
            "ood": bool(case.ood),
            "ood_reason": case.ood,
            "final_distance_m": distance,
            "object_distance_m": float(np.linalg.norm(final[:3, 3] - centre)),
            "object_displacement_m": moved,
            "arm_table_contact": trace.table_contact_steps > 0,
            "arm_object_contact": trace.object_contact_steps > 0,
            "success_5cm": near and still,
            "success_2cm": distance < 0.02 and still,
            "approach_angle_deg": angle,
            "approach_angle_ok": angle <= self.settings.approach_tol_deg,
            "approach_correct": near and angle <= self.settings.approach_tol_deg,
            "jerk": float(integrated_squared_jerk(trace.ee_poses[:, :3, 3], dt)),
            "demo_jerk": float(integrated_squared_jerk(case.demo_ee, dt))
            if case.demo_ee is not None
            else math.nan,
            "joint_limit_violations": trace.limit_violations,
            "policy_calls": len(trace.latencies_ms),
            "latency_ms_median": float(np.median(trace.latencies_ms)),
        }

    @staticmethod
    def _write(
        out_dir: Path,
        metrics: dict,
        rows: list[dict],
        cases: list[Case],
        traces: dict[str, list[EpisodeTrace]],
    ) -> None:
        write_bytes_atomic(out_dir / "metrics.json", json_bytes(metrics))
        table = io.StringIO(newline="")
        writer = csv.DictWriter(table, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
        write_bytes_atomic(out_dir / "episodes.csv", table.getvalue().encode())
        by_object: dict[str, list[int]] = {}
        for i, case in enumerate(cases):
            by_object.setdefault(case.obj.name, []).append(i)
        for name, idx in by_object.items():
            distances = {
                kind: [r["final_distance_m"] for r in rows if r["method"] == kind and r["object"] == name]
                for kind in traces
            }
            distance_bars(out_dir / f"distance_{name}.png", name, [cases[i].label for i in idx], distances)
            paths_3d(
                out_dir / f"paths3d_{name}.png",
                name,
                np.stack([cases[i].plan.target_point for i in idx]),
                [cases[i].demo_ee for i in idx],
                {kind: [traces[kind][i].ee_poses[:, :3, 3] for i in idx] for kind in traces},
            )
