"""Learn a robot skill from a video of a person (docs/video.md).

Usage::

    python scripts/imitate.py video=person.mp4 robot=wam4 side=right
    python scripts/imitate.py video=person.mp4 robot=sawyer goal=[0.6,-0.1,0.5]

Chain: video -> MediaPipe pose (progress bar over frames) -> :func:`lfd.human.analyze_arm`
(angles, torques) -> retargeting (:mod:`lfd.human.retarget`: WAM posture or 7-DoF wrist
path) -> DMP fitted to the joint trajectory, time-scaled so its rollout keeps the velocity limits -> PyBullet
rollout under position control with the URDF limits -> side-by-side video (the frame with
the detected arm drawn, the robot in simulation). With ``goal=`` (tool position in the robot
base frame) the DMP is rolled out towards the IK solution of that goal as well.

Outputs in the Hydra run directory: ``keypoints.csv`` (+ ``keypoints.npz``), ``arm.csv``/
``arm.mot``/``arm.json`` (lfd.human), ``dmp.npz``, ``robot_trajectory.csv`` (time, retargeted,
DMP and executed joints), ``summary.json`` (fps, time-scale factor, tracking RMSE, limits),
``side_by_side.mp4`` and ``side_by_side.gif``. Configuration: ``configs/imitate.yaml``.
"""

from __future__ import annotations

import json
from pathlib import Path

import hydra
import numpy as np
from omegaconf import DictConfig

CONFIGS = str(Path(__file__).resolve().parents[1] / "configs")
ROBOTS = ("wam4", "sawyer", "pr2_right_arm")


def _fill(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Interpolate NaN rows of ``x (T, ...)`` over time; drop leading/trailing missing rows."""
    flat = x.reshape(len(t), -1)
    ok = np.isfinite(flat).all(1)
    if ok.sum() < 4:
        raise ValueError(f"the arm was seen in only {int(ok.sum())} frames; need at least 4")
    first, last = np.argmax(ok), len(ok) - np.argmax(ok[::-1])
    t, flat, ok = t[first:last], flat[first:last], ok[first:last]
    filled = np.stack([np.interp(t, t[ok], col[ok]) for col in flat.T], 1)
    return t, filled.reshape((len(t),) + x.shape[1:])


def retarget(cfg: DictConfig, t: np.ndarray, positions: np.ndarray):
    """Robot joint trajectory from trunk-frame shoulder/elbow/wrist ``(T, 3, 3)``."""
    from lfd.human.retarget import retarget_wam4, retarget_wrist_path

    s, e, w = positions[:, 0], positions[:, 1], positions[:, 2]
    if cfg.robot == "wam4":
        return retarget_wam4(s, e, w, side=cfg.side, mount=str(cfg.get("wam_mount", "auto")), t=t)
    return retarget_wrist_path(s, e, w, robot=cfg.robot)


def _draw(rgb: np.ndarray, pixels: np.ndarray, scale: float, side: str) -> np.ndarray:
    import cv2

    from lfd.human.video import ARM_EDGES

    img = rgb.copy()
    arm = {(12, 14), (14, 16)} if side == "right" else {(11, 13), (13, 15)}
    for a, b in ARM_EDGES:
        if np.isfinite(pixels[[a, b]]).all():
            colour = (255, 60, 0) if (a, b) in arm else (0, 200, 255)
            pa, pb = (pixels[a] * scale).astype(int), (pixels[b] * scale).astype(int)
            cv2.line(img, tuple(pa.tolist()), tuple(pb.tolist()), colour, 3)
    return img


def write_side_by_side(path_mp4, path_gif, video, kp, side, robot_images, times, fps, gif_frames, height=320):
    """Video frames (arm drawn) next to the robot renders, as MP4 (PyAV) and/or GIF (Pillow)."""
    import cv2

    from lfd.human.video import iter_frames

    wanted = {int(i): k for k, i in enumerate(times)}
    tiles = []
    for index, _, rgb in iter_frames(video):
        if index not in wanted:
            continue
        k = wanted[index]
        j = int(np.searchsorted(kp.frame_index, index))
        left = _draw(rgb, kp.pixels[j], 1.0, side)
        left = cv2.resize(left, (int(round(left.shape[1] * height / left.shape[0] / 2) * 2), height))
        right = cv2.resize(robot_images[k], (height, height))
        tiles.append(np.concatenate([left, right], 1))
        if len(tiles) == len(robot_images):
            break
    paths = []
    if path_mp4 is not None and tiles:
        import av

        with av.open(str(path_mp4), "w") as out:
            stream = out.add_stream("libx264", rate=int(round(fps)))
            stream.width, stream.height, stream.pix_fmt = tiles[0].shape[1], tiles[0].shape[0], "yuv420p"
            for tile in tiles:
                for packet in stream.encode(av.VideoFrame.from_ndarray(tile, format="rgb24")):
                    out.mux(packet)
            for packet in stream.encode():
                out.mux(packet)
        paths.append(Path(path_mp4))
    if path_gif is not None and tiles:
        from PIL import Image

        pick = np.linspace(0, len(tiles) - 1, min(gif_frames, len(tiles))).astype(int)
        images = [Image.fromarray(cv2.resize(tiles[i], None, fx=0.5, fy=0.5)) for i in pick]
        step = (len(tiles) / fps) / len(pick)
        images[0].save(path_gif, save_all=True, append_images=images[1:], duration=int(1000 * step), loop=0)
        paths.append(Path(path_gif))
    return paths


def run(cfg: DictConfig, out_dir: str | Path) -> dict:
    """The whole chain for ``cfg.video`` writing into ``out_dir``; returns the summary dict."""
    import torch

    from lfd.dmp import DMP
    from lfd.human import analyze_arm
    from lfd.io.files import write_text_atomic as _atomic_write
    from lfd.human.retarget import time_scale
    from lfd.human.video import estimate_keypoints
    from lfd.robots import load_robot
    from lfd.robots.ik import solve_ik
    from lfd.sim.tracking import ArmWorld, track_resampled

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if cfg.robot not in ROBOTS:
        raise ValueError(f"robot must be one of {', '.join(ROBOTS)}, got {cfg.robot!r}")
    if cfg.side not in ("left", "right"):
        raise ValueError(f"side must be 'left' or 'right', got {cfg.side!r}")
    video = Path(str(cfg.video))
    kp = estimate_keypoints(video, width=cfg.pose.width, stride=int(cfg.pose.stride), max_frames=cfg.pose.max_frames,
                            progress=True)  # fmt: skip
    kp.to_csv(out / "keypoints.csv")
    kp.save(out / "keypoints.npz")
    a = cfg.analysis
    repair = bool(cfg.pose.get("repair_flips", True))
    analysis = analyze_arm(kp.to_skeleton(float(cfg.pose.min_visibility), repair), side=cfg.side, body_mass=float(a.body_mass),
                           sex=a.sex, filter=a.filter, cutoff=float(a.cutoff), max_gap=float(a.max_gap))  # fmt: skip
    analysis.save(out, stem="arm", plots=False)
    t, positions = _fill(analysis.t, analysis.positions)
    frame_of = kp.frame_index[np.searchsorted(kp.t, t)]
    rt = retarget(cfg, t, positions)
    robot = load_robot(cfg.robot)
    # The robot executes the DMP, so its rollout (not the frame-to-frame retargeted samples, whose
    # single-frame pose glitches the DMP smooths away) must respect the velocity limits; a DMP is
    # invariant to a uniform time stretch, so the factor found in video time holds after it.
    _, factor_retargeted = time_scale(t, rt.q, robot.velocity_limits.numpy())
    q_video = np.clip(np.asarray(DMP(n_basis=int(cfg.dmp.n_basis)).fit(t, rt.q).rollout(t)), robot.lower.numpy(),
                      robot.upper.numpy())  # fmt: skip
    t_robot, factor = time_scale(t, q_video, robot.velocity_limits.numpy())
    dmp = DMP(n_basis=int(cfg.dmp.n_basis)).fit(t_robot, rt.q)
    dmp.save(out / "dmp.npz")
    q_dmp = np.asarray(dmp.rollout(t_robot))
    q_dmp = np.clip(q_dmp, robot.lower.numpy(), robot.upper.numpy())
    # World frame of the simulation = the trunk frame; the WAM is side-mounted (lfd.human.retarget).
    base = rt.base_rotation
    rate = float(cfg.sim.rate)
    with ArmWorld(robot, timestep=1.0 / rate, base_position=(0.0, 0.0, 1.0), base_rotation=base,
                  position_gain=float(cfg.sim.position_gain), velocity_gain=float(cfg.sim.velocity_gain),
                  image_size=tuple(cfg.sim.image_size)) as world:  # fmt: skip
        want = cfg.outputs.video or cfg.outputs.gif
        q_exec, images = track_resampled(world, t_robot, q_dmp, rate, t_robot if want else None)
        goal_result = None
        if cfg.goal is not None:
            goal = np.asarray(list(cfg.goal), float)
            if goal.shape != (3,) or not np.isfinite(goal).all():
                raise ValueError(f"goal must be a tool position [x, y, z] in metres, got {list(cfg.goal)}")
            sol = solve_ik(
                robot, torch.from_numpy(goal[None]), torch.from_numpy(rt.q[-1][None]), position_only=True
            )
            q_goal = sol.q[0].numpy()
            q_new = np.clip(
                np.asarray(dmp.rollout(t_robot, goal=q_goal)), robot.lower.numpy(), robot.upper.numpy()
            )
            q_new_exec, _ = track_resampled(world, t_robot, q_new, rate)
            reached = robot.fk(torch.from_numpy(q_new_exec[-1:]))[0, :3, 3].numpy()
            goal_result = {"goal_m": goal.tolist(), "ik_success": bool(sol.success[0]),
                           "final_tool_error_m": float(np.linalg.norm(reached - goal))}  # fmt: skip
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    rmse = float(np.sqrt(np.mean((q_exec - rt.q) ** 2)))
    cols = {"time_s": t_robot, "video_time_s": t}
    for j, name in enumerate(robot.joint_names):
        cols[f"{name}_retargeted"] = rt.q[:, j]
        cols[f"{name}_dmp"] = q_dmp[:, j]
        cols[f"{name}_executed"] = q_exec[:, j]
    data = np.column_stack(list(cols.values()))
    _atomic_write(
        out / "robot_trajectory.csv",
        "\n".join([",".join(cols)] + [",".join(f"{v:.6g}" for v in r) for r in data]) + "\n",
    )
    summary = {
        "video": str(video), "robot": cfg.robot, "side": cfg.side, "frames": kp.n_frames,
        "frames_with_person": int(kp.detected.sum()), "frames_other_person": int(kp.other_person.sum()),
        "pose_fps": kp.fps, "time_scale_factor": factor,
        "time_scale_factor_retargeted_samples": factor_retargeted, "front_back_flips_repaired": int(kp.front_back_flips().sum()) if repair else 0,
        "base_rotation": np.asarray(rt.base_rotation).tolist(), "clamped_frames": int(rt.clamped.sum()),
        "retarget_error_max": float(rt.error.max()),
        "dmp_rmse_rad": float(np.sqrt(np.mean((q_dmp - rt.q) ** 2))),
        "executed_rmse_rad": rmse,
        "executed_within_limits": bool(((q_exec >= lo - 1e-3) & (q_exec <= hi + 1e-3)).all()),
        "goal": goal_result,
    }  # fmt: skip
    if cfg.outputs.video or cfg.outputs.gif:
        write_side_by_side(out / "side_by_side.mp4" if cfg.outputs.video else None,
                           out / "side_by_side.gif" if cfg.outputs.gif else None, video, kp, cfg.side, images,
                           frame_of, len(t) / max(t[-1] - t[0], 1e-6), int(cfg.outputs.gif_frames))  # fmt: skip
    _atomic_write(out / "summary.json", json.dumps(summary, indent=1) + "\n")
    print(f"[lfd] {video}: {kp.detected.sum()}/{kp.n_frames} frames with the person ({kp.fps:.1f} fps); {cfg.robot}: "
          f"time scaled x{factor:.2f}, executed DMP RMSE {np.degrees(rmse):.2f} deg; outputs in {out}")  # fmt: skip
    return summary


@hydra.main(version_base="1.3", config_path=CONFIGS, config_name="imitate")
def main(cfg: DictConfig) -> None:
    from hydra.core.hydra_config import HydraConfig

    run(cfg, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    main()
