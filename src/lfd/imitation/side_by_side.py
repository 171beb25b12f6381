"""Side-by-side video of an imitation: the person's frames (arm drawn) next to the robot renders.

:func:`write_side_by_side` writes an MP4 (PyAV, H.264, ``yuv420p``) and/or a GIF (Pillow,
half size) of tiles ``[video frame with the skeleton drawn | robot render]``, one tile per
robot render, both halves ``height`` px tall.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .outputs import write_common_outputs
from .results import DMPFit, Execution
from .settings import ImitationSettings

__all__ = ["write_outputs", "write_side_by_side"]


def _draw(rgb: np.ndarray, pixels: np.ndarray, scale: float, side: str) -> np.ndarray:
    """``rgb (H, W, 3)`` with the MediaPipe skeleton ``pixels (33, 2)`` (x ``scale``) drawn: the
    ``side`` arm in orange, the rest in cyan (missing landmarks skipped)."""
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


def write_side_by_side(
    path_mp4, path_gif, video, kp, side, robot_images, times, fps, gif_frames, height=320
) -> list[Path]:
    """Video frames (arm drawn) next to the robot renders, as MP4 (PyAV) and/or GIF (Pillow).

    Args:
        path_mp4, path_gif: output paths, or None to skip that file.
        video: the person's video; kp: its :class:`lfd.human.video.VideoKeypoints`.
        side: ``"left"`` or ``"right"``, the arm drawn in orange.
        robot_images: ``(h, w, 3)`` uint8 robot renders, one per tile.
        times: (K,) video frame index of each render.
        fps: frame rate of the MP4 (rounded) and the GIF's pace.
        gif_frames: at most this many GIF frames (evenly picked).
        height: tile height, px.

    Returns:
        The paths written (none when no frame matched).
    """
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


def write_outputs(
    settings: ImitationSettings,
    out: Path,
    kp,
    robot,
    t: np.ndarray,
    rt,
    fit: DMPFit,
    run: Execution,
    refinement=None,
    q_plan=None,
) -> dict:
    """Stage 6 for a video: the side-by-side video/GIF (``settings.outputs``) and the outputs of
    :func:`lfd.imitation.outputs.write_common_outputs` with the video's own summary entries
    (returned as a dict)."""
    repair = settings.pose.repair_flips
    outputs = settings.outputs
    lo, hi = robot.lower.numpy(), robot.upper.numpy()
    q_exec, q_dmp = run.q_exec, fit.q_dmp
    video = Path(settings.demonstration)
    extra = {
        "video": str(video),
        "side": settings.side,
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
        "executed_rmse_rad": float(np.sqrt(np.mean((q_exec - rt.q) ** 2))),
        "executed_within_limits": bool(((q_exec >= lo - 1e-3) & (q_exec <= hi + 1e-3)).all()),
        "goal": run.goal,
    }
    if outputs.video or outputs.gif:
        frame_of = kp.frame_index[np.searchsorted(kp.t, t)]
        write_side_by_side(
            out / "side_by_side.mp4" if outputs.video else None,
            out / "side_by_side.gif" if outputs.gif else None,
            video,
            kp,
            settings.side,
            run.images,
            frame_of,
            len(t) / max(t[-1] - t[0], 1e-6),
            int(outputs.gif_frames),
        )
    return write_common_outputs(
        settings, out, robot, source=str(video), source_type="video", t_source=t, q_reference=rt.q, fit=fit,
        q_commanded=q_dmp if q_plan is None else q_plan, q_exec=q_exec, refinement=refinement, extra=extra,
    )  # fmt: skip
