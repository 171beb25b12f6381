"""Export a teach recording (CSV, JSON, DMP, dataset episode) and Send it to the simulated arm.

Files written by :func:`export_session` (atomically, temp file + rename):

* ``demo.csv``: header ``time,j0,...,j{n-1}``, seconds and radians, one row per recorded
  sample: the ``t, q0..qn`` columns under the names the Sawyer / PoWER tools
  read (:func:`lfd.model_reaching.demonstrations.load_demo_csv` with ``n_joints=n``).
* ``demo.json``: robot, scene, mode, collisions, counters, timings (drag latency
  median / p95, recording duration), the recording (``t``, ``q``, ``tool``), the 2-D
  waypoints and, after a Send, its errors.
* ``demo.dmp.json``: an :class:`lfd.dmp.DMP` fitted to the recording resampled on a
  uniform grid (``DMP.load`` reads it).
* ``episode.npz``: the recording as a dataset episode
  (:meth:`lfd.visuomotor.data.episodes.EpisodeRecord.load` reads it): ``t``, ``joints``,
  ``velocities``, ``ee_poses``, the DMP (``dmp_y0``, ``dmp_goal``, ``dmp_weights``,
  ``dmp_tau``), the goal centre as ``target_point`` and the goal region as a sphere
  "object" (``object_shape="sphere"``, ``object_dims=(radius,)``, ``placement=(x, y, 0)``).

**DMP formulation.** A path over an obstacle lifts joints and puts them back, so a
joint can end where it started. The classic forcing term scales with ``g - y0`` and
cannot represent that joint; the export asks :class:`lfd.dmp.DMP` explicitly for
Pastor et al.'s formulation (:data:`RETURNING_FORMULATION`), whose forcing term does
not vanish at ``g == y0``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from lfd.dmp import DMP
from lfd.io.files import publish_output, write_bytes_atomic, write_npz_atomic

if TYPE_CHECKING:
    from lfd.sim.tracking import TrackedPath


__all__ = [
    "RETURNING_FORMULATION",
    "SendResult",
    "dmp_options",
    "export_new_folder",
    "export_session",
    "fit_recording_dmp",
    "send_session",
]

#: DMP formulation used for exported demonstrations, when lfd.dmp.DMP supports one.
RETURNING_FORMULATION = "pastor"


def dmp_options() -> dict:
    """Constructor options of :class:`lfd.dmp.DMP` for teach demonstrations."""
    return {"formulation": RETURNING_FORMULATION}


def _uniform(rec, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    grid = np.linspace(rec.t[0], rec.t[-1], n_samples)
    q = np.stack([np.interp(grid, rec.t, rec.q[:, j]) for j in range(rec.q.shape[1])], axis=1)
    return grid - grid[0], q


def fit_recording_dmp(rec, n_samples: int = 200, n_basis: int = 30) -> DMP:
    """A :class:`lfd.dmp.DMP` (``n_basis`` per joint) fitted to ``rec`` resampled at
    ``n_samples`` uniform times. Raises ``ValueError`` with fewer than 3 samples."""
    if len(rec) < 3:
        raise ValueError(
            f"the recording has {len(rec)} sample(s); drag (or store waypoints) first: at least 3 needed"
        )
    t, q = _uniform(rec, n_samples)
    return DMP(n_basis=n_basis, **dmp_options()).fit(t, q)


def _csv_text(t: np.ndarray, q: np.ndarray) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["time", *(f"j{j}" for j in range(q.shape[1]))])
    for ti, qi in zip(t, q, strict=True):
        w.writerow([repr(float(ti)), *(repr(float(x)) for x in qi)])
    return buf.getvalue()


def export_session(session, out_dir) -> dict:
    """Write the four files (module docstring) for ``session`` into ``out_dir``.

    Returns:
        ``{"csv": Path, "json": Path, "dmp": Path, "episode": Path}``.

    Raises:
        ValueError: fewer than 3 recorded samples.
        FileExistsError: ``out_dir`` already holds one of the four files (nothing is overwritten;
            :func:`export_new_folder` makes a new folder per export).
    """
    rec, raw = session.recorded, session.recorded_raw
    dmp = fit_recording_dmp(rec)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {
        k: out / name
        for k, name in (
            ("csv", "demo.csv"),
            ("json", "demo.json"),
            ("dmp", "demo.dmp.json"),
            ("episode", "episode.npz"),
        )
    }
    taken = [p.name for p in paths.values() if p.exists() or p.is_symlink()]
    if taken:
        raise FileExistsError(
            f"teach export: {out} already holds {', '.join(taken)}; lfd does not overwrite files: "
            "choose a new folder"
        )
    write_bytes_atomic(paths["csv"], _csv_text(rec.t, rec.q).encode())
    dmp.save(paths["dmp"])
    info = session.summary()
    info.update(
        {
            "format": "lfd-teach-demonstration",
            "format_version": 1,
            "units": {"t": "s", "q": "rad", "tool": "m"},
            "joint_names": list(session.robot.spec.joint_names),
            "scene": session.scene.to_dict(),
            "start": session.start.tolist(),
            "timings": {
                "duration_s": float(rec.t[-1] - rec.t[0]),
                "drag_latency_median_ms": info.pop("latency_median_ms"),
                "drag_latency_p95_ms": info.pop("latency_p95_ms"),
                "drag_updates": session.counters["drag_updates"],
            },
            "recording": {"t": rec.t.tolist(), "q": rec.q.tolist(), "tool": rec.tool.tolist()},
            "recording_raw": {"t": raw.t.tolist(), "q": raw.q.tolist()},
            "path_length_m": rec.path_length,
            "waypoints": session.waypoints.tolist(),
            "dmp": {"file": paths["dmp"].name, "n_basis": dmp.n_basis, **dmp_options()},
            "files": {k: p.name for k, p in paths.items()},
        }
    )
    if session.last_send is not None:
        info["send"] = session.last_send.to_dict()
    write_bytes_atomic(paths["json"], json.dumps(info, indent=1).encode())
    write_npz_atomic(paths["episode"], _episode_arrays(session, rec, dmp))
    return paths


#: Kind recorded in the export marker of a teach export folder (:func:`lfd.io.files.publish_output`).
EXPORT_KIND = "teach-demonstration"


def export_new_folder(session, export_dir, now: float | None = None) -> dict:
    """Export ``session`` (:func:`export_session`) into a new folder of ``export_dir`` named
    ``demo-YYYYmmdd-HHMMSS`` (local time ``now``, default the current time), with ``-2``,
    ``-3``, ... appended when that name is taken: nothing already there is overwritten. The
    folder is written beside its final place and renamed into it when complete
    (:func:`lfd.io.files.publish_output`).

    Returns:
        the paths of :func:`export_session`, in the new folder.

    Raises:
        ValueError: fewer than 3 recorded samples (nothing is created).
        OSError: ``export_dir`` cannot be created or written (e.g. it is a file).
    """
    fit_recording_dmp(session.recorded)  # refuse a too-short recording before creating anything
    root = Path(export_dir)
    if root.exists() and not root.is_dir():
        raise NotADirectoryError(f"teach export: export_dir {root} is a file, not a folder")
    root.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("demo-%Y%m%d-%H%M%S", time.localtime(now))
    for k in range(1, 10_000):
        target = root / (stamp if k == 1 else f"{stamp}-{k}")
        if target.exists() or target.is_symlink():
            continue
        try:
            with publish_output(target, EXPORT_KIND, who="teach export") as folder:
                paths = export_session(session, folder)
        except FileExistsError:  # taken between the check and the publication
            continue
        return {key: target / p.name for key, p in paths.items()}
    raise FileExistsError(f"teach export: no free folder name for {root / stamp}")


def _episode_arrays(session, rec, dmp: DMP) -> dict:
    t, q = _uniform(rec, max(len(rec), 3))
    frames = np.array([session.kin.frames(x)[-1] for x in q])
    goal = session.scene.goal
    target = goal.center if goal is not None else rec.tool[-1]
    radius = goal.radius if goal is not None else 0.01
    return {
        "index": np.array(0),
        "object_index": np.array(0),
        "object_group": np.array("train"),  # dataset format 2: the object group of the split keys
        "placement_index": np.array(0),
        "split": np.array("train"),
        "object_name": np.array(f"teach-goal-{session.scene.name}"),
        "object_shape": np.array("sphere"),
        "object_dims": np.array([radius]),
        "object_rgba": np.array([0.2, 0.8, 0.2, 0.4]),
        "object_mass": np.array(0.1),  # nominal: the goal region is a marker, not a body
        "placement": np.array([target[0], target[1], 0.0]),
        "approach_mode": np.array("teach"),
        "target_point": np.asarray(target, dtype=float),
        "t": t,
        "joints": q,
        "velocities": np.gradient(q, t, axis=0),
        "ee_poses": frames,
        "final_error": np.array(float(np.linalg.norm(frames[-1, :3, 3] - target))),
        "dmp_y0": np.asarray(dmp.y0_),
        "dmp_goal": np.asarray(dmp.goal_),
        "dmp_weights": np.asarray(dmp.weights_),
        "dmp_tau": np.array(float(dmp.tau_)),
        "discarded": np.zeros(4, dtype=np.int64),
        "discard_reasons": np.array(["ik_failed", "table_collision", "object_collision", "tracking_error"]),
        "robot": np.array(session.robot_name),
        "collisions": np.array(session.collisions),
    }


def _path_deviation(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """(P,) distance (m) from each point to the polyline ``path`` (M, 3)."""
    if len(path) == 1:
        return np.linalg.norm(points - path[0], axis=1)
    a, b = path[:-1], path[1:]
    ab = b - a
    denom = np.maximum((ab * ab).sum(1), 1e-18)
    s = np.clip(((points[:, None, :] - a[None]) * ab[None]).sum(-1) / denom[None], 0.0, 1.0)
    closest = a[None] + s[..., None] * ab[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=-1).min(axis=1)


@dataclass(frozen=True)
class SendResult:
    """A Send: the DMP's plan and what the simulated arm did.

    Attributes:
        plan_t, plan_q: (T,) s and (T, n) rad, the DMP rollout that was commanded.
        executed: the :class:`~lfd.sim.tracking.TrackedPath` from PyBullet
            (:func:`lfd.sim.tracking.execute_joint_trajectory`).
        demo_tool: (N, 3) m, the recorded tool path.
        final_error: m, executed final tool position (after settling) to the recorded end.
        max_path_deviation: m, largest distance of the executed tool path from the
            recorded one (nearest point on the polyline).
    """

    plan_t: np.ndarray
    plan_q: np.ndarray
    executed: TrackedPath
    demo_tool: np.ndarray
    final_error: float
    max_path_deviation: float

    def to_dict(self) -> dict:
        return {
            "final_error_m": self.final_error,
            "max_path_deviation_m": self.max_path_deviation,
            "clipped_samples": self.executed.clipped_samples,
            "executed_tool": self.executed.tool.tolist(),
        }


def send_session(session) -> SendResult:
    """Fit the DMP to the recording and run its rollout on the simulated arm."""
    from lfd.sim.tracking import execute_joint_trajectory

    rec = session.recorded
    dmp = fit_recording_dmp(rec)
    plan_t = np.linspace(0.0, float(dmp.tau_), dmp.n_steps_)
    plan_q = np.asarray(dmp.rollout(), dtype=float)
    run = execute_joint_trajectory(session.robot, plan_t, plan_q)
    final = float(np.linalg.norm(run.tool_final - rec.tool[-1]))
    deviation = float(_path_deviation(np.vstack([run.tool, run.tool_final[None]]), rec.tool).max())
    if not math.isfinite(final):
        raise ValueError("the simulated execution produced a non-finite tool position")
    return SendResult(plan_t, plan_q, run, rec.tool, final, deviation)
