"""Demonstrations of the Sawyer tasks and the inverse-model data built from them (thesis ch. 5).

One demonstration per task (scripted -- IK of the demonstration goal + a quintic in joint
space -- or recorded, :func:`load_demo_csv`) plus, for nearby goals, third/fifth-order
polynomial warps of it (:func:`lfd.sim.trajectory.warp_to_goals`) and straight joint-space
paths into each goal from another goal (:func:`build_inverse_data`, settings in
:class:`InverseDataConfig`). Each path is followed with *exponential progress*
(:func:`lfd.sim.trajectory.follow_paths`): the commanded joint velocity is the path tangent
times the remaining fraction of the path over a time constant. A rest-to-rest timing would
pair the largest Cartesian errors (at the start) with zero velocity, and the learned error ->
velocity map would never leave the start pose in closed loop; with exponential progress, and
paths arriving from several directions, the map is a convergent feedback law. Training pairs
are ``(x_e(t) - goal, qd(t))`` with ``x_e`` from forward kinematics.

Units: metres, radians, seconds. Orientations are roll-pitch-yaw in degrees at the edges
(configs), i.e. extrinsic x-y-z rotations ``R = Rz(yaw) Ry(pitch) Rx(roll)``, converted once
(:func:`lfd.robots.make_transform`). No PyBullet and no Lightning here (torch for the robot model).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import torch

from lfd.robots import make_transform, solve_near
from lfd.sim.trajectory import follow_paths, via_quintic, warp_to_goals

__all__ = [
    "DEMO_GOAL",
    "SAWYER_START_DEG",
    "TASK_ORIENTATIONS_DEG",
    "DemoFileError",
    "InverseData",
    "InverseDataConfig",
    "JointDemonstration",
    "build_inverse_data",
    "load_demo_csv",
    "make_demonstration",
    "scripted_demo",
]

#: Start pose of the original experiments (deg), joints j0..j6.
SAWYER_START_DEG = (0.0, -50.0, 0.0, 120.0, 0.0, 0.0, 0.0)
#: Goal of the original demonstration (m), Sawyer world frame.
DEMO_GOAL = (0.035, -0.573, -0.04)
#: End-effector orientations (roll, pitch, yaw in deg) of the original tasks.
TASK_ORIENTATIONS_DEG = {"cube": (180.0, 0.0, 90.0), "cup": (-135.0, -90.0, 135.0)}


# ---------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class InverseDataConfig:
    """Everything that determines one task's inverse-model data (besides the task's
    orientation or recorded file), like :class:`lfd.visuomotor.data.GeneratorConfig` for the reaching data.

    Attributes:
        start_deg: start pose of the scripted demonstration (deg, one per joint).
        demo_goal: goal of the scripted demonstration (m, robot world frame).
        duration: scripted demonstration length (s).
        n_demo_steps: samples of the demonstration (a recorded one is resampled to them).
        n_goals: augmentation goals drawn around the demonstration's end point.
        goal_spread: half-widths (m) of the goal box, x, y, z.
        orders: polynomial blend orders (3 or 5) of the warps, cycled over the goals.
        cross_paths: straight joint-space paths into each goal from other goals.
        time_constant: seconds of exponential progress along each path.
        dt: seconds between training samples; n_steps: samples per path.
        n_seeds: IK seeds per augmentation goal (:func:`lfd.robots.solve_near`).
        seed: seed of the goals, the IK seeds, the cross paths and the train/val split.
    """

    start_deg: tuple[float, ...] = SAWYER_START_DEG
    demo_goal: tuple[float, float, float] = DEMO_GOAL
    duration: float = 4.0
    n_demo_steps: int = 100
    n_goals: int = 125
    goal_spread: tuple[float, float, float] = (0.25, 0.15, 0.05)
    orders: tuple[int, ...] = (3, 5)
    cross_paths: int = 1
    time_constant: float = 1.5
    dt: float = 0.075
    n_steps: int = 100
    n_seeds: int = 8
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("start_deg", "demo_goal", "goal_spread", "orders"):
            object.__setattr__(self, name, tuple(getattr(self, name)))
        if len(self.demo_goal) != 3 or len(self.goal_spread) != 3 or min(self.goal_spread) < 0:
            raise ValueError(
                "InverseDataConfig: demo_goal and goal_spread need 3 values (m, spread >= 0), got "
                f"{self.demo_goal}, {self.goal_spread}"
            )
        if not self.orders or set(self.orders) - {3, 5}:
            raise ValueError(f"InverseDataConfig.orders: expected blend orders 3 and/or 5, got {self.orders}")
        for name in ("duration", "time_constant", "dt"):
            if not getattr(self, name) > 0:
                raise ValueError(
                    f"InverseDataConfig.{name}: expected seconds > 0, got {getattr(self, name)!r}"
                )
        for name, low in (
            ("n_demo_steps", 3),
            ("n_goals", 0),
            ("cross_paths", 0),
            ("n_steps", 2),
            ("n_seeds", 1),
        ):
            if int(getattr(self, name)) < low:
                raise ValueError(
                    f"InverseDataConfig.{name}: expected an int >= {low}, got {getattr(self, name)!r}"
                )

    @classmethod
    def from_mapping(cls, values: Mapping | InverseDataConfig | None) -> InverseDataConfig:
        """A config from a mapping of its fields (e.g. a Hydra node); unknown keys raise ``ValueError``."""
        if isinstance(values, cls):
            return values
        values = dict(values or {})
        unknown = sorted(set(values) - {f.name for f in fields(cls)})
        if unknown:
            raise ValueError(
                f"InverseDataConfig: unknown field(s) {unknown}; expected some of {[f.name for f in fields(cls)]}"
            )
        return cls(**values)


# ---------------------------------------------------------------------------- demonstrations
@dataclass(frozen=True)
class JointDemonstration:
    """One joint-space demonstration on a uniform time grid.

    Attributes:
        t: ``(T,)`` times (s), starting at 0, uniform.
        q: ``(T, n)`` joint angles (rad).
        source: where it came from (file path or ``"scripted"``), for messages.
    """

    t: np.ndarray
    q: np.ndarray
    source: str

    @property
    def duration(self) -> float:
        return float(self.t[-1])


class DemoFileError(ValueError):
    """A demonstration file is malformed; the message names the file, line and column."""


def load_demo_csv(path: str | Path, n_joints: int = 7, n_steps: int = 100) -> JointDemonstration:
    """Read a recorded demonstration ``time, j0, ..., j{n-1}`` and resample it uniformly.

    The first non-empty line not starting with ``#`` is the header; columns may come in
    any order and extra columns are ignored. Times are seconds, strictly increasing, at
    any (even irregular) rate; joints are radians. The samples are linearly interpolated
    onto ``n_steps`` uniform times from 0 to the recorded duration.

    Raises:
        FileNotFoundError: no file at ``path``.
        DemoFileError: missing columns, a short row, a non-numeric or non-finite value,
            a time not greater than the previous one, or fewer than 3 samples; the message
            reads ``<file>:<line>: column '<name>': <problem>``.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"demonstration file not found: {path}")
    wanted = ["time", *(f"j{i}" for i in range(n_joints))]
    rows: list[list[float]] = []
    header: dict[str, int] | None = None
    last_time, last_line = -math.inf, 0
    with path.open(newline="") as f:
        for line_no, fields in enumerate(csv.reader(f), start=1):
            fields = [x.strip() for x in fields]
            if not any(fields) or fields[0].startswith("#"):
                continue
            if header is None:
                header = {name.lower(): i for i, name in enumerate(fields)}
                missing = [c for c in wanted if c not in header]
                if missing:
                    raise DemoFileError(
                        f"{path}:{line_no}: header is missing column(s) {', '.join(missing)}; expected "
                        f"{', '.join(wanted)}"
                    )
                continue
            row = []
            for name in wanted:
                col = header[name]
                if col >= len(fields) or fields[col] == "":
                    raise DemoFileError(
                        f"{path}:{line_no}: column '{name}': value missing ({len(fields)} fields in this row)"
                    )
                try:
                    value = float(fields[col])
                except ValueError:
                    raise DemoFileError(
                        f"{path}:{line_no}: column '{name}': {fields[col]!r} is not a number"
                    ) from None
                if not math.isfinite(value):
                    raise DemoFileError(f"{path}:{line_no}: column '{name}': {fields[col]!r} is not finite")
                row.append(value)
            if row[0] <= last_time:
                raise DemoFileError(
                    f"{path}:{line_no}: column 'time': {row[0]} is not greater than the previous time "
                    f"{last_time} (line {last_line})"
                )
            last_time, last_line = row[0], line_no
            rows.append(row)
    if header is None or len(rows) < 3:
        raise DemoFileError(f"{path}: need a header and at least 3 samples, got {len(rows)} sample(s)")
    data = np.array(rows)
    t = data[:, 0] - data[0, 0]
    grid = np.linspace(0.0, t[-1], n_steps)
    q = np.stack([np.interp(grid, t, data[:, 1 + j]) for j in range(n_joints)], axis=1)
    return JointDemonstration(t=grid, q=q, source=str(path))


def scripted_demo(
    robot,
    start: np.ndarray,
    goal_pose: np.ndarray,
    duration: float = 4.0,
    n_steps: int = 100,
    n_seeds: int = 64,
    seed: int = 0,
) -> JointDemonstration:
    """A demonstration from ``start (n,)`` (rad) to the IK solution of ``goal_pose (4, 4)``
    nearest the start, timed by a rest-to-rest quintic in joint space.

    Raises:
        ValueError: IK finds no solution of the goal pose within the joint limits.
    """
    solution = solve_near(robot, goal_pose[None], start, n_seeds=n_seeds, seed=seed)
    if not bool(solution.success[0]):
        raise ValueError(
            f"scripted_demo: no IK solution for the demonstration goal pose\n{np.round(goal_pose, 4)}"
        )
    t = np.linspace(0.0, duration, n_steps)
    q, _, _ = via_quintic(t, np.array([0.0, duration]), np.stack([start, solution.q[0].numpy()]))
    return JointDemonstration(t=t, q=q, source="scripted")


def make_demonstration(
    robot,
    orientation_deg: Sequence[float] | None = None,
    demo_csv: str | Path | None = None,
    config: InverseDataConfig | None = None,
) -> JointDemonstration:
    """The demonstration of one task: the CSV file if given (resampled to
    ``config.n_demo_steps``), else the scripted one from ``config.start_deg`` to
    ``config.demo_goal`` with the end-effector orientation ``orientation_deg`` (roll, pitch,
    yaw in deg).

    Raises:
        ValueError: neither an orientation nor a file, or a recorded sample outside the
            joint limits (the message names the file).
    """
    config = config or InverseDataConfig()
    if demo_csv is not None:
        demo = load_demo_csv(demo_csv, robot.n_dof, config.n_demo_steps)
        outside = ~robot.within_limits(torch.from_numpy(demo.q)).numpy()
        if outside.any():
            raise DemoFileError(
                f"{demo.source}: {int(outside.sum())} resampled sample(s) outside the {robot.name} joint limits"
            )
        return demo
    if orientation_deg is None:
        raise ValueError(
            "make_demonstration: give an orientation_deg for the scripted demonstration or a demo_csv file"
        )
    start = np.radians(np.asarray(config.start_deg, dtype=np.float64))
    goal_pose = make_transform(config.demo_goal, np.radians(np.asarray(orientation_deg, dtype=np.float64)))
    return scripted_demo(robot, start, goal_pose, config.duration, config.n_demo_steps, seed=config.seed)


# ---------------------------------------------------------------------------- augmentation
@dataclass(frozen=True)
class InverseData:
    """Training pairs of one task's inverse model.

    Attributes:
        demo: the demonstration (kept in the model checkpoint).
        goals: ``(G, 3)`` goal position (m) of each path; row 0 is the demonstration.
        t: ``(N,)`` sample times (s) shared by all paths.
        q: ``(G, N, n)`` joint positions (rad) along each followed path.
        errors: ``(G, N, 3)`` inputs ``x_e - goal`` (m).
        velocities: ``(G, N, n)`` targets (rad/s).
        n_failed: augmentation goals dropped because IK found no solution.
    """

    demo: JointDemonstration
    goals: np.ndarray
    t: np.ndarray
    q: np.ndarray
    errors: np.ndarray
    velocities: np.ndarray
    n_failed: int


def build_inverse_data(
    robot, demo: JointDemonstration, config: InverseDataConfig | None = None
) -> InverseData:
    """Training paths of one task's inverse model (settings: :class:`InverseDataConfig`).

    ``config.n_goals`` goals are drawn uniformly in a box of half-widths ``goal_spread`` (m)
    around the demonstration's end point, each with the demonstration's final orientation
    (IK nearest the demonstrated final configuration; goals without a solution are dropped
    and counted). Paths, all followed with :func:`~lfd.sim.trajectory.follow_paths`:

    * the demonstration itself (row 0);
    * per goal, the demonstration warped to it by a polynomial blend of order
      ``orders[k % len(orders)]`` (:func:`~lfd.sim.trajectory.warp_to_goals`): the approach
      from the start;
    * per goal (the demonstration's included), ``cross_paths`` straight joint-space paths
      from the configuration of another, random goal. Without them every path near a goal
      arrives from the start's side, the errors near the goals span one direction only and
      the learned map cannot correct errors in the others.
    """
    c = config or InverseDataConfig()
    end_pose = robot.fk(torch.from_numpy(demo.q[-1:]))[0].numpy()
    rng = np.random.default_rng(c.seed)
    offsets = rng.uniform(-1.0, 1.0, size=(c.n_goals, 3)) * np.asarray(c.goal_spread, dtype=np.float64)
    poses = np.repeat(end_pose[None], c.n_goals, axis=0)
    poses[:, :3, 3] += offsets
    solution = solve_near(robot, poses, demo.q[-1], n_seeds=c.n_seeds, seed=c.seed)
    ok = solution.success.numpy()
    goal_q = np.concatenate([demo.q[-1:], solution.q.numpy()[ok]])
    order_list = [c.orders[k % len(c.orders)] for k in range(len(goal_q))]
    paths = [warp_to_goals(demo.q, goal_q, order_list)]
    ends = [goal_q]
    if len(goal_q) > 1:
        for _ in range(c.cross_paths):
            origin = (np.arange(len(goal_q)) + rng.integers(1, len(goal_q), len(goal_q))) % len(
                goal_q
            )  # never the goal itself
            p = np.linspace(0.0, 1.0, demo.q.shape[0])[None, :, None]
            paths.append(goal_q[origin][:, None] + p * (goal_q - goal_q[origin])[:, None])
            ends.append(goal_q)
    t, q, qd = follow_paths(np.concatenate(paths), c.time_constant, c.dt, c.n_steps)
    goals = robot.fk_positions(np.concatenate(ends)).numpy()
    errors = robot.fk_positions(q).numpy() - goals[:, None, :]
    return InverseData(
        demo=demo, goals=goals, t=t, q=q, errors=errors, velocities=qd, n_failed=int((~ok).sum())
    )
