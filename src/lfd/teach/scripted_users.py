"""Scripted users and seeded task layouts for comparing the 3-D and the 2-D interface.

A *task* (``make_task(seed)``): the WAM on a table, the tool starting on one side of a
wall and a goal region on the other side; wall position, thickness and height, start
and goal are drawn from ``numpy.random.default_rng(seed)``. Each task also draws the
user's *clearance misjudgment*: how far above the wall top the user first aims (0 to
8 cm, so some first attempts clip the wall). Every user below gets the same layout and
the same misjudgment, and the same plan: lift above the wall, cross over, go down into
the goal. When the interface refuses a move because of a collision, the user raises the
clearance by 5 cm and continues from where the arm stopped (lifting first).

* :func:`run_drag_user` (3-D mode): each straight stretch towards the next via point is
  one *drag segment* (press, move, release) sent as gizmo updates every 1.5 cm.
* :func:`run_xyz_user` (2-D panel, x/y/z entry): per via point it types the three
  numbers (keystrokes: the characters plus one Tab/Enter per field), clicks "Move (IK)"
  and then "Store".
* :func:`run_slider_user` (2-D panel, joint sliders): per via point it moves one joint
  slider at a time to the via point's joint angle (as if it could read them off; a
  generous model), trying another joint first when a slider move is refused, then
  clicks "Store".

A user gives up after ``max_actions`` actions. Counting actions is exact; any time per
task is a *model* (:func:`klm_seconds`, a keystroke-level model), not a measurement.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from .session import TeachSession

__all__ = [
    "KLM",
    "Task",
    "UserRun",
    "klm_seconds",
    "make_task",
    "run_drag_user",
    "run_slider_user",
    "run_xyz_user",
]

TABLE_Z = -0.10
CLEARANCE_STEP = 0.05  # m the user adds after a refused move
DRAG_UPDATE = 0.015  # m of gizmo motion between two drag updates

#: Keystroke-level model operators (Card, Moran & Newell 1980), seconds: K keystroke
#: (average typist), P point with the mouse, B mouse button press or release, H move the
#: hand between mouse and keyboard, M mental preparation.
KLM = {"K": 0.28, "P": 1.1, "B": 0.1, "H": 0.4, "M": 1.35}


@dataclass(frozen=True)
class Task:
    """A seeded layout: ``scene`` (dict for :class:`TeachSession`), the wall top height
    (m), and the user's first clearance above it (m)."""

    seed: int
    scene: dict
    wall_top: float
    clearance: float


@dataclass
class UserRun:
    """One scripted user on one task: success, collisions, recorded tool path length
    (m) and the actions by kind (``drag_segments``, ``slider_moves``, ``clicks``,
    ``keystrokes``, ``field_entries``)."""

    user: str
    seed: int
    success: bool
    collisions: int
    path_length: float
    actions: Counter = field(default_factory=Counter)

    @property
    def n_actions(self) -> int:
        """Drag segments + slider moves + clicks + keystrokes."""
        return sum(self.actions[k] for k in ("drag_segments", "slider_moves", "clicks", "keystrokes"))


def klm_seconds(run: UserRun) -> float:
    """Keystroke-level-model time estimate of ``run`` (a model, not a measurement).

    * drag segment or slider move: M + P + B + P + B (decide, point at the handle,
      press, move to the target, release) = 3.75 s;
    * click: M + P + B + B = 2.65 s;
    * typed field: H (hand to the keyboard, back counted in the next pointing) + one
      K per keystroke (the characters and the Tab/Enter).
    """
    k = KLM
    gesture = k["M"] + 2 * k["P"] + 2 * k["B"]
    click = k["M"] + k["P"] + 2 * k["B"]
    a = run.actions
    return (
        (a["drag_segments"] + a["slider_moves"]) * gesture
        + a["clicks"] * click
        + a["field_entries"] * k["H"] / 3.0
        + a["keystrokes"] * k["K"]
    )


def make_task(seed: int, robot: str = "wam4") -> Task:
    """The seeded layout ``seed`` (see the module docstring); resamples until the scene
    is valid (start collision-free, goal reachable, nothing overlapping the base)."""
    rng = np.random.default_rng(seed)
    probe = TeachSession(robot=robot, scene=None, validate=False)
    try:
        for _ in range(200):
            height = rng.uniform(0.20, 0.38)
            thick = rng.uniform(0.04, 0.10)
            wall = {
                "center": [rng.uniform(0.45, 0.55), rng.uniform(-0.04, 0.04), TABLE_Z + height / 2],
                "size": [0.30, thick, height],
                "yaw_deg": float(rng.uniform(-15, 15)),
            }
            start_p = np.array([rng.uniform(0.38, 0.55), rng.uniform(-0.45, -0.28), rng.uniform(0.03, 0.15)])
            goal_p = np.array([rng.uniform(0.38, 0.55), rng.uniform(0.28, 0.45), rng.uniform(0.03, 0.15)])
            step = probe.ik.solve(probe.robot.home.numpy(), start_p)
            if not step.reached:
                continue
            scene = {
                "start": step.q.tolist(),
                "table_z": TABLE_Z,
                "obstacles": [wall],
                "goal": {"center": goal_p.tolist(), "radius": 0.05},
                "name": f"task{seed}",
            }
            try:
                TeachSession(robot=robot, scene=scene).close()
            except ValueError:
                continue
            return Task(seed, scene, TABLE_Z + height, float(rng.uniform(0.0, 0.08)))
    finally:
        probe.close()
    raise RuntimeError(f"no valid layout for seed {seed}")


def _plan(pos: np.ndarray, goal: np.ndarray, height: float) -> list[np.ndarray]:
    """Via points from ``pos``: straight up to ``height``, across above the goal, down into it."""
    return [
        np.array([pos[0], pos[1], max(height, pos[2])]),
        np.array([goal[0], goal[1], max(height, pos[2])]),
        goal.copy(),
    ]


def _start(task: Task, mode: str, robot: str) -> tuple[TeachSession, np.ndarray, float, list[np.ndarray]]:
    """A session on ``task`` in ``mode``, the goal centre, the first aimed height and plan."""
    s = TeachSession(robot=robot, scene=task.scene, mode=mode, clock=_Clock())
    goal = np.asarray(task.scene["goal"]["center"], float)
    height = task.wall_top + task.clearance
    return s, goal, height, _plan(s.tool_position, goal, height)


def _finish(user: str, task: Task, s: TeachSession, actions: Counter) -> UserRun:
    rec = s.recorded
    ok = s.recording_state == "done" and s.end_reason == "goal"
    run = UserRun(user, task.seed, ok, s.collisions, rec.path_length if len(rec) else 0.0, actions)
    s.close()
    return run


def run_drag_user(task: Task, max_actions: int = 40, robot: str = "wam4") -> UserRun:
    """The 3-D user (see the module docstring)."""
    s, goal, height, via = _start(task, "3d", robot)
    actions: Counter = Counter()
    i = 0
    while s.recording_state != "done" and actions["drag_segments"] < max_actions and i < len(via):
        actions["drag_segments"] += 1
        p0, target = s.tool_position, via[i]
        n = max(1, math.ceil(np.linalg.norm(target - p0) / DRAG_UPDATE))
        refused = None
        for k in range(1, n + 1):
            r = s.drag(p0 + (target - p0) * k / n)
            if s.recording_state == "done":
                break
            if not r.accepted:
                refused = r
                break
        if refused is None:
            i += 1
        else:  # release, lift higher, carry on from here
            height = (height if refused.in_collision else s.tool_position[2]) + CLEARANCE_STEP
            via, i = _plan(s.tool_position, goal, height), 0
    return _finish("3-D drag", task, s, actions)


def _type_xyz(actions: Counter, p: np.ndarray) -> None:
    for v in p:
        actions["keystrokes"] += len(f"{v:.2f}") + 1  # the digits + Tab/Enter
        actions["field_entries"] += 1


def run_xyz_user(task: Task, max_actions: int = 120, robot: str = "wam4") -> UserRun:
    """The 2-D panel user with the x/y/z entry (see the module docstring)."""
    s, goal, height, via = _start(task, "2d", robot)
    actions: Counter = Counter()
    i = 0
    while (
        s.recording_state != "done"
        and sum(actions[k] for k in ("clicks", "keystrokes")) < max_actions
        and i < len(via)
    ):
        _type_xyz(actions, via[i])
        actions["clicks"] += 1  # Move (IK)
        r = s.move_to(np.round(via[i], 2))
        if r.accepted:
            actions["clicks"] += 1  # Store
            if s.store():
                i += 1
                continue
        height = (height if (r.in_collision or r.accepted) else s.tool_position[2]) + CLEARANCE_STEP
        via, i = _plan(s.tool_position, goal, height), 0
    return _finish("2-D x/y/z entry", task, s, actions)


def run_slider_user(task: Task, max_actions: int = 60, robot: str = "wam4") -> UserRun:
    """The 2-D panel user with the joint sliders (see the module docstring)."""
    s, goal, height, via = _start(task, "2d", robot)
    actions: Counter = Counter()
    i = 0
    total = lambda: actions["slider_moves"] + actions["clicks"]  # noqa: E731
    while s.recording_state != "done" and total() < max_actions and i < len(via):
        step = s.ik.solve(s.q, via[i])
        if not step.reached:  # the generous user reads off an IK solution from anywhere
            res = s.robot.ik(via[i][None], s.q[None], restarts=16)
            target_q = res.q[0].numpy()
        else:
            target_q = step.q
        pending = [j for j in range(s.n_dof) if abs(target_q[j] - s.q[j]) > 0.01]
        stuck = False
        while pending and total() < max_actions:
            for j in list(pending):
                q = s.q.copy()
                q[j] = round(float(target_q[j]), 2)  # slider step 0.01 rad
                actions["slider_moves"] += 1
                if s.set_joints(q).accepted:
                    pending.remove(j)
                    break
            else:
                stuck = True
                break
        if not stuck and not pending:
            actions["clicks"] += 1  # Store
            if s.store():
                i += 1
                continue
        height += CLEARANCE_STEP
        via, i = _plan(s.tool_position, goal, height), 0
    return _finish("2-D joint sliders", task, s, actions)


class _Clock:
    """Simulated clock for scripted users: 1/30 s per call (a 30 Hz update stream)."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        self.t += 1.0 / 30.0
        return self.t
