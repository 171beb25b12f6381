"""Evaluation results in LeRobot's layout: ``eval_info.json`` and rollout MP4s.

For every evaluated method ``<out>/<method>/`` receives:

* ``eval_info.json`` in the schema of lerobot's ``lerobot_eval.py``: ``per_episode``
  (``episode_ix``, ``sum_reward``, ``max_reward``, ``success``, ``seed``) and
  ``aggregated`` (``avg_sum_reward``, ``avg_max_reward``, ``pc_success``, ``eval_s``,
  ``eval_ep_s``) as ``eval_policy`` writes them, plus ``per_task`` / ``per_group`` /
  ``overall`` as ``eval_policy_all`` writes them (a task = one object, with its task
  string; a group = an object family);
* ``videos/eval_episode_<i>.mp4`` (H.264) for the first ``n_videos`` episodes: a
  third-person view (:func:`lfd.sim.camera.third_person_camera`, 640 x 480) with the
  policy's own camera image (scaled up by an integer factor) beside it.

Rewards: ``r_t = clip(1 - d_t / d_0, 0, 1)`` after each control step ``t``, ``d_t`` the
tool's distance to the grasp target point (the share of the initial distance covered);
``sum_reward`` sums them, ``max_reward`` is their maximum. ``success`` is the one of
``metrics.json``: final distance < 5 cm (``success_5cm``). ``seed`` is the evaluation
run's seed (episodes start from their case -- object, placement -- not from a seed).

The videos replay the recorded joint angles of each episode in a fresh scene (arm exact;
the object is drawn where it stood at the start: the traces do not record its motion).

Example (what :meth:`lfd.visuomotor.eval.evaluator.ReachEvaluator.run` does)::

    write_lerobot_eval(out_dir, rows, cases, traces, gen_config, seed=42, eval_s=61.0)
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from lfd.io.files import write_text_atomic

SUCCESS_KEY = "success_5cm"


def episode_rewards(ee_path: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rewards ``(S,)`` of a tool path ``(S + 1, 3)`` (m): share of the initial distance to
    ``target (3,)`` covered after each step, clipped to ``[0, 1]``."""
    d = np.linalg.norm(np.asarray(ee_path) - np.asarray(target), axis=-1)
    if d.ndim != 1 or len(d) < 2:
        raise ValueError(
            f"episode_rewards: expected a tool path (S + 1, 3) with S >= 1, got {np.shape(ee_path)}"
        )
    return np.clip(1.0 - d[1:] / max(d[0], 1e-9), 0.0, 1.0)


def _mean(xs) -> float:
    xs = np.asarray(list(xs), dtype=np.float64)
    return float(np.nanmean(xs)) if xs.size else float("nan")


def eval_info(
    rows: list[dict[str, Any]],
    cases: list,
    traces: list,
    *,
    seed: int | None,
    eval_s: float,
    n_episodes_all_methods: int | None = None,
    video_paths: list[str] | None = None,
) -> dict[str, Any]:
    """``eval_info.json`` content of one method.

    Args:
        rows: that method's per-episode rows (``episodes.csv``), in case order.
        cases, traces: the evaluation cases and that method's episode traces.
        seed: the run's seed.
        eval_s: wall time of the evaluation run, s.
        n_episodes_all_methods: episodes ``eval_s`` covered (default ``len(rows)``).
        video_paths: rollout videos written for the first episodes.

    Raises:
        ValueError: ``rows``, ``cases`` and ``traces`` differ in length.
    """
    from lfd.interop.lerobot.export import task_string

    if not (len(rows) == len(cases) == len(traces)):
        raise ValueError(
            f"eval_info: need one row and trace per case, got {len(rows)}, {len(cases)}, {len(traces)}"
        )
    video_paths = list(video_paths or [])
    per_episode, tasks = [], {}
    for i, (row, case, trace) in enumerate(zip(rows, cases, traces, strict=True)):
        r = episode_rewards(trace.ee_poses[:, :3, 3], case.plan.target_point)
        ep = {
            "episode_ix": i,
            "sum_reward": float(r.sum()),
            "max_reward": float(r.max()),
            "success": bool(row[SUCCESS_KEY]),
            "seed": seed,
        }
        per_episode.append(ep)
        key = (case.obj.shape, int(case.object_index))
        task = tasks.setdefault(
            key,
            {
                "task_group": case.obj.shape,
                "task_id": int(case.object_index),
                "task": task_string(case.obj, case.plan.mode),
                "object": case.obj.name,
                "metrics": {"sum_rewards": [], "max_rewards": [], "successes": [], "video_paths": []},
            },
        )
        m = task["metrics"]
        m["sum_rewards"].append(ep["sum_reward"])
        m["max_rewards"].append(ep["max_reward"])
        m["successes"].append(ep["success"])
        if i < len(video_paths):
            m["video_paths"].append(video_paths[i])
    n_all = n_episodes_all_methods or len(rows)

    def agg(eps: list[dict]) -> dict[str, float]:
        return {
            "avg_sum_reward": _mean(e["sum_reward"] for e in eps),
            "avg_max_reward": _mean(e["max_reward"] for e in eps),
            "pc_success": _mean(e["success"] for e in eps) * 100 if eps else float("nan"),
        }

    groups: dict[str, list[dict]] = defaultdict(list)
    group_videos: dict[str, list[str]] = defaultdict(list)
    for ep, case in zip(per_episode, cases, strict=True):
        groups[case.obj.shape].append(ep)
    for t in tasks.values():
        group_videos[t["task_group"]] += t["metrics"]["video_paths"]
    timing = {"eval_s": float(eval_s), "eval_ep_s": float(eval_s) / max(1, n_all)}
    return {
        "per_episode": per_episode,
        "aggregated": {**agg(per_episode), **timing},
        "per_task": list(tasks.values()),
        "per_group": {
            g: {**agg(eps), "n_episodes": len(eps), "video_paths": group_videos[g]}
            for g, eps in groups.items()
        },
        "overall": {**agg(per_episode), "n_episodes": len(per_episode), **timing, "video_paths": video_paths},
        "video_paths": video_paths,
    }


def side_by_side(view: np.ndarray, policy_view: np.ndarray) -> np.ndarray:
    """``view (H, W, 3)`` with ``policy_view (h, h, 3)`` scaled up by ``H // h`` (nearest)
    and centred in an ``H x H`` dark panel to its right: ``(H, W + H, 3)`` uint8."""
    H = view.shape[0]
    h = policy_view.shape[0]
    k = max(1, H // h)
    big = np.repeat(np.repeat(policy_view, k, axis=0), k, axis=1)[:H, :H]
    panel = np.full((H, H, 3), 24, np.uint8)
    top, left = (H - big.shape[0]) // 2, (H - big.shape[1]) // 2
    panel[top : top + big.shape[0], left : left + big.shape[1]] = big
    return np.concatenate([view, panel], axis=1)


def render_rollout(scene, case, trace, camera, frame_every: int = 1) -> np.ndarray:
    """Replay an episode's recorded joint angles in ``scene`` (with the case's object at
    its placement): frames ``(N, H, W + H, 3)`` of ``camera`` beside the policy camera."""
    scene.reset(case.obj, case.placement, q=trace.joints[0])
    # the floor and table are drawn in the scene's backdrop client only (see ReachScene)
    backdrop = camera.render(scene._backdrop_client, scene.base_to_world)
    frames = []
    for k in range(0, len(trace.joints), max(1, int(frame_every))):
        scene.set_joints(trace.joints[k])
        frames.append(
            side_by_side(camera.render(scene.client, scene.base_to_world, backdrop), scene.render())
        )
    return np.stack(frames)


def write_lerobot_eval(
    out_dir: str | Path,
    rows: list[dict[str, Any]],
    cases: list,
    traces: dict[str, list],
    gen,
    *,
    seed: int | None,
    eval_s: float,
    n_videos: int = 2,
    frame_every: int = 2,
    video_size: tuple[int, int] = (640, 480),
) -> dict[str, Path]:
    """Write ``<out_dir>/<method>/eval_info.json`` and its rollout videos for every method
    of ``traces``; returns the ``eval_info.json`` path per method.

    Args:
        rows: every method's per-episode rows (``episodes.csv``, with a ``method`` column).
        cases: the evaluation cases; ``traces[method][i]`` ran ``cases[i]``.
        gen: the dataset's generator config (``robot``, ``image_size``, ``control_dt``, ``substeps``).
        seed, eval_s: the run's seed and wall time (s) so far.
        n_videos: episodes per method with a video; ``frame_every``: keep every this many steps.
        video_size: third-person view (width, height), px.
    """
    from lfd.io.video import write_mp4
    from lfd.robots import load_robot
    from lfd.sim.camera import third_person_camera
    from lfd.sim.scene import ReachScene

    out_dir = Path(out_dir)
    n_all = sum(len(t) for t in traces.values())
    written: dict[str, Path] = {}
    camera = third_person_camera(*video_size)
    scene = None
    try:
        for method, method_traces in traces.items():
            mine = [r for r in rows if r["method"] == method]
            folder = out_dir / method
            videos = []
            for i in range(min(n_videos, len(cases))):
                if scene is None:
                    scene = ReachScene(
                        load_robot(gen.robot),
                        image_size=gen.image_size,
                        control_dt=gen.control_dt,
                        substeps=gen.substeps,
                    )
                frames = render_rollout(scene, cases[i], method_traces[i], camera, frame_every)
                path = write_mp4(
                    folder / "videos" / f"eval_episode_{i}.mp4",
                    frames,
                    fps=1.0 / (gen.control_dt * frame_every),
                )
                videos.append(str(path))
            info = eval_info(
                mine,
                cases,
                method_traces,
                seed=seed,
                eval_s=eval_s,
                n_episodes_all_methods=n_all,
                video_paths=videos,
            )
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / "eval_info.json"
            write_text_atomic(path, json.dumps(_finite(info), indent=2))
            written[method] = path
    finally:
        if scene is not None:
            scene.close()
    return written


def _finite(obj):
    """NaN -> None, so the file is strict JSON."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_finite(v) for v in obj]
    return obj
