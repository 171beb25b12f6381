"""The stages of learning a robot skill from a video of a person, callable one by one.

Like Pose2Sim's ``Pose2Sim.calibration()``, ``Pose2Sim.poseEstimation()``, ..., each stage
is a function of the configuration (``configs/imitate.yaml``, any object with attribute
access such as an OmegaConf ``DictConfig``) and of the previous stages' results:

1. :func:`estimate_pose`: MediaPipe keypoints of the video (``keypoints.csv``/``.npz``);
2. :func:`analyse`: arm angles and torques (:func:`lfd.human.analyze_arm`; ``arm.csv``/
   ``.mot``/``.json``);
3. :func:`retarget`: the robot joint trajectory (:mod:`lfd.human.retarget`: WAM posture or
   7-DoF wrist path + IK), missing frames interpolated;
4. :func:`fit_dmp`: a DMP fitted to it and time-scaled so its rollout keeps the velocity
   limits (``dmp.json``, read by ``lfd.dmp.DMP.load``);
5. :func:`execute`: the DMP rollout run in PyBullet (the one tracker,
   :func:`lfd.sim.tracking.track_resampled`) and, with ``goal``, rolled out towards the IK
   solution of that tool position and run as well;
6. :func:`write_outputs`: ``robot_trajectory.csv``, ``side_by_side.mp4``/``.gif``,
   ``summary.json``.

:func:`run` chains them. Units: s, rad, m.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "ROBOTS",
    "DMPFit",
    "Execution",
    "analyse",
    "check_config",
    "estimate_pose",
    "execute",
    "fill_missing",
    "fit_dmp",
    "retarget",
    "run",
    "write_outputs",
]

#: Robots a person's arm is retargeted to.
ROBOTS = ("wam4", "sawyer", "pr2_right_arm")


def check_config(cfg: Any) -> None:
    """Raise ``ValueError`` for a robot not in :data:`ROBOTS` or a side not left/right."""
    if cfg.robot not in ROBOTS:
        raise ValueError(f"robot must be one of {', '.join(ROBOTS)}, got {cfg.robot!r}")
    if cfg.side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {cfg.side!r}")


def estimate_pose(cfg: Any, out: Path):
    """Stage 1: :class:`lfd.human.video.VideoKeypoints` of ``cfg.video`` (``cfg.pose``:
    width, stride, max_frames), written to ``out/keypoints.csv`` and ``keypoints.npz``.

    Raises:
        FileNotFoundError, ValueError: from :func:`lfd.human.video.estimate_keypoints`
            (missing or undecodable video).
    """
    from lfd.human.video import estimate_keypoints

    kp = estimate_keypoints(
        Path(str(cfg.video)),
        width=cfg.pose.width,
        stride=int(cfg.pose.stride),
        max_frames=cfg.pose.max_frames,
        progress=True,
    )
    kp.to_csv(out / "keypoints.csv")
    kp.save(out / "keypoints.npz")
    return kp


def analyse(cfg: Any, kp, out: Path):
    """Stage 2: :func:`lfd.human.analyze_arm` of the skeleton (visibility threshold
    ``cfg.pose.min_visibility``, front/back flips repaired with ``cfg.pose.repair_flips``),
    options ``cfg.analysis``; saved as ``out/arm.*`` (no plots)."""
    from lfd.human import analyze_arm

    a = cfg.analysis
    repair = bool(cfg.pose.get("repair_flips", True))
    analysis = analyze_arm(
        kp.to_skeleton(float(cfg.pose.min_visibility), repair),
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
    """Stage 4: fit a DMP (``cfg.dmp.n_basis``) to ``q (T, n)`` at ``t (T,)``, stretched in time
    so its rollout keeps ``robot``'s velocity limits; saved as ``out/dmp.json``.

    The robot executes the DMP, so its rollout (not the frame-to-frame retargeted samples,
    whose single-frame pose glitches the DMP smooths away) must respect the limits; a DMP is
    invariant to a uniform time stretch, so the factor found in video time holds after it.
    """
    from lfd.dmp import DMP
    from lfd.human.retarget import time_scale

    lo, hi, vmax = robot.lower.numpy(), robot.upper.numpy(), robot.velocity_limits.numpy()
    n_basis = int(cfg.dmp.n_basis)
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


def execute(cfg: Any, robot, base_rotation: np.ndarray, fit: DMPFit, q_start: np.ndarray) -> Execution:
    """Stage 5: run ``fit.q_dmp`` on the arm alone in PyBullet (``cfg.sim``: physics ``rate``
    Hz, position/velocity gains, ``image_size``; base 1 m up, oriented by ``base_rotation``:
    the simulation's world frame is the person's trunk frame). With ``cfg.goal`` (tool
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
        q_exec, images = track_resampled(world, t_robot, fit.q_dmp, rate, t_robot if want else None)
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


def write_outputs(cfg: Any, out: Path, kp, robot, t: np.ndarray, rt, fit: DMPFit, run: Execution) -> dict:
    """Stage 6: ``out/robot_trajectory.csv`` (robot and video time, retargeted, DMP and
    executed joints), the side-by-side video/GIF (``cfg.outputs``) and ``summary.json``
    (returned as a dict)."""
    from lfd.io.files import write_text_atomic

    from .side_by_side import write_side_by_side

    repair = bool(cfg.pose.get("repair_flips", True))
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    q_exec, q_dmp = run.q_exec, fit.q_dmp
    rmse = float(np.sqrt(np.mean((q_exec - rt.q) ** 2)))
    cols = {"time_s": fit.t_robot, "video_time_s": t}
    for j, name in enumerate(robot.joint_names):
        cols[f"{name}_retargeted"] = rt.q[:, j]
        cols[f"{name}_dmp"] = q_dmp[:, j]
        cols[f"{name}_executed"] = q_exec[:, j]
    data = np.column_stack(list(cols.values()))
    write_text_atomic(
        out / "robot_trajectory.csv",
        "\n".join([",".join(cols)] + [",".join(f"{v:.6g}" for v in r) for r in data]) + "\n",
    )
    video = Path(str(cfg.video))
    summary = {
        "video": str(video),
        "robot": cfg.robot,
        "side": cfg.side,
        "frames": kp.n_frames,
        "frames_with_person": int(kp.detected.sum()),
        "frames_other_person": int(kp.other_person.sum()),
        "pose_fps": kp.fps,
        "time_scale_factor": fit.factor,
        "time_scale_factor_retargeted_samples": fit.factor_retargeted,
        "front_back_flips_repaired": int(kp.front_back_flips().sum()) if repair else 0,
        "base_rotation": np.asarray(rt.base_rotation).tolist(),
        "clamped_frames": int(rt.clamped.sum()),
        "retarget_error_max": float(rt.error.max()),
        "dmp_rmse_rad": float(np.sqrt(np.mean((q_dmp - rt.q) ** 2))),
        "executed_rmse_rad": rmse,
        "executed_within_limits": bool(((q_exec >= lo - 1e-3) & (q_exec <= hi + 1e-3)).all()),
        "goal": run.goal,
    }
    if cfg.outputs.video or cfg.outputs.gif:
        frame_of = kp.frame_index[np.searchsorted(kp.t, t)]
        write_side_by_side(
            out / "side_by_side.mp4" if cfg.outputs.video else None,
            out / "side_by_side.gif" if cfg.outputs.gif else None,
            video,
            kp,
            cfg.side,
            run.images,
            frame_of,
            len(t) / max(t[-1] - t[0], 1e-6),
            int(cfg.outputs.gif_frames),
        )
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=1) + "\n")
    return summary


def run(cfg: Any, out_dir: str | Path) -> dict:
    """The whole chain for ``cfg.video`` writing into ``out_dir``; returns the summary dict.

    Raises:
        ValueError: unknown robot or side, undecodable video, too few frames with the arm,
            a malformed goal.
        FileNotFoundError: no video at ``cfg.video``.
    """
    from lfd.robots import load_robot

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    check_config(cfg)
    kp = estimate_pose(cfg, out)
    analysis = analyse(cfg, kp, out)
    t, rt = retarget(cfg, analysis)
    robot = load_robot(cfg.robot)
    fit = fit_dmp(cfg, robot, t, rt.q, out)
    executed = execute(cfg, robot, rt.base_rotation, fit, rt.q[-1])
    summary = write_outputs(cfg, out, kp, robot, t, rt, fit, executed)
    rmse = summary["executed_rmse_rad"]
    print(
        f"[lfd] {Path(str(cfg.video))}: {kp.detected.sum()}/{kp.n_frames} frames with the person ({kp.fps:.1f} fps); "
        f"{cfg.robot}: time scaled x{fit.factor:.2f}, executed DMP RMSE {np.degrees(rmse):.2f} deg; "
        f"outputs in {out}"
    )
    return summary
