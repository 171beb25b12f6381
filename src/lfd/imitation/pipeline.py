"""The stages of turning a demonstration into a robot skill, callable one by one.

Like Pose2Sim's ``Pose2Sim.calibration()``, ``Pose2Sim.poseEstimation()``, ..., each stage
is a function of the configuration (``configs/imitate.yaml``, any object with attribute
access such as an OmegaConf ``DictConfig``) and of the previous stages' results. The source
(:mod:`lfd.imitation.sources`) decides the first stages:

1. a video: :func:`estimate_pose` (MediaPipe keypoints, ``keypoints.csv``/``.npz``), then
   :func:`analyse`; several calibrated videos (a list): :func:`lfd.imitation.multiview.estimate_multiview`
   (triangulated skeleton), then :func:`analyse_skeleton`; a skeleton file: :func:`analyse_skeleton`
   (arm angles and torques,
   ``arm.csv``/``.mot``/``.json``); then :func:`retarget` (WAM posture or 7-DoF wrist path + IK);
   a robot recording (teach export, bag, joint CSV) skips these:
   :func:`lfd.imitation.sources.load_robot_source`;
2. :func:`fit_dmp`: a DMP fitted to the joints and time-scaled so its rollout keeps the velocity
   limits (``dmp.json``, read by ``lfd.dmp.DMP.load``);
3. :func:`refine` (with ``refine.task``): policy search for a task (:mod:`lfd.imitation.refine`);
4. :func:`execute`: the DMP (or refined) rollout run in PyBullet (the one tracker,
   :func:`lfd.sim.tracking.track_resampled`) and, with ``goal``, rolled out towards the IK
   solution of that tool position and run as well;
5. outputs (:mod:`lfd.imitation.outputs`): ``robot_trajectory.csv``, ``robot_trajectory.bag``
   (``trajectory_msgs/JointTrajectory``), ``refinement.png``, ``summary.json``; for a video also
   ``side_by_side.mp4``/``.gif`` (:func:`write_outputs`).

:func:`run` chains them. Units: s, rad, m.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "ROBOTS",
    "DMPFit",
    "Execution",
    "analyse",
    "analyse_skeleton",
    "basis_count",
    "check_config",
    "estimate_pose",
    "execute",
    "fill_missing",
    "fit_dmp",
    "refine",
    "retarget",
    "run",
    "source_of",
]

#: Robots a person's arm is retargeted to.
ROBOTS = ("wam4", "sawyer", "pr2_right_arm")


def check_config(cfg: Any) -> None:
    """Raise ``ValueError`` (one line naming the field) for a robot not in :data:`ROBOTS`, a side not
    left/right, an unknown ``source_type``, a bad ``dmp.n_basis`` or bad ``refine`` options; before any
    file is read."""
    from .refine import METHODS
    from .sources import SOURCE_TYPES

    if cfg.robot not in ROBOTS:
        raise ValueError(f"robot must be one of {', '.join(ROBOTS)}, got {cfg.robot!r}")
    if cfg.side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {cfg.side!r}")
    kind = cfg.get("source_type")
    if kind is not None and kind not in SOURCE_TYPES:
        raise ValueError(
            f"source_type must be one of {', '.join(SOURCE_TYPES)} (or null: detected), got {kind!r}"
        )
    if cfg.get("dmp") is not None:
        basis_count(cfg.dmp, 1.0)
    refine = cfg.get("refine")
    if refine is not None and refine.get("task") is not None:
        from lfd.rl.skill import SKILL_TASKS

        if refine.task not in SKILL_TASKS:
            raise ValueError(
                f"refine.task must be one of {', '.join(SKILL_TASKS)} (or null), got {refine.task!r}"
            )
        if refine.method not in METHODS:
            raise ValueError(f"refine.method must be one of {', '.join(METHODS)}, got {refine.method!r}")
        target = refine.get("target")
        values = list(target) if target is not None and not isinstance(target, str) else []
        if len(values) != 3 or not all(isinstance(v, int | float) and np.isfinite(v) for v in values):
            raise ValueError(f"refine.target must be a tool position [x, y, z] in metres, got {target}")


def source_of(cfg: Any) -> str | list[str]:
    """The demonstration path: ``cfg.source``, or ``cfg.video`` (the older name for a video source); a
    list of paths (several calibrated videos) as a ``list[str]``."""
    from .sources import is_path_list

    source = cfg.get("source") or cfg.get("video")
    if source is None:
        raise ValueError("source: give the demonstration, e.g. source=person.mp4 or source=arm.bag")
    return [str(s) for s in source] if is_path_list(source) else str(source)


def pose_options(cfg: Any) -> dict:
    """Keyword arguments of :func:`lfd.human.video.estimate_keypoints` from ``cfg.pose`` (with a progress bar)."""
    return dict(
        width=cfg.pose.width,
        stride=int(cfg.pose.stride),
        max_frames=cfg.pose.max_frames,
        progress=True,
        model=str(cfg.pose.get("model", "full")),
        heavy_model=cfg.pose.get("heavy_model"),
    )


def estimate_pose(cfg: Any, out: Path):
    """Stage 1: :class:`lfd.human.video.VideoKeypoints` of ``cfg.video`` (``cfg.pose``:
    model, heavy_model, width, stride, max_frames), written to ``out/keypoints.csv`` and ``keypoints.npz``.

    Raises:
        FileNotFoundError, ValueError: from :func:`lfd.human.video.estimate_keypoints`
            (missing or undecodable video, ``pose.model`` not full/heavy, heavy model missing).
    """
    from lfd.human.video import estimate_keypoints

    kp = estimate_keypoints(Path(source_of(cfg)), **pose_options(cfg))
    kp.to_csv(out / "keypoints.csv")
    kp.save(out / "keypoints.npz")
    return kp


def analyse(cfg: Any, kp, out: Path):
    """Stage 2: :func:`lfd.human.analyze_arm` of the skeleton (visibility threshold
    ``cfg.pose.min_visibility``, front/back flips repaired with ``cfg.pose.repair_flips``),
    arm depth lifted with ``cfg.pose.lift_depth``, options ``cfg.analysis``; saved as
    ``out/arm.*`` (no plots)."""
    repair = bool(cfg.pose.get("repair_flips", True))
    lift = bool(cfg.pose.get("lift_depth", True))
    return analyse_skeleton(cfg, kp.to_skeleton(float(cfg.pose.min_visibility), repair, lift), out)


def analyse_skeleton(cfg: Any, path, out: Path):
    """Stage 2 for a skeleton file: :func:`lfd.human.read_skeleton` (``cfg.units``; the plausibility checks of
    :mod:`lfd.human.plausibility`), or a :class:`lfd.human.Skeleton` given as ``path`` (the multiview
    source), then :func:`lfd.human.analyze_arm` with ``cfg.analysis``; saved as ``out/arm.*`` (no plots)."""
    from lfd.human import Skeleton, analyze_arm, read_skeleton

    a = cfg.analysis
    skeleton = path if isinstance(path, Skeleton) else read_skeleton(path, units=cfg.get("units"))
    analysis = analyze_arm(
        skeleton,
        side=cfg.side,
        body_mass=float(a.body_mass),
        sex=a.sex,
        filter=a.filter,
        cutoff=float(a.cutoff),
        max_gap=float(a.max_gap),
    )
    analysis.save(out, stem="arm", plots=False)
    return analysis


def fill_missing(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate NaN rows of ``x (T, ...)`` over times ``t (T,)``; leading/trailing missing
    rows are dropped. Returns the kept times and rows.

    Raises:
        ValueError: fewer than 4 complete rows.
    """
    flat = x.reshape(len(t), -1)
    ok = np.isfinite(flat).all(1)
    if ok.sum() < 4:
        raise ValueError(f"the arm was seen in only {int(ok.sum())} frames; need at least 4")
    first, last = np.argmax(ok), len(ok) - np.argmax(ok[::-1])
    t, flat, ok = t[first:last], flat[first:last], ok[first:last]
    filled = np.stack([np.interp(t, t[ok], col[ok]) for col in flat.T], 1)
    return t, filled.reshape((len(t),) + x.shape[1:])


def retarget(cfg: Any, analysis):
    """Stage 3: times ``t (T,)`` s and the :mod:`lfd.human.retarget` result (``q (T, n)``,
    ``base_rotation``, ``clamped``, ``error``) of the analysis' trunk-frame shoulder, elbow
    and wrist positions, missing frames filled (:func:`fill_missing`)."""
    from lfd.human.retarget import retarget_wam4, retarget_wrist_path

    t, positions = fill_missing(analysis.t, analysis.positions)
    s, e, w = positions[:, 0], positions[:, 1], positions[:, 2]
    if cfg.robot == "wam4":
        return t, retarget_wam4(s, e, w, side=cfg.side, mount=str(cfg.get("wam_mount", "auto")), t=t)
    return t, retarget_wrist_path(s, e, w, robot=cfg.robot)


def basis_count(dmp_cfg: Any, duration: float) -> int:
    """The DMP's basis functions for a demonstration of ``duration`` s: ``dmp_cfg.n_basis`` when it is an
    integer; ``"auto"``: ``max(min_basis, ceil(basis_per_second * duration))`` (long recordings of several
    repetitions get more, short clips keep ``min_basis``).

    Raises:
        ValueError: ``n_basis`` neither a positive integer nor ``"auto"``, or ``basis_per_second``/``min_basis``
            not positive.
    """
    n = dmp_cfg.n_basis
    if isinstance(n, str) and n == "auto":
        rate, least = dmp_cfg.get("basis_per_second", 10.0), dmp_cfg.get("min_basis", 30)
        if not (isinstance(rate, int | float) and rate > 0 and isinstance(least, int) and least > 0):
            raise ValueError(
                f"dmp.basis_per_second must be > 0 and dmp.min_basis a positive integer, got {rate!r}, {least!r}"
            )
        return max(int(least), int(np.ceil(float(rate) * max(duration, 0.0))))
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"dmp.n_basis must be a positive integer or 'auto', got {n!r}")
    return int(n)


@dataclass(frozen=True)
class DMPFit:
    """Stage 4's result: the ``dmp`` fitted on robot time ``t_robot (T,)`` s, its rollout
    ``q_dmp (T, n)`` rad clipped into the limits, the time-scale ``factor`` of the DMP rollout
    and ``factor_retargeted`` (the one the raw retargeted samples would need)."""

    dmp: Any
    t_robot: np.ndarray
    q_dmp: np.ndarray
    factor: float
    factor_retargeted: float


def fit_dmp(cfg: Any, robot, t: np.ndarray, q: np.ndarray, out: Path) -> DMPFit:
    """Stage 4: fit a DMP (:func:`basis_count` of ``cfg.dmp``) to ``q (T, n)`` at ``t (T,)``, stretched in time
    so its rollout keeps ``robot``'s velocity limits; saved as ``out/dmp.json``.

    The robot executes the DMP, so its rollout (not the frame-to-frame retargeted samples,
    whose single-frame pose glitches the DMP smooths away) must respect the limits; a DMP is
    invariant to a uniform time stretch, so the factor found in video time holds after it.
    """
    from lfd.dmp import DMP
    from lfd.human.retarget import time_scale

    lo, hi, vmax = robot.lower.numpy(), robot.upper.numpy(), robot.velocity_limits.numpy()
    n_basis = basis_count(cfg.dmp, float(t[-1] - t[0]))
    _, factor_retargeted = time_scale(t, q, vmax)
    q_video = np.clip(np.asarray(DMP(n_basis=n_basis).fit(t, q).rollout(t)), lo, hi)
    t_robot, factor = time_scale(t, q_video, vmax)
    dmp = DMP(n_basis=n_basis).fit(t_robot, q)
    dmp.save(out / "dmp.json")
    q_dmp = np.clip(np.asarray(dmp.rollout(t_robot)), lo, hi)
    return DMPFit(dmp, t_robot, q_dmp, factor, factor_retargeted)


@dataclass(frozen=True)
class Execution:
    """Stage 5's result: executed joints ``q_exec (T, n)`` rad at the DMP's times, the robot
    renders (one per sample when frames were asked for) and the goal result (None without
    a goal): ``goal_m``, ``ik_success``, ``final_tool_error_m``."""

    q_exec: np.ndarray
    images: list
    goal: dict | None


def execute(
    cfg: Any,
    robot,
    base_rotation: np.ndarray,
    fit: DMPFit,
    q_start: np.ndarray,
    q_plan: np.ndarray | None = None,
    render: bool | None = None,
) -> Execution:
    """Stage 5: run ``q_plan (T, n)`` (default ``fit.q_dmp``) at ``fit.t_robot`` on the arm alone in
    PyBullet (``cfg.sim``: physics ``rate`` Hz, position/velocity gains, ``image_size``; base 1 m up,
    oriented by ``base_rotation``: the simulation's world frame is the person's trunk frame; identity
    for robot sources). Robot renders are taken only when ``render`` (default: ``cfg.outputs`` asks
    for a video or GIF). With ``cfg.goal`` (tool
    position, m, robot base frame) the DMP is also rolled out towards the IK solution
    (position only, started at ``q_start``) and run in the same world.

    Raises:
        ValueError: a goal that is not three finite numbers.
    """
    import torch

    from lfd.robots.ik import solve_ik
    from lfd.sim.tracking import ArmWorld, track_resampled

    rate = float(cfg.sim.rate)
    t_robot = fit.t_robot
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    with ArmWorld(
        robot,
        timestep=1.0 / rate,
        base_position=(0.0, 0.0, 1.0),
        base_rotation=base_rotation,
        position_gain=float(cfg.sim.position_gain),
        velocity_gain=float(cfg.sim.velocity_gain),
        image_size=tuple(cfg.sim.image_size),
    ) as world:
        want = cfg.outputs.video or cfg.outputs.gif
        q_plan = fit.q_dmp if q_plan is None else q_plan
        want = want if render is None else render
        q_exec, images = track_resampled(world, t_robot, q_plan, rate, t_robot if want else None)
        goal_result = None
        if cfg.goal is not None:
            goal = np.asarray(list(cfg.goal), float)
            if goal.shape != (3,) or not np.isfinite(goal).all():
                raise ValueError(f"goal must be a tool position [x, y, z] in metres, got {list(cfg.goal)}")
            sol = solve_ik(
                robot, torch.from_numpy(goal[None]), torch.from_numpy(q_start[None]), position_only=True
            )
            q_new = np.clip(np.asarray(fit.dmp.rollout(t_robot, goal=sol.q[0].numpy())), lo, hi)
            q_new_exec, _ = track_resampled(world, t_robot, q_new, rate)
            reached = robot.fk(torch.from_numpy(q_new_exec[-1:]))[0, :3, 3].numpy()
            goal_result = {
                "goal_m": goal.tolist(),
                "ik_success": bool(sol.success[0]),
                "final_tool_error_m": float(np.linalg.norm(reached - goal)),
            }
    return Execution(q_exec, images, goal_result)


def refine(cfg: Any, robot, fit: DMPFit):
    """Stage 4b (with ``cfg.refine.task``): :func:`lfd.imitation.refine.refine_skill` of ``fit.dmp`` and its
    rollout on ``fit.t_robot``; returns ``(refinement, q_plan (T, n))`` or ``(None, fit.q_dmp)``."""
    from .refine import refine_skill

    r = cfg.get("refine")
    if r is None or r.get("task") is None:
        return None, fit.q_dmp
    result = refine_skill(
        robot,
        fit.dmp,
        task=str(r.task),
        target=[float(v) for v in r.target],
        method=str(r.method),
        tol=float(r.tol),
        max_rollouts=int(r.max_rollouts),
        shape_weight=float(r.shape_weight),
        t_via=None if r.get("t_via") is None else float(r.t_via) * fit.factor,
        radius=float(r.radius),
        goal_init=str(r.get("goal_init", "demo")),
        seed=int(r.seed),
        progress=True,
    )
    s_grid = np.linspace(0.0, 1.0, len(result.t))
    s_robot = (fit.t_robot - fit.t_robot[0]) / (fit.t_robot[-1] - fit.t_robot[0])
    q_plan = np.stack([np.interp(s_robot, s_grid, col) for col in result.trajectory.T], axis=1)
    return result, np.clip(q_plan, robot.lower.numpy(), robot.upper.numpy())


def run(cfg: Any, out_dir: str | Path) -> dict:
    """The whole chain for the demonstration ``cfg.source`` (:mod:`lfd.imitation.sources`) writing into
    ``out_dir``; returns the summary dict.

    Human sources (a video, several calibrated videos, a skeleton file) go through the arm analysis and
    retargeting; robot sources (a teach export, a bag, a joint CSV) carry the robot's joints and skip them.
    Then: DMP fitted and time-scaled to the limits, refined when ``cfg.refine.task`` is set, executed in
    PyBullet, outputs written.

    Raises:
        ValueError: unknown robot, side, source type or refine option (before any file is read); an
            undecodable video, a recording without the robot's joints or the arm's, too few frames, an
            unreachable refinement target, a malformed goal.
        FileNotFoundError: nothing at the source path.
    """
    from lfd.robots import load_robot

    from .outputs import write_common_outputs
    from .sources import HUMAN_SOURCES, detect_source_type, load_robot_source

    check_config(cfg)
    source = source_of(cfg)
    kind = cfg.get("source_type") or detect_source_type(source)
    if isinstance(source, list) and kind != "multiview":
        raise ValueError(f"source: a list of paths is a multiview source (several videos), not {kind!r}")
    robot = load_robot(cfg.robot)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if kind == "video":
        kp = estimate_pose(cfg, out)
        analysis = analyse(cfg, kp, out)
    elif kind == "multiview":
        from .multiview import estimate_multiview

        skeleton, views = estimate_multiview(cfg, source if isinstance(source, list) else [source], out)
        analysis = analyse_skeleton(cfg, skeleton, out)
    elif kind in HUMAN_SOURCES:
        analysis = analyse_skeleton(cfg, source, out)
    if kind in HUMAN_SOURCES:
        t, rt = retarget(cfg, analysis)
        q_reference, base_rotation = rt.q, rt.base_rotation
    else:
        demo = load_robot_source(
            source, kind, robot, topic=cfg.get("topic"), joint_names=cfg.get("joint_names")
        )
        t, q_reference, base_rotation = demo.t, demo.q, np.eye(3)
    fit = fit_dmp(cfg, robot, t, q_reference, out)
    refinement, q_plan = refine(cfg, robot, fit)
    executed = execute(cfg, robot, base_rotation, fit, q_reference[-1], q_plan, render=kind == "video")
    if kind == "video":
        from .side_by_side import write_outputs

        summary = write_outputs(cfg, out, kp, robot, t, rt, fit, executed, refinement, q_plan)
    else:
        extra = {"side": cfg.side} if kind in HUMAN_SOURCES else {"recording": demo.detail}
        if kind in HUMAN_SOURCES:
            extra.update(
                clamped_frames=int(rt.clamped.sum()), base_rotation=np.asarray(base_rotation).tolist()
            )
        if kind == "multiview":
            extra["multiview"] = views
        extra["goal"] = executed.goal
        summary = write_common_outputs(
            cfg, out, robot, source=source, source_type=kind, t_source=t, q_reference=q_reference, fit=fit,
            q_commanded=q_plan, q_exec=executed.q_exec, refinement=refinement, extra=extra,
        )  # fmt: skip
    refined = (
        ""
        if refinement is None
        else (
            f"; refined ({refinement.method}, {refinement.task}) in {refinement.rollouts} rollouts to "
            f"{100 * refinement.task_error_m:.2f} cm, shape RMSE {refinement.shape_rmse_rad:.3f} rad"
        )
    )
    print(
        f"[lfd] {source} ({kind}, {summary['frames']} samples) -> {cfg.robot}: time scaled x{fit.factor:.2f}, "
        f"executed vs commanded RMSE {np.degrees(summary['executed_vs_dmp_rmse_rad']):.2f} deg, "
        f"{summary['limit_violations']} limit violations{refined}; outputs in {out}"
    )
    return summary
