"""Export a teach recording (CSV, JSON, DMP, dataset episode) and Send it to the simulated arm.

Files written by :func:`export_session` (atomically, temp file + rename):

* ``demo.csv``: header ``time,j0,...,j{n-1}``, seconds and radians, one row per sample of the
  idle-trimmed recording (with nothing recorded: of the motion through the keyframes): the
  ``t, q0..qn`` columns under the names the Sawyer / PoWER tools
  read (:func:`lfd.model_reaching.demonstrations.load_demo_csv` with ``n_joints=n``).
* ``demo.json``: robot, scene, mode, collisions, counters, timings (drag latency
  median / p95, recording duration), the recording (``t``, ``q``, ``tool``; idle-trimmed),
  ``recording_raw`` (``t``, ``q`` as the clock stamped them), the 2-D waypoints, the keyframes
  (``q``, ``anchor``: raw sample index or null, ``t``: s of the motion), the gripper events
  (``t`` s of the motion, ``closed``), ``speed``, ``target_point`` and, after a Send, its errors.
  :meth:`lfd.teach.session.TeachSession.reopen` reads it back.
* ``demo.dmp.json``: the skill: the :class:`lfd.dmp.DMP` of :func:`lfd.teach.motion.plan_skill`
  (fitted to the trimmed recording, conditioned through the keyframes, ``tau_`` = duration / speed;
  ``DMP.load`` reads it, ``rollout()`` passes every keyframe at one of its samples).
* ``episode.npz``: the motion as a dataset episode
  (:meth:`lfd.visuomotor.data.episodes.EpisodeRecord.load` reads it): ``t``, ``joints``,
  ``velocities``, ``ee_poses`` of the DMP's rollout, the DMP (``dmp_y0``, ``dmp_goal``,
  ``dmp_weights``, ``dmp_tau``), ``target_point``, ``final_error``, the gripper (``gripper`` (T,)
  0 open / 1 closed, ``gripper_event_t``, ``gripper_event_closed``), ``speed``, ``keyframes``
  (K, n) and ``keyframe_t`` (K,) s, and the goal region (or, without one, a 1 cm sphere at the
  target point) as a sphere "object" (``object_shape="sphere"``, ``object_dims=(radius,)``,
  ``placement=(x, y, 0)``).

**Final error, one meaning.** ``target_point`` is the tool position of the skill's goal
configuration (``dmp.goal_``: the last sample of the trimmed recording, or the last keyframe when
it ends the motion). ``final_error`` (m) is the distance from the tool's final position to it:
in ``episode.npz`` of the planned motion (the DMP rollout, as the dataset's expert episodes
measure their final tool pose), in Send (:class:`SendResult`, ``demo.json``'s ``send``) of the
arm simulated in PyBullet after settling.

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

from lfd.checks import check_float
from lfd.dmp import DMP
from lfd.io.files import publish_output, write_bytes_atomic, write_npz_atomic

from .checks import check_vector
from .gripper import GripperEvent, gripper_state
from .keyframes import Keyframe

if TYPE_CHECKING:
    from lfd.sim.tracking import TrackedPath


__all__ = [
    "MAX_DEMO_JSON_BYTES",
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
#: The largest ``demo.json`` :func:`read_export` reads (bytes): 64 MiB, hours of dragging at 30 Hz.
MAX_DEMO_JSON_BYTES = 64 << 20
#: ``format`` of a teach ``demo.json``.
DEMO_FORMAT = "lfd-teach-demonstration"


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
        ValueError: nothing to export (fewer than 3 recorded samples and fewer than 2 keyframes).
        FileExistsError: ``out_dir`` already holds one of the four files (nothing is overwritten;
            :func:`export_new_folder` makes a new folder per export).
    """
    rec, raw = session.recorded, session.recorded_raw
    skill = session.skill()
    dmp = skill.dmp
    if len(rec) < 3:  # keyframes alone: the motion is the demonstration
        motion = session.motion(int(dmp.n_steps_))
        rec = type(rec)(motion.t, motion.q, motion.tool)
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
            "format": DEMO_FORMAT,
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
            "keyframes": {
                "q": session.keyframes.tolist(),
                "anchor": [kf.anchor for kf in session._keyframes],
                "t": skill.via_t.tolist(),
            },
            "gripper_events": [{"t": e.t, "closed": e.closed} for e in session.gripper_events],
            "speed": session.speed,
            "target_point": target_point(session, dmp).tolist(),
            "motion": {"source": skill.source, "duration_s": float(dmp.tau_)},
            "dmp": {"file": paths["dmp"].name, "n_basis": dmp.n_basis, **dmp_options()},
            "files": {k: p.name for k, p in paths.items()},
        }
    )
    if session.last_send is not None:
        info["send"] = session.last_send.to_dict()
    write_bytes_atomic(paths["json"], json.dumps(info, indent=1).encode())
    write_npz_atomic(paths["episode"], _episode_arrays(session, skill))
    return paths


def target_point(session, dmp: DMP) -> np.ndarray:
    """(3,) m: the tool position of the skill's goal configuration ``dmp.goal_`` (module docstring)."""
    return session.kin.tool_position(np.asarray(dmp.goal_, dtype=float))


def read_export(export_dir) -> dict:
    """The ``demo.json`` of a teach export folder, checked to be one lfd wrote.

    Raises:
        FileNotFoundError: no ``demo.json`` in ``export_dir``.
        ValueError: larger than :data:`MAX_DEMO_JSON_BYTES`, not UTF-8 JSON, nested too deep, or not a
            teach demonstration of a known format version (one line naming the file).
    """
    path = Path(export_dir) / "demo.json"
    if not path.is_file():
        raise FileNotFoundError(f"teach reopen: no demo.json in {export_dir} (choose a folder Export wrote)")
    with path.open("rb") as file:
        data = file.read(MAX_DEMO_JSON_BYTES + 1)
    if len(data) > MAX_DEMO_JSON_BYTES:
        raise ValueError(f"{path}: more than the {MAX_DEMO_JSON_BYTES >> 20} MiB a teach demo.json may have")
    try:
        info = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a teach demo.json (not valid UTF-8 JSON: {exc})") from None
    except RecursionError:
        raise ValueError(f"{path}: not a teach demo.json (nested too deep)") from None
    if not isinstance(info, dict) or info.get("format") != DEMO_FORMAT:
        found = info.get("format") if isinstance(info, dict) else type(info).__name__
        raise ValueError(
            f"{path}: not a teach demonstration lfd wrote (format {found!r}, expected {DEMO_FORMAT!r})"
        )
    if info.get("format_version") != 1:
        raise ValueError(f"{path}: unsupported format_version {info.get('format_version')!r}, expected 1")
    return info


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
        ValueError: nothing to export (fewer than 3 recorded samples and fewer than 2 keyframes; nothing
            is created).
        OSError: ``export_dir`` cannot be created or written (e.g. it is a file).
    """
    session.skill()  # refuse when there is nothing to export before creating anything
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


def _episode_arrays(session, skill) -> dict:
    dmp = skill.dmp
    t = np.linspace(0.0, float(dmp.tau_), int(dmp.n_steps_))
    q = np.asarray(dmp.rollout(), dtype=float)
    frames = np.array([session.kin.frames(x)[-1] for x in q])
    target = target_point(session, dmp)
    goal = session.scene.goal
    marker = goal.center if goal is not None else target
    radius = goal.radius if goal is not None else 0.01
    events = session.gripper_events
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
        "placement": np.array([marker[0], marker[1], 0.0]),
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
        "gripper": gripper_state(events, t),
        "gripper_event_t": np.array([e.t for e in events], dtype=float),
        "gripper_event_closed": np.array([e.closed for e in events], dtype=bool),
        "speed": np.array(float(session.speed)),
        "keyframes": session.keyframes,
        "keyframe_t": skill.via_t,
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
        demo_tool: (N, 3) m, the recorded tool path (trimmed; the motion's when nothing was recorded).
        final_error: m, executed final tool position (after settling) to the target point (the tool
            position of the skill's goal configuration; the same meaning as ``episode.npz``'s
            ``final_error``, module docstring).
        max_path_deviation: m, largest distance of the executed tool path from the
            planned one (the motion's tool path, nearest point on the polyline).
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
    """Run the session's motion (:meth:`~lfd.teach.session.TeachSession.skill`'s DMP rollout, at its speed)
    on the simulated arm. Raises ``ValueError`` when there is nothing to plan."""
    from lfd.sim.tracking import execute_joint_trajectory

    dmp = session.skill().dmp
    plan_t = np.linspace(0.0, float(dmp.tau_), dmp.n_steps_)
    plan_q = np.asarray(dmp.rollout(), dtype=float)
    plan_tool = np.array([session.kin.tool_position(q) for q in plan_q])
    rec = session.recorded
    demo_tool = rec.tool if len(rec) >= 3 else plan_tool
    run = execute_joint_trajectory(session.robot, plan_t, plan_q)
    final = float(np.linalg.norm(run.tool_final - target_point(session, dmp)))
    deviation = float(_path_deviation(np.vstack([run.tool, run.tool_final[None]]), plan_tool).max())
    if not math.isfinite(final):
        raise ValueError("the simulated execution produced a non-finite tool position")
    return SendResult(plan_t, plan_q, run, demo_tool, final, deviation)


def reopen_session(cls, export_dir, **settings_overrides):
    """The :class:`~lfd.teach.session.TeachSession` (``cls``) continuing the export folder ``export_dir``
    (:meth:`TeachSession.reopen <lfd.teach.session.TeachSession.reopen>` documents the contract)."""
    info = read_export(export_dir)
    where = f"{export_dir}/demo.json"

    def field(name, kind):
        value = info.get(name)
        if not isinstance(value, kind):
            raise ValueError(f"{where}: field '{name}' is missing or not a {getattr(kind, '__name__', kind)}")
        return value

    options = {"mode": field("mode", str), **settings_overrides}
    try:
        session = cls(field("robot", str), field("scene", dict), **options)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    try:
        if "recording_raw" in info:
            rec = field("recording_raw", dict)
        else:
            rec = field("recording", dict)
        waypoints = info.get("waypoints", [])
        if info.get("end_reason") not in (None, "goal", "stop"):
            raise ValueError(f"field 'end_reason' must be goal, stop or null, got {info.get('end_reason')!r}")
        session.recorder.restore(
            info["mode"] if rec.get("t") or waypoints else "idle",
            rec.get("t", []),
            rec.get("q", []),
            waypoints,
            info.get("end_reason"),
        )
        keys = field("keyframes", dict)
        kq, anchors = keys.get("q", []), keys.get("anchor", [])
        if not isinstance(kq, list) or not isinstance(anchors, list) or len(anchors) != len(kq):
            raise ValueError("field 'keyframes': q and anchor must be lists of one length")
        raw = session.recorder.samples if session.recorder.mode == "3d" else 0
        for q, a in zip(kq, anchors, strict=True):
            q = check_vector(q, session.n_dof, "keyframes.q")
            if a is not None and (isinstance(a, bool) or not isinstance(a, int) or not 0 <= a < raw):
                raise ValueError(
                    f"field 'keyframes.anchor': {a!r} is not a recording sample index (0..{raw - 1})"
                )
            session._keyframes.append(Keyframe(q, a))
        session.speed = field("speed", (int, float))
        for e in field("gripper_events", list):
            if not isinstance(e, dict) or not isinstance(e.get("closed"), bool):
                raise ValueError("field 'gripper_events': each must be {t: seconds, closed: true|false}")
            t = check_float(e.get("t"), "gripper_events.t", low=0.0)
            session._gripper.append(GripperEvent(t * session.speed, e["closed"]))
        session._gripper.sort(key=lambda e: e.t)
    except (ValueError, TypeError) as exc:
        session.close()
        raise ValueError(f"{where}: {exc}") from None
    session._edits += 1
    return session
