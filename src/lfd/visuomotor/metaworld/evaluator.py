"""Closed-loop evaluation of the visuomotor policies on a Meta-World task (``configs/eval/metaworld.yaml``).

:class:`MetaWorldEvaluator` (an :class:`lfd.training.Evaluator`) runs every policy checkpoint it is
given (or finds for its task) on ``n_episodes`` placements of the data config's task, drawn from the
``split``'s own stream (:func:`lfd.metaworld.env.placement_seed`), and writes to its run directory:

* ``metrics.json``: per policy kind the success rate with its Wilson 95 % interval, the successes,
  the mean time and median steps to success, the mean network latency, the checkpoint, the task,
  the split and the horizon;
* ``episodes.csv``: one row per kind and episode (reset seed, success, steps and time to success,
  mean latency, the placement vector);
* ``rollouts/<kind>_ep<i>.gif``: the first ``n_gifs`` episodes of each kind.

An episode ``i`` resets :class:`~lfd.metaworld.env.MetaWorldTask` with the reset seed
``placement_seed(data.seed, split, i)``, starts the policy's controller for ``horizon`` control
steps and sends it the 4-D state (hand x, y, z in metres, last gripper command) and, where the
controller looks at it, the camera image; its command becomes a position target
(``q_target`` for position actuation, ``state + qd dt`` for velocity actuation) that
:meth:`~lfd.metaworld.env.MetaWorldTask.step_to` executes. The episode counts as a success when the
task reports itself solved at any step within the horizon; it **stops at the first success** (the
remaining steps could not change the outcome), so ``steps_to_success`` is also the episode's length.

Episodes are seeded (the placement by its reset seed, torch's generator by the same seed before the
first policy call), so they give the same rows whether they run in this process (``workers=1``) or
spread over ``workers`` spawned processes, each of which loads the checkpoints and builds its own
task; only the measured latencies differ.
"""

from __future__ import annotations

import csv
import inspect
import io
import multiprocessing
import sys
import warnings
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

from lfd.checks import check_choice, check_int
from lfd.io.files import json_bytes, write_bytes_atomic
from lfd.metaworld.env import MetaWorldTask, check_task, placement_seed
from lfd.training import CHECKPOINT_GLOB, CheckpointError, read_checkpoint
from lfd.visuomotor.eval.metrics import wilson_interval
from lfd.visuomotor.eval.plots import write_gif
from lfd.visuomotor.policies import POLICIES, load_policy
from lfd.visuomotor.policies.base import TRAINING_RUN_KEY
from lfd.visuomotor.protocols import Observation

__all__ = ["EPISODE_COLUMNS", "N_JOINTS", "EpisodeResult", "MetaWorldEvalSettings", "MetaWorldEvaluator"]

#: State size every Meta-World policy takes and commands: hand x, y, z (m) and the gripper command.
N_JOINTS = 4
#: Columns of ``episodes.csv``, in order.
EPISODE_COLUMNS = (
    "kind",
    "episode",
    "reset_seed",
    "success",
    "steps_to_success",
    "time_to_success_s",
    "latency_ms",
    "placement",
)


def _kind_list(value: Any, name: str, *, optional: bool) -> tuple[str, ...] | None:
    """``value`` as a tuple of registered policy kinds (None passes when ``optional``)."""
    if value is None and optional:
        return None
    if value is None:
        value = ()
    if (
        isinstance(value, str)
        or not isinstance(value, Sequence)
        or not all(isinstance(k, str) for k in value)
    ):
        raise ValueError(
            f"{name} must be a list of policy kinds{' (or None)' if optional else ''}, got {value!r}"
        )
    unknown = sorted(set(value) - set(POLICIES))
    if unknown:
        raise ValueError(
            f"{name} must be a subset of {', '.join(POLICIES)}, got unknown {', '.join(unknown)}"
        )
    if optional and not value:
        raise ValueError(f"{name} must be a non-empty list of policy kinds, or None for every kind, got []")
    return tuple(value)


@dataclass(frozen=True)
class MetaWorldEvalSettings:
    """The Meta-World evaluation's settings (``configs/eval/metaworld.yaml``), checked once when
    built: a bad value raises a one-line ``ValueError`` naming the field (``eval.<field> must be ...``).

    Args:
        task: the Meta-World task whose checkpoints :meth:`MetaWorldEvaluator.resolve_checkpoints`
            takes (the YAML sets the data config's task); None = any task. :meth:`MetaWorldEvaluator.run`
            refuses a data config of another task.
        split: placements evaluated: ``"test"`` (the report) or ``"val"`` (model selection, tuning).
        n_episodes: episodes (placements ``0 .. n_episodes - 1`` of the split) per policy kind.
        horizon: control steps per episode (at most the task's ``max_path_length``, 500).
        workers: processes the episodes are spread over (1: this process; more: spawned ones).
        kinds: policy kinds to evaluate (:data:`lfd.visuomotor.policies.POLICIES`); None = every kind
            with a checkpoint.
        colour_tta: kinds whose policies average their output over the 6 orders of the RGB channels
            (checkpoints trained with ``colour_augment`` only).
        chunk_execution: ``{kind: {"replan_every": ..., "ensemble_m": ...}}`` for chunking policies
            (ACT, Diffusion Policy) run otherwise than trained (as ``configs/eval/reach.yaml``'s).
        n_gifs: rollout GIFs per kind (the first episodes).
        gif_every: keep every this many control steps in a GIF.
        torch_threads: torch intra-op threads in every process running episodes.
        dmp_replan_every: control steps between re-plans of the DMP-planning policies (those with
            ``item_mode == "dmp"``: CNN -> DMP), passed to their controller as ``replan_every``;
            None = plan once per episode, as trained.
        dmp_replan_weights: with ``dmp_replan_every``, each re-plan re-predicts the DMP's forcing
            weights as well as its goal (the controller's ``replan_weights``); False: the goal only.
    """

    task: str | None = None
    split: str = "test"
    n_episodes: int = 50
    horizon: int = 200
    workers: int = 1
    kinds: tuple[str, ...] | None = None
    colour_tta: tuple[str, ...] = ()
    chunk_execution: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    n_gifs: int = 2
    gif_every: int = 2
    torch_threads: int = 1
    dmp_replan_every: int | None = None
    dmp_replan_weights: bool = False

    def __post_init__(self) -> None:
        def fix(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        if self.task is not None:
            try:
                check_task(self.task)
            except ValueError as e:
                raise ValueError(f"eval.{e}") from None
        check_choice(self.split, "eval.split", ("test", "val"))
        for name, least in (
            ("n_episodes", 1),
            ("horizon", 1),
            ("workers", 1),
            ("n_gifs", 0),
            ("gif_every", 1),
            ("torch_threads", 1),
        ):
            fix(name, check_int(getattr(self, name), f"eval.{name}", minimum=least))
        fix(
            "dmp_replan_every",
            check_int(self.dmp_replan_every, "eval.dmp_replan_every", minimum=1, optional=True),
        )
        if not isinstance(self.dmp_replan_weights, bool):
            raise ValueError(
                f"eval.dmp_replan_weights must be true or false, got {self.dmp_replan_weights!r}"
            )
        if self.dmp_replan_weights and self.dmp_replan_every is None:
            raise ValueError("eval.dmp_replan_weights=true needs eval.dmp_replan_every (an int >= 1)")
        fix("kinds", _kind_list(self.kinds, "eval.kinds", optional=True))
        fix("colour_tta", _kind_list(self.colour_tta, "eval.colour_tta", optional=False))
        execution = self.chunk_execution or {}
        if not isinstance(execution, Mapping):
            raise ValueError(
                f"eval.chunk_execution must be a mapping {{kind: {{replan_every, ensemble_m}}}}, got {execution!r}"
            )
        chunking = [k for k, c in POLICIES.items() if hasattr(c, "set_execution")]
        checked = {}
        for kind, settings in execution.items():
            if (
                kind not in chunking
                or not isinstance(settings, Mapping)
                or set(settings) - {"replan_every", "ensemble_m"}
            ):
                raise ValueError(
                    f"eval.chunk_execution must map a chunking policy's kind ({', '.join(chunking)}) to "
                    f"{{replan_every, ensemble_m}}, got {kind!r}: {settings!r}"
                )
            checked[kind] = dict(settings)
        fix("chunk_execution", checked)


@dataclass
class EpisodeResult:
    """One closed-loop episode of one policy kind.

    Attributes:
        kind, episode, reset_seed: which policy, which episode of the split and its reset seed.
        success: the task reported itself solved within the horizon.
        steps_to_success: control steps until the first success (None: no success).
        time_to_success_s: ``steps_to_success * control_dt`` (None: no success).
        latencies_ms: wall time of each network call, ms.
        placement: the task's reset vector of this episode.
        frames: GIF frames (every ``gif_every`` steps and the last state), empty unless asked.
    """

    kind: str
    episode: int
    reset_seed: int
    success: bool
    steps_to_success: int | None
    time_to_success_s: float | None
    latencies_ms: list[float]
    placement: list[float]
    frames: list[np.ndarray] = field(default_factory=list)

    def row(self) -> dict[str, Any]:
        """Its ``episodes.csv`` row (:data:`EPISODE_COLUMNS`)."""
        latency = float(np.mean(self.latencies_ms)) if self.latencies_ms else None
        return {
            "kind": self.kind,
            "episode": self.episode,
            "reset_seed": self.reset_seed,
            "success": self.success,
            "steps_to_success": self.steps_to_success,
            "time_to_success_s": self.time_to_success_s,
            "latency_ms": latency,
            "placement": " ".join(repr(float(v)) for v in self.placement),
        }


@dataclass(frozen=True)
class _Spec:
    """Everything a process running episodes needs (picklable: sent to spawned workers)."""

    task: str
    image_size: int
    camera: str
    seed: int
    settings: MetaWorldEvalSettings
    loader: Callable[[Path], Any]
    fovy: float | None = None


@dataclass(frozen=True)
class _Job:
    kind: str
    checkpoint: str
    episode: int


class _EpisodeRunner:
    """Runs episodes in one process: its own :class:`MetaWorldTask`, each checkpoint loaded once."""

    def __init__(self, spec: _Spec) -> None:
        self.spec = spec
        self.task = MetaWorldTask(spec.task, image_size=spec.image_size, camera=spec.camera, fovy=spec.fovy)
        self.policies: dict[str, Any] = {}
        self.warm: set[str] = set()

    def close(self) -> None:
        self.task.close()

    def policy(self, kind: str, checkpoint: str) -> Any:
        """The policy of ``checkpoint``, loaded on first use with this evaluation's run-time settings."""
        if checkpoint not in self.policies:
            self.policies[checkpoint] = _prepare_policy(self.spec, kind, Path(checkpoint))
        return self.policies[checkpoint]

    def controller(self, policy: Any) -> Any:
        s = self.spec.settings
        return _make_controller(policy, self.task.control_dt, s.dmp_replan_every, s.dmp_replan_weights)

    def episode(self, job: _Job) -> EpisodeResult:
        """Episode ``job.episode`` of the split with ``job.kind``'s policy (module docstring)."""
        s, task = self.spec.settings, self.task
        policy = self.policy(job.kind, job.checkpoint)
        seed = placement_seed(self.spec.seed, s.split, job.episode)
        dt, horizon = task.control_dt, s.horizon
        state = task.reset(seed)
        if job.checkpoint not in self.warm:  # one untimed call: one-off costs stay out of the latencies
            warm_up = self.controller(policy)
            warm_up.start(horizon)
            warm_up.command(Observation(image=task.render(), joints=state.copy(), time=0.0), 0, [])
            self.warm.add(job.checkpoint)
        torch.manual_seed(seed)  # a sampling policy (Diffusion Policy) draws the same noise anywhere
        controller = self.controller(policy)
        controller.start(horizon)
        gif = job.episode < s.n_gifs
        latencies: list[float] = []
        frames: list[np.ndarray] = []
        steps = None
        for step in range(horizon):
            frame_due = gif and step % s.gif_every == 0
            image = task.render() if controller.needs_image or frame_due else None
            if frame_due:
                frames.append(image)
            obs = Observation(image=image, joints=state.copy(), time=step * dt)
            q_target, qd = controller.command(obs, step, latencies)
            if controller.actuation == "velocity":
                target = state + np.asarray(qd, dtype=np.float64) * dt
            else:
                target = np.asarray(q_target, dtype=np.float64)
            solved = task.step_to(target)
            state = task.state()
            if solved:
                steps = step + 1
                break
        if gif:
            frames.append(task.render())
        return EpisodeResult(
            kind=job.kind,
            episode=job.episode,
            reset_seed=seed,
            success=steps is not None,
            steps_to_success=steps,
            time_to_success_s=None if steps is None else steps * dt,
            latencies_ms=[float(v) for v in latencies],
            placement=[float(v) for v in task.placement],
            frames=frames,
        )


def _prepare_policy(spec: _Spec, kind: str, checkpoint: Path) -> Any:
    """The policy of ``checkpoint`` (``spec.loader``) with ``colour_tta`` / ``chunk_execution`` applied.

    Raises:
        ValueError: the policy refuses a run-time setting (one line naming the setting).
    """
    s = spec.settings
    policy = spec.loader(checkpoint)
    if kind in s.colour_tta:
        try:
            policy.colour_tta = True
        except ValueError as e:
            raise ValueError(
                f"eval.colour_tta: {kind} checkpoint {checkpoint}: {e}; evaluate it without: eval.colour_tta=[]"
            ) from e
    if kind in s.chunk_execution:
        try:
            policy.set_execution(**s.chunk_execution[kind])
        except ValueError as e:
            raise ValueError(f"eval.chunk_execution.{kind}: {e}") from e
    return policy


def _make_controller(policy: Any, dt: float, replan_every: int | None, replan_weights: bool = False) -> Any:
    """``policy.controller(dt)``; a DMP-planning policy (``item_mode == "dmp"``) gets
    ``replan_every`` when set (as the keyword of its ``controller``, else as its controller's
    attribute ``replan_every``), and ``replan_weights`` when true (keyword only).

    Raises:
        ValueError: ``replan_every`` is set and the policy's controller has no such setting, or
            ``replan_weights`` is true and its ``controller`` takes no such keyword.
    """
    if replan_every is None or getattr(policy, "item_mode", None) != "dmp":
        return policy.controller(dt)
    parameters = inspect.signature(policy.controller).parameters
    if replan_weights:
        if "replan_weights" not in parameters:
            raise ValueError(
                f"eval.dmp_replan_weights=true: the {getattr(policy, 'kind', type(policy).__name__)} "
                "policy's controller cannot re-plan its weights; set eval.dmp_replan_weights=false"
            )
        return policy.controller(dt, replan_every=replan_every, replan_weights=True)
    if "replan_every" in parameters:
        return policy.controller(dt, replan_every=replan_every)
    controller = policy.controller(dt)
    if not hasattr(controller, "replan_every"):
        raise ValueError(
            f"eval.dmp_replan_every={replan_every}: the {getattr(policy, 'kind', type(policy).__name__)} "
            f"policy's controller ({type(controller).__name__}) does not re-plan; set eval.dmp_replan_every=null"
        )
    controller.replan_every = replan_every
    return controller


# one runner per spawned worker process, built on its first episode
_WORKER: dict[str, Any] = {}


def _init_worker(spec: _Spec) -> None:
    torch.set_num_threads(spec.settings.torch_threads)
    _WORKER["spec"] = spec


def _worker_episode(job: _Job) -> EpisodeResult:
    runner = _WORKER.get("runner")
    if runner is None:
        runner = _WORKER["runner"] = _EpisodeRunner(_WORKER["spec"])
    return runner.episode(job)


def _recorded(path: Path) -> tuple[dict[str, Any], Any, bool]:
    """``(hyper_parameters, recorded task, whether a training run is recorded)`` of a checkpoint
    file, read without loading its tensors (:func:`lfd.training.read_checkpoint`)."""
    ckpt = read_checkpoint(path)
    hparams = dict(ckpt.get("hyper_parameters", {}))
    run = ckpt.get(TRAINING_RUN_KEY)
    if not isinstance(run, Mapping):
        return hparams, None, False
    data = run.get("data")
    return hparams, data.get("task") if isinstance(data, Mapping) else None, True


class MetaWorldEvaluator:
    """Closed-loop evaluation of the visuomotor policies on one Meta-World task (module docstring;
    an :class:`lfd.training.Evaluator`).

    Built from its settings (:class:`MetaWorldEvalSettings`) or from their fields as keywords
    (``configs/eval/metaworld.yaml``).

    Args:
        policy_loader: for tests: a picklable callable ``path -> policy`` used instead of
            :func:`lfd.visuomotor.policies.load_policy` (in every process).

    Raises:
        ValueError: a bad setting (one line naming it).
    """

    #: :meth:`run` reads the data config (task, seed, image size, camera) of ``evaluate.py``'s datamodule.
    needs_datamodule = True

    def __init__(
        self,
        settings: MetaWorldEvalSettings | None = None,
        *,
        policy_loader: Callable[[Path], Any] | None = None,
        **fields: Any,
    ) -> None:
        if settings is not None and fields:
            raise TypeError("MetaWorldEvaluator: give its settings or their fields, not both")
        self.settings = settings if settings is not None else MetaWorldEvalSettings(**fields)
        self.policy_loader = load_policy if policy_loader is None else policy_loader

    # ------------------------------------------------------------------ inputs
    def resolve_checkpoints(
        self, output_root: str | Path, given: Sequence[str | Path] | str | Path | None = None
    ) -> dict[str, Path]:
        """``{kind: path}`` of the checkpoints to evaluate, in the registry's order: the ``given``
        files (each one's kind read from it), and for the kinds without one (``kinds``; None = every
        registered kind, searched only when nothing is given) the newest ``last.ckpt`` under
        ``output_root`` whose recorded training run names this evaluator's ``task`` (any task when
        it is None). The files are read without loading their tensors.

        Raises:
            FileNotFoundError: a given file does not exist, or no checkpoint at all was found.
            ValueError: a given file is not a registered policy's, two are of one kind, one is of a
                kind ``kinds`` leaves out, or one was trained on another task (one line naming it).
        """
        if given is None:
            given = ()
        elif isinstance(given, (str, Path)):
            given = (given,)
        s = self.settings
        chosen: dict[str, Path] = {}
        for path in map(Path, given):
            if not path.is_file():
                raise FileNotFoundError(f"ckpt={path}: no such checkpoint file")
            hparams, task, recorded = _recorded(path)
            kind = hparams.get("kind")
            if kind not in POLICIES:
                raise ValueError(
                    f"ckpt={path}: kind {kind!r} is not a policy; expected one of {sorted(POLICIES)}"
                )
            if kind in chosen:
                raise ValueError(
                    f"ckpt: two '{kind}' checkpoints ({chosen[kind]}, {path}); evaluate them apart"
                )
            if s.kinds is not None and kind not in s.kinds:
                raise ValueError(f"ckpt={path}: a '{kind}' checkpoint, but eval.kinds={list(s.kinds)}")
            if recorded and s.task is not None and task != s.task:
                raise ValueError(f"ckpt={path}: trained on task {task!r}, but eval.task={s.task!r}")
            chosen[kind] = path
        searched = tuple(k for k in (s.kinds or tuple(POLICIES)) if k not in chosen)
        if searched and (s.kinds is not None or not chosen):
            chosen.update(self._search(output_root, searched))
        missing = [k for k in (s.kinds or ()) if k not in chosen]
        of_task = f" trained on {s.task}" if s.task is not None else ""
        hints = "; ".join(
            f"no '{k}' checkpoint{of_task} under {Path(output_root) / CHECKPOINT_GLOB}: train one with "
            f"`python train.py model={k}` (and the Meta-World data config) or pass ckpt=PATH"
            for k in (missing or (tuple(POLICIES) if not chosen else ()))
        )
        if not chosen:
            raise FileNotFoundError(hints)
        if missing:
            warnings.warn(hints, RuntimeWarning, stacklevel=2)
            print(f"[lfd] {hints}", file=sys.stderr)
        return {k: chosen[k] for k in POLICIES if k in chosen}

    def _search(self, output_root: str | Path, kinds: tuple[str, ...]) -> dict[str, Path]:
        """The newest ``last.ckpt`` of each of ``kinds`` under ``output_root`` of this evaluator's
        task (unreadable files skipped with a warning naming them)."""
        found: dict[str, Path] = {}
        candidates = sorted(
            Path(output_root).glob(CHECKPOINT_GLOB), key=lambda p: p.stat().st_mtime, reverse=True
        )
        for path in candidates:
            try:
                hparams, task, _ = _recorded(path)
            except (CheckpointError, OSError) as e:
                warnings.warn(f"skipped: {e}", RuntimeWarning, stacklevel=3)
                continue
            kind = hparams.get("kind")
            if (
                kind in kinds
                and kind not in found
                and (self.settings.task is None or task == self.settings.task)
            ):
                found[kind] = path
            if len(found) == len(kinds):
                break
        return found

    def _check_checkpoint(self, kind: str, path: Path, task: str) -> None:
        """Refuse (one line) a checkpoint of another kind, of another state size than Meta-World's,
        or trained on another task than ``task``; read without loading its tensors."""
        hparams, recorded_task, recorded = _recorded(path)
        if hparams.get("kind") != kind:
            raise ValueError(f"{kind} checkpoint {path}: it holds a {hparams.get('kind')!r} policy")
        n_joints = hparams.get("n_joints", 7)  # the policies' default when a checkpoint has none
        if n_joints != N_JOINTS:
            raise ValueError(
                f"{kind} checkpoint {path}: n_joints={n_joints!r}; a Meta-World policy's state has {N_JOINTS} "
                "entries (hand x, y, z and gripper)"
            )
        if recorded and recorded_task != task:
            raise ValueError(
                f"{kind} checkpoint {path} was trained on task {recorded_task!r}, the data config is of task "
                f"{task!r}; evaluate with data.task={recorded_task}"
            )

    # ------------------------------------------------------------------ run
    def run(self, datamodule, checkpoints: Mapping[str, str | Path], out_dir: str | Path) -> dict[str, Any]:
        """Evaluate, write the outputs into ``out_dir`` and return the ``metrics.json`` content.

        Args:
            datamodule: any object whose ``config`` has ``task``, ``seed``, ``image_size`` and
                ``camera`` (the Meta-World data config the policies were trained on); a policy with
                ``check_data`` is also checked against it (image size, timing, depth).
            checkpoints: ``{kind: path}`` of the policies to run (:meth:`resolve_checkpoints`).
            out_dir: run directory for the outputs (created).

        Raises:
            ValueError: no or unknown kinds, a checkpoint refused (:meth:`_check_checkpoint`), a
                run-time setting a policy refuses, a horizon past the task's ``max_path_length``.
        """
        s = self.settings
        unknown = sorted(set(checkpoints) - set(POLICIES))
        if unknown or not checkpoints:
            raise ValueError(
                f"MetaWorldEvaluator.run: checkpoints must map some of {sorted(POLICIES)} to files, got "
                f"{sorted(checkpoints)}"
            )
        cfg = datamodule.config
        task = check_task(cfg.task)
        if s.task is not None and s.task != task:
            raise ValueError(f"eval.task={s.task!r}, but the data config is of task {task!r}")
        ordered = {kind: Path(checkpoints[kind]) for kind in POLICIES if kind in checkpoints}
        for kind, path in ordered.items():
            self._check_checkpoint(kind, path, task)
        fovy = getattr(cfg, "camera_fovy", None)
        spec = _Spec(
            task, int(cfg.image_size), str(cfg.camera), int(cfg.seed), s, self.policy_loader, fovy=fovy
        )
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        threads = torch.get_num_threads()
        torch.set_num_threads(s.torch_threads)
        runner = _EpisodeRunner(spec)
        try:
            if s.horizon > runner.task.max_path_length:
                raise ValueError(
                    f"eval.horizon must be at most {task}'s max_path_length {runner.task.max_path_length}, "
                    f"got {s.horizon}"
                )
            for kind, path in ordered.items():  # every refusal before the first episode
                policy = runner.policy(kind, str(path))
                check = getattr(policy, "check_data", None)
                if check is not None:
                    try:
                        check(cfg, depth=False)
                    except ValueError as e:
                        raise ValueError(
                            f"{kind} checkpoint {path}: {e}; evaluate with the data config it was trained on"
                        ) from e
                runner.controller(policy)
            if s.workers == 1:
                results = {kind: self._run_here(runner, kind, path) for kind, path in ordered.items()}
            else:
                results = self._run_spread(spec, ordered)
        finally:
            runner.close()
            torch.set_num_threads(threads)
        dt = runner.task.control_dt
        metrics = {kind: self._summary(kind, ordered[kind], task, results[kind]) for kind in ordered}
        self._write(out_dir, metrics, results, dt)
        return metrics

    def _jobs(self, kind: str, path: Path) -> list[_Job]:
        return [_Job(kind, str(path), i) for i in range(self.settings.n_episodes)]

    def _progress(self, kind: str, task: str) -> tqdm:
        """A progress bar on stderr over one kind's episodes."""
        return tqdm(
            total=self.settings.n_episodes,
            desc=f"[lfd] {task} {kind}",
            unit="episode",
            file=sys.stderr,
            dynamic_ncols=True,
        )

    def _run_here(self, runner: _EpisodeRunner, kind: str, path: Path) -> list[EpisodeResult]:
        """One kind's episodes in this process, in order."""
        with self._progress(kind, runner.spec.task) as bar:
            results = []
            for job in self._jobs(kind, path):
                results.append(runner.episode(job))
                bar.update(1)
        return results

    def _run_spread(self, spec: _Spec, ordered: Mapping[str, Path]) -> dict[str, list[EpisodeResult]]:
        """The episodes of every kind spread over ``workers`` spawned processes, by episode index."""
        workers = min(self.settings.workers, self.settings.n_episodes)
        context = multiprocessing.get_context("spawn")
        results = {}
        with ProcessPoolExecutor(
            workers, mp_context=context, initializer=_init_worker, initargs=(spec,)
        ) as pool:
            try:
                for kind, path in ordered.items():
                    with self._progress(kind, spec.task) as bar:
                        futures = [pool.submit(_worker_episode, job) for job in self._jobs(kind, path)]
                        for future in as_completed(futures):
                            future.result()  # a worker's error stops the evaluation here
                            bar.update(1)
                    results[kind] = sorted((f.result() for f in futures), key=lambda r: r.episode)
            except BaseException:
                pool.shutdown(wait=False, cancel_futures=True)
                raise
        return results

    def _summary(self, kind: str, path: Path, task: str, results: list[EpisodeResult]) -> dict[str, Any]:
        """One kind's ``metrics.json`` entry."""
        s = self.settings
        n = len(results)
        wins = [r for r in results if r.success]
        low, high = wilson_interval(len(wins), n)
        latencies = [v for r in results for v in r.latencies_ms]
        return {
            "success_rate": len(wins) / n,
            "success_ci95": [low, high],
            "episodes": n,
            "successes": len(wins),
            "mean_time_to_success_s": float(np.mean([r.time_to_success_s for r in wins])) if wins else None,
            "median_steps_to_success": float(np.median([r.steps_to_success for r in wins])) if wins else None,
            "latency_ms": float(np.mean(latencies)) if latencies else None,
            "checkpoint": str(path),
            "task": task,
            "split": s.split,
            "horizon": s.horizon,
            "colour_tta": kind in s.colour_tta,
            "chunk_execution": s.chunk_execution.get(kind),
            "dmp_replan_every": s.dmp_replan_every if POLICIES[kind].item_mode == "dmp" else None,
        }

    def _write(
        self, out_dir: Path, metrics: dict[str, Any], results: Mapping[str, list[EpisodeResult]], dt: float
    ) -> None:
        write_bytes_atomic(out_dir / "metrics.json", json_bytes(metrics))
        table = io.StringIO(newline="")
        writer = csv.DictWriter(table, fieldnames=list(EPISODE_COLUMNS))
        writer.writeheader()
        for kind in metrics:
            writer.writerows(r.row() for r in results[kind])
        write_bytes_atomic(out_dir / "episodes.csv", table.getvalue().encode())
        for kind in metrics:
            for r in results[kind]:
                if r.frames:
                    (out_dir / "rollouts").mkdir(exist_ok=True)
                    write_gif(
                        out_dir / "rollouts" / f"{kind}_ep{r.episode}.gif",
                        r.frames,
                        dt * self.settings.gif_every,
                    )
