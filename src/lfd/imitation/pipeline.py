"""The stages of turning a demonstration into a robot skill, callable one by one.

Like Pose2Sim's ``Pose2Sim.calibration()``, ``Pose2Sim.poseEstimation()``, ..., each stage
is a function of the validated settings (:class:`lfd.imitation.settings.ImitationSettings`, the keys of
``configs/imitate.yaml``) and of the previous stages' results (:mod:`lfd.imitation.results`). The source
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

:func:`run` chains them. Retargeting follows the robot's catalogue entry
(:class:`lfd.robots.catalogue.CatalogueEntry`, ``retarget``): ``"posture"`` maps the arm's link
directions (the WAM), ``"wrist_path"`` makes the tool follow the wrist path by IK. Units: s, rad, m.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from lfd.robots.catalogue import catalogue_entry

from .multiview import estimate_multiview
from .outputs import write_common_outputs
from .refine import refine_skill
from .results import DMPFit, Execution
from .settings import DMPSettings, ImitationSettings
from .side_by_side import write_outputs
from .sources import HUMAN_SOURCES, detect_source_type, load_robot_source

__all__ = [
    "RETARGETERS",
    "analyse",
    "analyse_skeleton",
    "basis_count",
    "estimate_pose",
    "execute",
    "fill_missing",
    "fit_dmp",
    "refine",
    "retarget",
    "run",
    "source_of",
]


def source_of(settings: ImitationSettings) -> str | list[str]:
    """The demonstration path (:attr:`ImitationSettings.demonstration`); raises ``ValueError`` when none."""
    return settings.demonstration


def estimate_pose(settings: ImitationSettings, out: Path):
    """Stage 1: :class:`lfd.human.video.VideoKeypoints` of the video (``settings.pose``:
    model, heavy_model, width, stride, max_frames), written to ``out/keypoints.csv`` and ``keypoints.npz``.

    Raises:
        FileNotFoundError, ValueError: from :func:`lfd.human.video.estimate_keypoints`
            (missing or undecodable video, ``pose.model`` not full/heavy, heavy model missing).
    """
    from lfd.human.video import estimate_keypoints

    kp = estimate_keypoints(Path(settings.demonstration), **settings.pose.estimator_options())
    kp.to_csv(out / "keypoints.csv")
    kp.save(out / "keypoints.npz")
    return kp


def analyse(settings: ImitationSettings, kp, out: Path):
    """Stage 2: :func:`lfd.human.analyze_arm` of the skeleton (visibility threshold
    ``settings.pose.min_visibility``, front/back flips repaired with ``settings.pose.repair_flips``),
    arm depth lifted with ``settings.pose.lift_depth``, options ``settings.analysis``; saved as
    ``out/arm.*`` (no plots)."""
    pose = settings.pose
    return analyse_skeleton(
        settings, kp.to_skeleton(pose.min_visibility, pose.repair_flips, pose.lift_depth), out
    )


def analyse_skeleton(settings: ImitationSettings, path, out: Path):
    """Stage 2 for a skeleton file: :func:`lfd.human.read_skeleton` (``settings.units``; the plausibility
    checks of :mod:`lfd.human.plausibility`), or a :class:`lfd.human.Skeleton` given as ``path`` (the
    multiview source), then :func:`lfd.human.analyze_arm` with ``settings.analysis``; saved as ``out/arm.*``
    (no plots)."""
    from lfd.human import Skeleton, analyze_arm, read_skeleton

    a = settings.analysis
    skeleton = path if isinstance(path, Skeleton) else read_skeleton(path, units=settings.units)
    analysis = analyze_arm(
        skeleton,
        side=settings.side,
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


def _posture(settings: ImitationSettings, t: np.ndarray, s, e, w):
    from lfd.human.retarget import retarget_wam4

    return retarget_wam4(s, e, w, side=settings.side, mount=settings.wam_mount, t=t)


def _wrist_path(settings: ImitationSettings, t: np.ndarray, s, e, w):
    from lfd.human.retarget import retarget_wrist_path

    return retarget_wrist_path(s, e, w, robot=settings.robot)


#: How a person's arm becomes the robot's joints, by the catalogue entry's ``retarget`` kind.
RETARGETERS = {"posture": _posture, "wrist_path": _wrist_path}


def retarget(settings: ImitationSettings, analysis):
    """Stage 3: times ``t (T,)`` s and the :mod:`lfd.human.retarget` result (``q (T, n)``,
    ``base_rotation``, ``clamped``, ``error``) of the analysis' trunk-frame shoulder, elbow
    and wrist positions, missing frames filled (:func:`fill_missing`); the robot's catalogue entry
    says how (:data:`RETARGETERS`).

    Raises:
        ValueError: a robot whose catalogue entry has no retargeting kind.
    """
    kind = catalogue_entry(settings.robot).retarget
    if kind not in RETARGETERS:
        raise ValueError(
            f"robot {settings.robot!r}: the catalogue offers no retargeting of a person's arm to it"
        )
    t, positions = fill_missing(analysis.t, analysis.positions)
    return t, RETARGETERS[kind](settings, t, positions[:, 0], positions[:, 1], positions[:, 2])


def basis_count(dmp: DMPSettings, duration: float) -> int:
    """The DMP's basis functions for a demonstration of ``duration`` s: ``dmp.n_basis`` when it is an
    integer; ``"auto"``: ``max(min_basis, ceil(basis_per_second * duration))`` (long recordings of several
    repetitions get more, short clips keep ``min_basis``). The values were checked by :class:`DMPSettings`.
    """
    if dmp.n_basis == "auto":
        return max(int(dmp.min_basis), int(np.ceil(float(dmp.basis_per_second) * max(duration, 0.0))))
    return int(dmp.n_basis)


def fit_dmp(settings: ImitationSettings, robot, t: np.ndarray, q: np.ndarray, out: Path) -> DMPFit:
    """Stage 4: fit a DMP (:func:`basis_count` of ``settings.dmp``) to ``q (T, n)`` at ``t (T,)``, stretched in time
    so its rollout keeps ``robot``'s velocity limits; saved as ``out/dmp.json``.

    The robot executes the DMP, so its rollout (not the frame-to-frame retargeted samples,
    whose single-frame pose glitches the DMP smooths away) must respect the limits; a DMP is
    invariant to a uniform time stretch, so the factor found in video time holds after it.
    """
    from lfd.dmp import DMP
    from lfd.human.retarget import time_scale

    lo, hi, vmax = robot.lower.numpy(), robot.upper.numpy(), robot.velocity_limits.numpy()
    n_basis = basis_count(settings.dmp, float(t[-1] - t[0]))
    _, factor_retargeted = time_scale(t, q, vmax)
    q_video = np.clip(np.asarray(DMP(n_basis=n_basis).fit(t, q).rollout(t)), lo, hi)
    t_robot, factor = time_scale(t, q_video, vmax)
    dmp = DMP(n_basis=n_basis).fit(t_robot, q)
    dmp.save(out / "dmp.json")
    q_dmp = np.clip(np.asarray(dmp.rollout(t_robot)), lo, hi)
    return DMPFit(dmp, t_robot, q_dmp, factor, factor_retargeted)


def execute(
    settings: ImitationSettings,
    robot,
    base_rotation: np.ndarray,
    fit: DMPFit,
    q_start: np.ndarray,
    q_plan: np.ndarray | None = None,
    render: bool | None = None,
) -> Execution:
    """Stage 5: run ``q_plan (T, n)`` (default ``fit.q_dmp``) at ``fit.t_robot`` on the arm alone in
    PyBullet (``settings.sim``: physics ``rate`` Hz, position/velocity gains, ``image_size``; base 1 m up,
    oriented by ``base_rotation``: the simulation's world frame is the person's trunk frame; identity
    for robot sources). Robot renders are taken only when ``render`` (default: ``settings.outputs`` asks
    for a video or GIF). With ``settings.goal`` (tool position, m, robot base frame) the DMP is also
    rolled out towards the IK solution (position only, started at ``q_start``) and run in the same world.
    """
    import torch

    from lfd.robots.ik import solve_ik
    from lfd.sim.tracking import ArmWorld, track_resampled

    sim, outputs = settings.sim, settings.outputs
    rate = float(sim.rate)
    t_robot = fit.t_robot
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    with ArmWorld(
        robot,
        timestep=1.0 / rate,
        base_position=(0.0, 0.0, 1.0),
        base_rotation=base_rotation,
        position_gain=float(sim.position_gain),
        velocity_gain=float(sim.velocity_gain),
        image_size=tuple(sim.image_size),
    ) as world:
        want = outputs.video or outputs.gif
        q_plan = fit.q_dmp if q_plan is None else q_plan
        want = want if render is None else render
        q_exec, images = track_resampled(world, t_robot, q_plan, rate, t_robot if want else None)
        goal_result = None
        if settings.goal is not None:
            goal = np.asarray(settings.goal, float)
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


def refine(settings: ImitationSettings, robot, fit: DMPFit):
    """Stage 4b (with ``settings.refine.task``): :func:`lfd.imitation.refine.refine_skill` of ``fit.dmp`` and
    its rollout on ``fit.t_robot``; returns ``(refinement, q_plan (T, n))`` or ``(None, fit.q_dmp)``."""
    r = settings.refine
    if r.task is None:
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
        t_via=None if r.t_via is None else float(r.t_via) * fit.factor,
        radius=float(r.radius),
        goal_init=str(r.goal_init),
        seed=int(r.seed),
        progress=True,
    )
    s_grid = np.linspace(0.0, 1.0, len(result.t))
    s_robot = (fit.t_robot - fit.t_robot[0]) / (fit.t_robot[-1] - fit.t_robot[0])
    q_plan = np.stack([np.interp(s_robot, s_grid, col) for col in result.trajectory.T], axis=1)
    return result, np.clip(q_plan, robot.lower.numpy(), robot.upper.numpy())


def run(settings: ImitationSettings | Mapping[str, Any], out_dir: str | Path) -> dict:
    """The whole chain for the demonstration ``settings.source`` (:mod:`lfd.imitation.sources`) writing into
    ``out_dir``; returns the summary dict. ``settings`` may also be a mapping of the config's keys
    (:meth:`ImitationSettings.from_mapping`, e.g. a composed ``configs/imitate.yaml``).

    Human sources (a video, several calibrated videos, a skeleton file) go through the arm analysis and
    retargeting; robot sources (a teach export, a bag, a joint CSV) carry the robot's joints and skip them.
    Then: DMP fitted and time-scaled to the limits, refined when ``settings.refine.task`` is set, executed in
    PyBullet, outputs written.

    Raises:
        ValueError: a bad setting (:mod:`lfd.imitation.settings`, before any file is read); no source; an
            undecodable video, a recording without the robot's joints or the arm's, too few frames, an
            unreachable refinement target.
        FileNotFoundError: nothing at the source path.
    """
    from lfd.robots import load_robot

    if not isinstance(settings, ImitationSettings):
        settings = ImitationSettings.from_mapping(settings)
    source = settings.demonstration
    kind = settings.source_type or detect_source_type(source)
    if isinstance(source, list) and kind != "multiview":
        raise ValueError(f"source: a list of paths is a multiview source (several videos), not {kind!r}")
    robot = load_robot(settings.robot)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if kind == "video":
        kp = estimate_pose(settings, out)
        analysis = analyse(settings, kp, out)
    elif kind == "multiview":
        videos = source if isinstance(source, list) else [source]
        skeleton, views = estimate_multiview(settings, videos, out)
        analysis = analyse_skeleton(settings, skeleton, out)
    elif kind in HUMAN_SOURCES:
        analysis = analyse_skeleton(settings, source, out)
    if kind in HUMAN_SOURCES:
        t, rt = retarget(settings, analysis)
        q_reference, base_rotation = rt.q, rt.base_rotation
    else:
        demo = load_robot_source(source, kind, robot, topic=settings.topic, joint_names=settings.joint_names)
        t, q_reference, base_rotation = demo.t, demo.q, np.eye(3)
    fit = fit_dmp(settings, robot, t, q_reference, out)
    refinement, q_plan = refine(settings, robot, fit)
    executed = execute(settings, robot, base_rotation, fit, q_reference[-1], q_plan, render=kind == "video")
    if kind == "video":
        summary = write_outputs(settings, out, kp, robot, t, rt, fit, executed, refinement, q_plan)
    else:
        extra = {"side": settings.side} if kind in HUMAN_SOURCES else {"recording": demo.detail}
        if kind in HUMAN_SOURCES:
            extra.update(
                clamped_frames=int(rt.clamped.sum()), base_rotation=np.asarray(base_rotation).tolist()
            )
        if kind == "multiview":
            extra["multiview"] = views
        extra["goal"] = executed.goal
        summary = write_common_outputs(
            settings, out, robot, source=source, source_type=kind, t_source=t, q_reference=q_reference, fit=fit,
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
        f"[lfd] {source} ({kind}, {summary['frames']} samples) -> {settings.robot}: time scaled x{fit.factor:.2f}, "
        f"executed vs commanded RMSE {np.degrees(summary['executed_vs_dmp_rmse_rad']):.2f} deg, "
        f"{summary['limit_violations']} limit violations{refined}; outputs in {out}"
    )
    return summary
