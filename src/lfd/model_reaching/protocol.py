"""Sawyer protocol (thesis ch. 5): forward + inverse models reach, a DMP learns the reach, PoWER refines it.

For each task (end-effector orientation: cube, cup) and each goal:

1. **Reach test** (:class:`lfd.robots.Workspace`): full-pose and position-only IK from several seeds,
   and the goal's distance from the shoulder (joint 1) against the arm's maximum reach.
   A goal without a position-only IK solution is not attempted: it is reported as
   unreachable when it also lies beyond the reach, as "no IK solution" otherwise.
2. **Models** (:func:`lfd.model_reaching.closed_loop.closed_loop_reach`): the forward model estimates the
   end-effector position from the measured joints, the task's inverse model turns the
   estimated error into joint velocities (clamped to the velocity limits), the arm
   integrates them (:class:`lfd.sim.arms.KinematicArm`, or PyBullet with the generated URDF,
   :class:`lfd.sim.arms.PyBulletArm`) until the *estimated* error is below ``threshold`` or
   ``max_steps`` is reached.
3. **DMP + PoWER** (:func:`lfd.rl.refine`): a DMP is fitted to the models' trajectory and PoWER
   (:func:`lfd.rl.power`, weights and goal explored, eq. 5.4 reward on the FK position)
   refines it until the end effector is within ``tol`` (1 cm) of the goal. The baseline
   fits the DMP to the task's demonstration only (the one the inverse model was trained
   on, stored in the checkpoint) and runs the same PoWER. Episodes = PoWER iterations.
4. Optionally the refined trajectories are replayed in PyBullet (position control,
   :func:`lfd.sim.tracking.replay_in_pybullet`) and their final distance to the goal measured there.

This module holds the protocol (:class:`SawyerProtocol`); its report (tables, CSV, plots) is
:mod:`lfd.model_reaching.report`.

Outputs in the run directory: ``protocol.md`` (tables), ``protocol.csv`` (one row per
task x goal x scenario x PoWER seed), ``reach.csv`` (closed-loop reaches),
``metrics.json``, ``paths_<task>.png`` (end-effector paths) and ``power_<task>.png``
(PoWER error curves).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import torch

from lfd.model_reaching.closed_loop import ReachTrace, closed_loop_reach
from lfd.model_reaching.data import SawyerFKDataModule
from lfd.model_reaching.demonstrations import SAWYER_START_DEG
from lfd.model_reaching.models import SawyerModels, load_sawyer_models
from lfd.model_reaching.report import ORIGINAL_EPISODES, SCENARIOS, protocol_tables, write_report
from lfd.rl import refine
from lfd.robots import Workspace, load_robot, rotation_log
from lfd.robots.spec import matrix_to_rpy
from lfd.sim.arms import ARMS
from lfd.sim.tracking import replay_in_pybullet
from lfd.training import find_checkpoints

__all__ = ["GOALS", "ORIGINAL_EPISODES", "SawyerProtocol"]

#: The five goals of the original protocol (m, Sawyer world frame).
GOALS = (
    (0.237, -0.466, -0.04),
    (-0.217, -0.474, -0.04),
    (1.110, -0.551, -0.04),
    (-0.179, -0.678, -0.04),
    (0.217, -0.680, -0.04),
)


def models_robot(models: SawyerModels):
    """The robot model the forward model was trained for."""
    return load_robot(models.forward_model.hparams.robot)


# ---------------------------------------------------------------------------- protocol
class SawyerProtocol:
    """The original evaluation protocol (``python evaluate.py eval=sawyer``; an :class:`lfd.training.Evaluator`).

    Args:
        checkpoint: :class:`~lfd.model_reaching.SawyerModels` checkpoint; None = the newest
            ``last.ckpt`` of that kind under ``<paths.output_root>/train/``
            (:meth:`resolve_checkpoints`).
        goals: goal positions (m).
        start_deg: start pose (deg).
        tasks: tasks to evaluate (None: every task in the checkpoint).
        simulator: ``"kinematic"`` or ``"pybullet"`` for the models' closed loop.
        dt, max_steps, threshold: closed-loop period (s), step cap and stopping threshold
            on the forward model's estimated error (m).
        n_basis: DMP basis functions per joint.
        power: :func:`lfd.rl.power` options (``n_rollouts``, ``n_best``, ``max_iter``,
            ``sigma``, ``sigma_goal``, ``tol``, ...) plus ``w1`` of the eq. 5.4 reward.
        n_seeds: PoWER runs per goal and scenario (seeds ``0..n_seeds-1``); tables show means.
        pybullet_replay: replay the refined trajectories (seed 0) in PyBullet.
        n_fk_test: size of the forward-model test set (drawn like the training run's, with
            seed ``fk_seed + 2``); 0 skips it.
        fk_seed: the training data seed (``configs/eval/sawyer.yaml``: the config's ``seed``).
    """

    #: The protocol draws its own goals and forward-model test set: ``evaluate.py`` passes no datamodule.
    needs_datamodule = False

    def __init__(
        self,
        checkpoint: str | None = None,
        goals: Sequence[Sequence[float]] = GOALS,
        start_deg: Sequence[float] = SAWYER_START_DEG,
        tasks: Sequence[str] | None = None,
        simulator: str = "kinematic",
        dt: float = 0.05,
        max_steps: int = 300,
        threshold: float = 0.02,
        n_basis: int = 20,
        power: Mapping[str, Any] | None = None,
        n_seeds: int = 5,
        pybullet_replay: bool = True,
        n_fk_test: int = 100_000,
        fk_seed: int = 0,
    ) -> None:
        if simulator not in ARMS:
            raise ValueError(f"SawyerProtocol.simulator: expected one of {sorted(ARMS)}, got {simulator!r}")
        if n_seeds < 1 or max_steps < 1 or not threshold > 0 or not dt > 0:
            raise ValueError("SawyerProtocol: need n_seeds >= 1, max_steps >= 1, threshold > 0 and dt > 0")
        self.checkpoint = checkpoint
        self.goals = np.asarray(goals, dtype=np.float64).reshape(-1, 3)
        self.start = np.radians(np.asarray(start_deg, dtype=np.float64))
        self.tasks = None if tasks is None else list(tasks)
        self.simulator, self.dt, self.max_steps, self.threshold = (
            simulator,
            float(dt),
            int(max_steps),
            float(threshold),
        )
        self.n_basis, self.n_seeds, self.pybullet_replay = int(n_basis), int(n_seeds), bool(pybullet_replay)
        self.power = {
            "n_rollouts": 10,
            "n_best": 5,
            "max_iter": 300,
            "sigma": 0.02,
            "sigma_goal": 0.05,
            "tol": 0.01,
            "w1": 0.9,
            **dict(power or {}),
        }
        self.n_fk_test, self.fk_seed = int(n_fk_test), int(fk_seed)

    def resolve_checkpoints(
        self, output_root: str | Path, given: Sequence[str | Path] | str | Path | None = None
    ) -> dict[str, Path]:
        """``{"sawyer_models": path}``: the configured checkpoint (``eval.checkpoint``), else the one
        ``given`` (``evaluate.py ckpt=PATH``), else the newest ``sawyer_models`` one under ``output_root``.

        Raises:
            ValueError: more than one checkpoint given.
            FileNotFoundError: the file does not exist, or none is found.
        """
        given = [given] if isinstance(given, (str, Path)) else list(given or [])
        if len(given) > 1:
            raise ValueError(f"ckpt: the Sawyer protocol runs one models checkpoint, got {len(given)}")
        path = self.checkpoint if self.checkpoint is not None else (given[0] if given else None)
        if path is not None:
            if not Path(path).is_file():
                raise FileNotFoundError(f"eval.checkpoint={path}: no such Sawyer models checkpoint")
            return {SawyerModels.kind: Path(path)}
        found = find_checkpoints(output_root, (SawyerModels.kind,)).get(SawyerModels.kind)
        if found is None:
            raise FileNotFoundError(
                f"no Sawyer models checkpoint under {output_root}/train; run `python train.py "
                "experiment=sawyer_models` "
                "first or pass eval.checkpoint=PATH"
            )
        return {SawyerModels.kind: found}

    def run(
        self, datamodule=None, checkpoints: Mapping[str, str | Path] | None = None, out_dir: str | Path = "."
    ) -> dict[str, Any]:
        """Run the protocol with the ``checkpoints["sawyer_models"]`` models and write the
        outputs to ``out_dir``; returns the metrics.

        ``datamodule`` is accepted (and ignored) so that ``evaluate.py`` calls every evaluator
        alike (:attr:`needs_datamodule` is False: it passes None); the protocol draws its own
        goals and forward-model test set (``n_fk_test``, ``fk_seed``).
        """
        if not checkpoints or SawyerModels.kind not in checkpoints:
            raise ValueError(
                f"SawyerProtocol.run: checkpoints must hold a '{SawyerModels.kind}' path, got {checkpoints!r}"
            )
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        ckpt = Path(checkpoints[SawyerModels.kind])
        models = load_sawyer_models(ckpt)
        metrics = self.evaluate(models, self.fk_seed)
        metrics["checkpoint"] = str(ckpt)
        write_report(out_dir, metrics, self.goals)
        print(metrics["tables"])
        return metrics

    # -- the experiment ----------------------------------------------------------------------
    def evaluate(self, models: SawyerModels, fk_seed: int = 0) -> dict[str, Any]:
        """Every task x goal x scenario; returns the metrics (tables included, no files)."""
        robot = models_robot(models)
        tasks = self.tasks or models.tasks
        unknown = sorted(set(tasks) - set(models.tasks))
        if unknown:
            raise ValueError(f"SawyerProtocol.tasks: {unknown} not in the checkpoint's tasks {models.tasks}")
        workspace = Workspace(robot)
        metrics: dict[str, Any] = {"settings": self.settings(), "tasks": {}}
        if self.n_fk_test:
            q, x = (
                SawyerFKDataModule(robot=robot.name, n_test=self.n_fk_test, seed=fk_seed)
                .fixed_set("test")
                .tensors
            )
            metrics["forward_error_mm"] = models.forward_error_summary(q, x)
        for task in tasks:
            metrics["tasks"][task] = self.evaluate_task(models, robot, workspace, task)
        metrics["totals"] = self.totals(metrics["tasks"])
        metrics["tables"] = protocol_tables(metrics, self.goals)
        return metrics

    def evaluate_task(self, models: SawyerModels, robot, workspace: Workspace, task: str) -> dict[str, Any]:
        demo = models.inverse_models[task].demo
        rotation = robot.fk(torch.from_numpy(demo.q[-1:]))[0, :3, :3].numpy()
        tests = [workspace.test(g, rotation) for g in self.goals]
        reachable = [i for i, test in enumerate(tests) if test.reachable]
        traces: dict[int, ReachTrace] = {}
        if reachable:
            arm = ARMS[self.simulator](robot, self.dt)
            inverse = models.inverse_models[task]
            reaches = closed_loop_reach(
                models.forward_model,
                inverse,
                robot,
                self.goals[reachable],
                self.start,
                arm,
                self.max_steps,
                self.threshold,
            )
            traces = dict(zip(reachable, reaches))
        goals_out = []
        for i, goal in enumerate(self.goals):
            entry: dict[str, Any] = {"goal": goal.tolist(), "reach_test": asdict(tests[i])}
            if i in traces:
                entry["reach"] = self.reach_metrics(robot, traces[i], goal, rotation)
                sources = {"models": (traces[i].t, traces[i].q), "demo": (demo.t, demo.q)}
                entry["power"] = {s: self.power_runs(robot, *sources[s], goal) for s in SCENARIOS}
            goals_out.append(entry)
        return {
            "demo_source": demo.source,
            "demo_final_rpy_deg": np.degrees(matrix_to_rpy(rotation)).round(3).tolist(),
            "goals": goals_out,
            "_traces": traces,
            "_demo_path": robot.fk_positions(demo.q).numpy(),
        }

    def reach_metrics(
        self, robot, trace: ReachTrace, goal: np.ndarray, rotation: np.ndarray
    ) -> dict[str, Any]:
        final = robot.fk(torch.from_numpy(trace.q[-1:]))[0, :3, :3]
        angle = float(rotation_log((torch.from_numpy(rotation) @ final.T)[None])[0].norm())
        return {
            "steps": len(trace.t) - 1,
            "reached": trace.reached,
            "final_error_m": trace.final_error(goal),
            "estimated_error_m": float(np.linalg.norm(trace.x_model[-1] - goal)),
            "orientation_error_deg": math.degrees(angle),
        }

    def power_runs(self, robot, t: np.ndarray, q: np.ndarray, goal: np.ndarray) -> dict[str, Any]:
        runs = [
            refine(robot, t, q, goal, self.n_basis, seed=seed, **self.power) for seed in range(self.n_seeds)
        ]
        out: dict[str, Any] = {
            "iterations": [r.iterations for r in runs],
            "rollouts": [r.rollouts for r in runs],
            "converged": [r.converged for r in runs],
            "final_error_m": [r.error for r in runs],
            "initial_error_m": float(runs[0].history.error[0]),
            "mean_iterations": float(np.mean([r.iterations for r in runs])),
            "_error_curve": runs[0].history.error,
            "_path": robot.fk_positions(runs[0].trajectory).numpy(),
        }
        if self.pybullet_replay:
            out["pybullet_final_error_m"] = float(
                np.linalg.norm(replay_in_pybullet(robot, runs[0].trajectory, float(t[1] - t[0])) - goal)
            )
        return out

    def settings(self) -> dict[str, Any]:
        return {
            "start_deg": np.degrees(self.start).round(6).tolist(),
            "simulator": self.simulator,
            "dt": self.dt,
            "max_steps": self.max_steps,
            "threshold_m": self.threshold,
            "n_basis": self.n_basis,
            "power": dict(self.power),
            "n_seeds": self.n_seeds,
        }

    @staticmethod
    def totals(tasks: Mapping[str, Any]) -> dict[str, dict[str, float]]:
        """Per task and scenario: summed mean episodes and converged runs over the reachable goals."""
        totals: dict[str, dict[str, float]] = {}
        for task, data in tasks.items():
            runs = [g["power"] for g in data["goals"] if "power" in g]
            totals[task] = {
                s: {
                    "episodes": float(sum(r[s]["mean_iterations"] for r in runs)),
                    "converged": int(sum(sum(r[s]["converged"]) for r in runs)),
                    "runs": int(sum(len(r[s]["converged"]) for r in runs)),
                }
                for s in SCENARIOS
            }
        return totals
