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
from pathlib import Path
from typing import Any

import numpy as np
import torch

from lfd.io.files import json_bytes, write_bytes_atomic
from lfd.robots import load_robot
from lfd.sim.camera import Camera
from lfd.sim.scene import ReachScene
from lfd.training import CHECKPOINT_GLOB, find_checkpoints
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

#: Checkpoint config key per policy kind (``python evaluate.py ckpt_dmp=... ckpt_velocity=...``).
CKPT_KEYS = {
    "cnn_dmp": "ckpt_dmp",
    "velocity": "ckpt_velocity",
    "act": "ckpt_act",
    "diffusion": "ckpt_diffusion",
}
#: Training command per policy kind, quoted when a checkpoint is missing.
TRAIN_COMMANDS = {kind: f"python train.py model={kind}" for kind in CKPT_KEYS}


class ReachEvaluator:
    """Closed-loop evaluation of the visuomotor policies (CNN -> DMP, velocity CNN, ACT, Diffusion
    Policy; an :class:`lfd.training.Evaluator`).

    Args:
        scenario: scenario YAML file (:mod:`lfd.visuomotor.eval.scenario`); None = the ``split`` of
            the ``data`` config's dataset.
        split: dataset split evaluated without a scenario: ``"test"`` (the report) or
            ``"val"`` (model selection and tuning: the val split's held-out validation
            objects at their placements; its training objects' other placements are left
            out, the overlap check refuses them as training objects).
        methods: policy kinds to evaluate (default: all four); :meth:`resolve_checkpoints` skips
            the kinds without a checkpoint with a one-line note, and raises when none has one.
        colour_tta: methods whose policies average their output over the 6 orders of the
            RGB channels (:attr:`lfd.visuomotor.policies.base.VisuomotorPolicy.colour_tta`; only for
            checkpoints trained with ``colour_augment``).
        chunk_execution: ``{kind: {"replan_every": ..., "ensemble_m": ...}}`` for chunking policies
            (ACT, Diffusion Policy): run their chunks otherwise than trained (an ablation; a key left
            out keeps the trained value; :meth:`~lfd.visuomotor.policies.chunking.ChunkPolicy.set_execution`).
        n_gifs: rollout GIFs per method (the first cases).
        gif_every: keep every this many control steps in a GIF.
        max_steps: control steps per episode; None = twice the demonstrations' length
            (``2 (n_steps - 1)``): the velocity policy, started at rest, is slower than the
            demonstrations, and the DMP policy holds its final point once its plan ends.
        approach_tol_deg: tolerance of ``approach_correct`` (degrees between the final tool
            x-axis and the approach rule's direction).
        limit: evaluate only the first ``limit`` cases (None: all).
        torch_threads: torch intra-op threads during the closed-loop runs (a batch of one
            gains nothing from more, and loses much to thread hand-offs on a busy CPU).
        episode_reports: writers of the episodes in other layouts, called in order after the
            outputs above (:class:`~lfd.visuomotor.protocols.EpisodeReport`;
            ``configs/eval/reach.yaml``: LeRobot's, :func:`lfd.interop.lerobot.report.write_lerobot_eval`).
    """

    #: :meth:`run` reads the policies' dataset (``evaluate.py`` instantiates ``cfg.data`` for it).
    needs_datamodule = True

    def __init__(
        self,
        scenario: str | None = None,
        methods: tuple[str, ...] | list[str] = tuple(POLICIES),
        n_gifs: int = 2,
        gif_every: int = 2,
        max_steps: int | None = None,
        approach_tol_deg: float = 30.0,
        limit: int | None = None,
        torch_threads: int = 1,
        split: str = "test",
        colour_tta: tuple[str, ...] | list[str] = (),
        chunk_execution: Mapping[str, Mapping[str, Any]] | None = None,
        episode_reports: Sequence[EpisodeReport] = (),
    ) -> None:
        if split not in ("test", "val"):
            raise ValueError(f"ReachEvaluator.split: expected 'test' or 'val', got {split!r}")
        unknown = sorted(set(methods) - set(POLICIES))
        if unknown:
            raise ValueError(
                f"ReachEvaluator.methods: unknown {unknown}; expected a subset of {sorted(POLICIES)}"
            )
        if max_steps is not None and max_steps < 1:
            raise ValueError(f"ReachEvaluator.max_steps: expected an int >= 1 or null, got {max_steps}")
        bad = sorted(set(colour_tta) - set(POLICIES))
        if bad:
            raise ValueError(
                f"ReachEvaluator.colour_tta: unknown methods {bad}; expected a subset of {sorted(POLICIES)}"
            )
        self.chunk_execution = {k: dict(v) for k, v in (chunk_execution or {}).items()}
        chunking = sorted(k for k, c in POLICIES.items() if hasattr(c, "set_execution"))  # act, diffusion
        for kind, settings in self.chunk_execution.items():
            if kind not in chunking or set(settings) - {"replan_every", "ensemble_m"}:
                raise ValueError(
                    f"ReachEvaluator.chunk_execution: expected {{kind: {{replan_every, ensemble_m}}}} with a chunking "
                    f"policy's kind {chunking}, got {kind!r}: {settings!r}"
                )
        if scenario is not None:  # fields, values, table and camera: before any checkpoint or data
            load_scenario(scenario)
        self.colour_tta = tuple(colour_tta)
        self.episode_reports = tuple(episode_reports)
        self.scenario = scenario
        self.methods = tuple(methods)
        self.n_gifs, self.gif_every = int(n_gifs), max(1, int(gif_every))
        self.max_steps = max_steps
        self.approach_tol_deg = float(approach_tol_deg)
        self.limit = limit
        self.torch_threads = int(torch_threads)
        self.split = split

    # ------------------------------------------------------------------ inputs
    def resolve_checkpoints(
        self, output_root: str | Path, given: Mapping[str, str | Path | None] | None = None
    ) -> dict[str, Path]:
        """Checkpoint per method: ``given[kind]`` when set (must exist; ``evaluate.py`` passes
        ``ckpt_dmp`` / ``ckpt_velocity``), else the newest found under ``output_root``.
        Missing ones are reported with the command that makes them; none at all raises."""
        given = {kind: (given or {}).get(kind) for kind in self.methods}
        for kind, path in given.items():
            if path is not None and not Path(path).is_file():
                raise FileNotFoundError(f"{CKPT_KEYS[kind]}={path}: no such checkpoint file")
        searched = [k for k, p in given.items() if p is None]
        found = find_checkpoints(output_root, tuple(searched)) if searched else {}
        out = {
            kind: Path(given[kind]) if given[kind] is not None else found.get(kind) for kind in self.methods
        }
        missing = [k for k, p in out.items() if p is None]
        hints = "; ".join(
            f"no '{k}' checkpoint under {Path(output_root) / CHECKPOINT_GLOB}: train one with "
            f"`{TRAIN_COMMANDS[k]}` or pass {CKPT_KEYS[k]}=PATH"
            for k in missing
        )
        if len(missing) == len(out):
            raise FileNotFoundError(hints)
        if missing:
            warnings.warn(hints, RuntimeWarning, stacklevel=2)
            print(f"[lfd] {hints}")
        return {k: p for k, p in out.items() if p is not None}

    def load_scenario(self, gen, robot, camera: Camera) -> Scenario | None:
        """This evaluator's scenario file fully checked for the data config ``gen``: fields,
        the ``camera`` image, the ``robot``'s reach, the training ranges (None: no scenario).

        Raises:
            lfd.visuomotor.eval.scenario.ScenarioError: a bad scenario file (one line).
        """
        if self.scenario is None:
            return None
        return load_scenario(self.scenario, camera=camera, robot=robot, training=gen)

    def cases(self, data, scene, scenario: Scenario | None = None) -> tuple[list[Case], str]:
        """The evaluation cases and a description of their source
        (:func:`~lfd.visuomotor.eval.cases.evaluation_cases` of this evaluator's settings;
        ``scenario``: this evaluator's scenario already loaded by :meth:`load_scenario`)."""
        return evaluation_cases(
            data, scene, scenario if scenario is not None else self.scenario, self.split, self.limit
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
        for kind in set(self.colour_tta) & set(policies):
            try:
                policies[kind].colour_tta = True
            except ValueError as e:
                raise ValueError(
                    f"eval.colour_tta: {kind} checkpoint {checkpoints[kind]}: {e}; evaluate it without: "
                    "eval.colour_tta=[]"
                ) from e
        for kind in set(self.chunk_execution) & set(policies):
            try:
                policies[kind].set_execution(**self.chunk_execution[kind])
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
        steps = self.max_steps or 2 * (gen.n_steps - 1)
        threads = torch.get_num_threads()
        torch.set_num_threads(self.torch_threads)
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
                    "colour_tta": kind in self.colour_tta,
                    "chunk_execution": policies[kind].execution if kind in self.chunk_execution else None,
                }
            )
        self._write(out_dir, metrics, rows, cases, traces)
        for report in self.episode_reports:  # e.g. LeRobot's layout: <method>/eval_info.json, videos/
            report(
                out_dir,
                rows,
                cases,
                traces,
                gen,
                seed=gen.seed,
                eval_s=time.perf_counter() - t0,
                n_videos=self.n_gifs,
                frame_every=self.gif_every,
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
            scene.reset(case.obj, case.placement, q=robot.home.numpy())
            trace = run_episode(
                scene, controller, steps, lower, upper, record_every=self.gif_every if i < self.n_gifs else 0
            )
            if trace.frames:
                (out_dir / "rollouts").mkdir(exist_ok=True)
                write_gif(
                    out_dir / "rollouts" / f"{kind}_{case.obj.name}_p{case.placement_index}.gif",
                    trace.frames,
                    dt * self.gif_every,
                )
            traces.append(trace)
        return traces

    @staticmethod
    def _warm_up(scene, case: Case, controller: Controller, steps: int) -> None:
        """One untimed policy call, so one-off costs (allocation, operator caches) stay out of the latencies."""
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
            "approach_angle_ok": angle <= self.approach_tol_deg,
            "approach_correct": near and angle <= self.approach_tol_deg,
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
